//! The main job's page from a queue's folders: rows as the runs left them, and the aims judged
//! only once every line is in.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use host_trainer::run::race::{RaceRecord, RacerRecord};
use host_trainer::run::validation::Round;
use studies::main_job::{load, read_record, record_row, render, Test};

/// A finished race's `race.json`, as `train` writes it: won by racer 1 for `why`, its racers'
/// (seed, episodes trained, the settled error of the round kept).
fn race_json(why: &str, racers: &[(u64, usize, Option<f64>)]) -> String {
    let racer = |&(seed, episodes, kept): &(u64, usize, Option<f64>)| RacerRecord {
        seed,
        folder: format!("racers/nav-walls__dcp__{seed}"),
        ending: None,
        episodes,
        validation: vec![],
        kept: kept.map(|error| Round {
            episode: episodes - 10,
            error: Some(error),
            ..Round::default()
        }),
    };
    let record = RaceRecord {
        base_seed: 0,
        config_toml: String::new(),
        racers: racers.iter().map(racer).collect(),
        winner: Some(1),
        why: why.into(),
    };
    serde_json::to_string(&record).expect("json")
}

/// A finished line: its parts, `done`, and a run folder with an `eval.json` (and a `race.json`
/// for a race won by racer `winner` at episode 1,600, or run to its budget).
fn line(runs: &Path, name: &str, (success, error, stuck): (f64, f64, f64), race: Option<bool>) {
    let dir = runs.join(name);
    let run = dir.join("nav-walls__dcp__0");
    std::fs::create_dir_all(&run).expect("run folder");
    std::fs::write(dir.join("parts.txt"), "1 130 100.5 90 1\n2 0 50.5 45 1\n").expect("parts");
    std::fs::write(dir.join("done"), "0\n").expect("done");
    let eval = format!(
        r#"{{"success_rate": {success}, "mean_error": {error}, "stuck_rate": {stuck}, "pass": {{"passed": {}, "failures": []}}}}"#,
        success >= 0.8 && stuck <= 0.2
    );
    std::fs::write(run.join("eval.json"), eval).expect("eval");
    if let Some(early) = race {
        let why = if early {
            "racer 1 (seed 9) was the first whose validation met the criteria"
        } else {
            "no racer's validation met the criteria"
        };
        let json = race_json(why, &[(0, 1600, None), (9, 1600, None)]);
        std::fs::write(run.join("race.json"), json).expect("race");
    }
}

/// A finished line that delivers (success 1.00, settled error 0.2), of one part taking `wall`
/// seconds of wall and CPU time.
fn timed(runs: &Path, name: &str, race: Option<bool>, wall: u32) {
    line(runs, name, (1.0, 0.2, 0.0), race);
    std::fs::write(
        runs.join(name).join("parts.txt"),
        format!("1 0 {wall} {wall} 0\n"),
    )
    .expect("parts");
}

/// Plan lines `KIND-S --seed S` for base seeds `seeds`.
fn plan_lines(kind: &str, seeds: std::ops::Range<u64>) -> String {
    seeds.map(|s| format!("{kind}-{s} --seed {s}\n")).collect()
}

/// A fresh scratch folder for one test: `(folder, its runs/ folder, its plan file)`.
fn scratch(name: &str) -> (PathBuf, PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let runs = dir.join("runs");
    std::fs::create_dir_all(&runs).expect("runs");
    let plan = dir.join("plan.txt");
    (dir, runs, plan)
}

/// The plan lines of the 20 pinwheel base seeds.
fn pinwheel_lines() -> String {
    (0..20)
        .map(|s| format!("pinwheel-{s} --seed {s}\n"))
        .collect()
}

#[test]
fn the_page_shows_every_line_and_judges_only_a_complete_queue() {
    let (dir, runs, plan) = scratch("main-job-page");
    let mut text = String::from("# a comment\ntoday-0 --seed 0 --race 1\n");
    text.push_str(&pinwheel_lines());
    std::fs::write(&plan, &text).expect("plan");
    line(&runs, "today-0", (1.0, 1.196, 0.46), None);
    line(&runs, "pinwheel-0", (1.0, 0.303, 0.0), Some(true));
    line(&runs, "pinwheel-1", (1.0, 0.7, 0.3), Some(false));
    let today: BTreeMap<u64, Test> = [(0, (1.0, 1.196, 0.46)), (1, (1.0, 0.673, 0.42))]
        .into_iter()
        .map(|(s, (success, error, stuck))| {
            (
                s,
                Test {
                    success,
                    error,
                    stuck,
                    passed: false,
                },
            )
        })
        .collect();
    let lines = load(&plan, &runs, &BTreeMap::new()).expect("loads");
    assert_eq!(lines.len(), 21);
    assert!((lines[1].wall() - 151.0).abs() < 1e-9 && (lines[1].cpu() - 137.0).abs() < 1e-9);
    let page = render(&lines, &today, "abc1234", "a test machine");
    assert!(page.contains("| 0 | 1, 9 | 1600 | validation | 1.00 | 0.303 | 0.00 | yes | PASS | 151 | 137 | 2 | 1.00, 1.196, no |"), "{page}");
    assert!(
        page.contains("| 1 | 1, 9 | 1600 | budget | 1.00 | 0.700 | 0.30 | no | FAIL |"),
        "{page}"
    );
    assert!(page.contains("| 2 | – | – | – | not started |"), "{page}");
    assert!(
        page.contains("| 0 | 1.00 | 1.196 | 0.46 | the same | 151 | 137 | 2 |"),
        "{page}"
    );
    assert!(
        page.contains("1 of the 2 pinwheel base seeds in deliver"),
        "{page}"
    );
    assert!(
        page.contains("Not judged yet: 2 of 20 base seeds are in"),
        "{page}"
    );
    assert!(page.contains("a ratio of 1.00"), "{page}");
    assert!(
        !page.contains("Verdict"),
        "nothing is judged before every line is in: {page}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The record keeps what the page needs of a finished line: the page rebuilt from the record
/// alone (the folders gone, as on another machine) shows the same rows, and names the commit
/// and machine each line ran on.
#[test]
fn a_page_rebuilt_from_the_record_shows_the_rows_the_folders_gave() {
    let (dir, runs, plan) = scratch("main-job-record");
    std::fs::write(
        &plan,
        "today-0 --seed 0 --race 1\npinwheel-0 --seed 0\npinwheel-1 --seed 1\nrings-0 --seed 0\n",
    )
    .expect("plan");
    line(&runs, "today-0", (1.0, 1.196, 0.46), None);
    line(&runs, "pinwheel-0", (1.0, 0.303, 0.0), Some(true));
    line(&runs, "pinwheel-1", (0.97, 0.7123, 0.03), Some(false));
    let today = BTreeMap::new();
    let from_folders = load(&plan, &runs, &BTreeMap::new()).expect("loads");
    let page = render(&from_folders, &today, "abc1234", "machine A");

    let record = dir.join("record.tsv");
    let mut text = String::from("# a comment\n");
    for l in &from_folders {
        if let Some(row) = record_row(l, "abc1234", "machine A") {
            text.push_str(&row);
            text.push('\n');
        }
    }
    assert_eq!(
        text.lines().count(),
        4,
        "three finished lines and the comment: {text}"
    );
    std::fs::write(&record, &text).expect("record");
    std::fs::remove_dir_all(&runs).expect("folders gone");
    let kept = read_record(&record).expect("reads");
    let from_record = load(&plan, &runs, &kept).expect("loads");
    let rebuilt = render(&from_record, &today, "def5678", "machine B");
    let rows = |p: &str| -> Vec<String> {
        p.lines()
            .filter(|l| l.starts_with("| "))
            .map(str::to_string)
            .collect()
    };
    assert_eq!(rows(&page), rows(&rebuilt));
    assert!(
        rebuilt.contains(
            "Measured with the binary of commit abc1234 on machine A (today 0; pinwheel 0–1)."
        ),
        "{rebuilt}"
    );

    // A bad row is an error that names the file, the line and the column.
    std::fs::write(
        &record,
        "pinwheel-0\tabc\tm\t1\t1.0\tx\t1\t0.1\t0\tPASS\t-\t-\t-\t-\t-\n",
    )
    .expect("bad record");
    let err = format!("{:#}", read_record(&record).expect_err("refused"));
    assert!(err.contains("line 1: cpu_s \"x\" is not a number"), "{err}");
    // The kept round's validation error is "-" or a number, nothing else.
    std::fs::write(
        &record,
        "every-10-0\tabc\tm\t1\t1.0\t1.0\t1\t0.1\t0\tPASS\t1\t9\t40\tvalidation\tabout 0.2\n",
    )
    .expect("bad record");
    let err = format!("{:#}", read_record(&record).expect_err("refused"));
    assert!(
        err.contains("line 1: kept_validation_error \"about 0.2\" is not a number"),
        "{err}"
    );
    std::fs::write(&record, "pinwheel-0\tabc\n").expect("short record");
    let err = format!("{:#}", read_record(&record).expect_err("refused"));
    assert!(err.contains("expected 15 tab-separated columns"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The amendment's candidate is judged by the same aims against the single runs timed in its
/// own queue, shown beside the defaults' line of each base seed, and adopted only once every
/// line is in and both aims are met.
#[test]
fn the_amendment_judges_its_candidate_against_its_own_single_runs() {
    let (dir, runs, plan) = scratch("main-job-amendment");
    let mut text = String::from("today-0 --seed 0\ntoday-1 --seed 1\n");
    text.push_str(&pinwheel_lines());
    text.push_str("single-0 --seed 0\nsingle-1 --seed 1\n");
    for s in 0..20 {
        text.push_str(&format!(
            "first-round-{s} --seed {s} --config first-round.toml\n"
        ));
    }
    std::fs::write(&plan, &text).expect("plan");
    line(&runs, "pinwheel-3", (1.0, 0.2, 0.0), Some(true));
    for s in 0..2 {
        let name = format!("single-{s}");
        line(&runs, &name, (1.0, 1.196, 0.46), None);
        // Today's single run took 400 s in this queue: the candidate's 151 s lines are below half.
        std::fs::write(runs.join(&name).join("parts.txt"), "1 0 400 390 2\n").expect("parts");
    }
    for s in 0..19 {
        line(
            &runs,
            &format!("first-round-{s}"),
            (1.0, 0.2, 0.0),
            Some(true),
        );
    }
    let today = BTreeMap::new();
    let rendered = || {
        render(
            &load(&plan, &runs, &BTreeMap::new()).expect("loads"),
            &today,
            "abc1234",
            "a test machine",
        )
    };
    let page = rendered();
    assert!(
        page.contains("maze 0 of 0, first-round 19 of 20, single 2 of 2."),
        "{page}"
    );
    assert!(
        page.contains("| 3 | 1, 9 | 1600 | validation | 1.00 | 0.200 | 0.00 | yes | PASS | 151 | 137 | 2 | 1600, yes |"),
        "the defaults' line of the same base seed beside the candidate's: {page}"
    );
    assert!(
        page.contains("| 0 | 1.00 | 1.196 | 0.46 | – | 400 | 392 | 1 |"),
        "{page}"
    );
    assert!(
        page.contains("19 of the 19 first-round base seeds in deliver"),
        "{page}"
    );
    assert!(
        page.contains("a median ratio of 0.38 over 19 lines (range 0.38–0.38; 19 at most 0.5). Seeds 0–9 (10 in) on a test machine: median 151 s against 400 s for `single-0`, 0.38. Seeds 10–19 (9 in) on a test machine: median 151 s against 400 s for `single-1`, 0.38. Pooled as first worded: median 151 s against 400 s, 0.38."),
        "{page}"
    );
    assert!(
        page.contains("Not decided yet"),
        "one line is missing: {page}"
    );
    assert!(!page.contains("adopted"), "{page}");

    line(&runs, "first-round-19", (0.95, 0.3, 0.0), Some(true));
    let adopted = "By the amendment's rule the candidate is **adopted**";
    assert!(rendered().contains(adopted), "{}", rendered());

    // One candidate line that does not deliver still meets aim 1 (19 of 20); a second does not.
    line(&runs, "first-round-18", (0.8, 0.3, 0.0), Some(true));
    assert!(rendered().contains(adopted), "{}", rendered());
    line(&runs, "first-round-17", (1.0, 0.6, 0.0), Some(true));
    let page = rendered();
    assert!(
        page.contains("By the amendment's rule the candidate is **not adopted**"),
        "{page}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_amendment_times_each_half_against_its_own_single_run() {
    let (dir, runs, plan) = scratch("main-job-halves");
    let mut text = String::from("single-0 --seed 0\n");
    text.push_str(&plan_lines("first-round", 0..10));
    text.push_str("single-1 --seed 1\n");
    text.push_str(&plan_lines("first-round", 10..20));
    std::fs::write(&plan, &text).expect("plan");
    // A slow machine ran the first half, a fast one the second: each half's lines took just
    // under and just over half of their own single run, while the pooled medians give exactly
    // one half.
    timed(&runs, "single-0", None, 800);
    timed(&runs, "single-1", None, 300);
    for s in 0..20 {
        timed(
            &runs,
            &format!("first-round-{s}"),
            Some(true),
            if s < 10 { 390 } else { 160 },
        );
    }
    let mut lines = load(&plan, &runs, &BTreeMap::new()).expect("loads");
    for l in lines
        .iter_mut()
        .filter(|l| l.name == "single-0" || (l.name.starts_with("first-round") && l.seed < 10))
    {
        l.origin = Some(("c0ffee1".into(), "a slow machine".into()));
    }
    let page = render(&lines, &BTreeMap::new(), "abc1234", "a fast machine");
    assert!(
        page.contains("a median ratio of 0.51 over 20 lines (range 0.49–0.53; 10 at most 0.5). Seeds 0–9 (10 in) on a slow machine: median 390 s against 800 s for `single-0`, 0.49. Seeds 10–19 (10 in) on a fast machine: median 160 s against 300 s for `single-1`, 0.53. Pooled as first worded (mixing 2 machines, so not what is judged): median 275 s against 550 s, 0.50."),
        "{page}"
    );
    assert!(
        page.contains("Verdict: the aim (a median ratio at most 0.5) is **not met**; 1 line whose ratio crossed 0.5 would flip it."),
        "{page}"
    );
    assert!(
        page.contains("By the amendment's rule the candidate is **not adopted**"),
        "{page}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The second amendment's candidate is timed against its own single runs (`single-2` and
/// `single-3`, not the first amendment's), and its rows show the first candidate's end and the
/// settled error of the validation round whose policy the winner handed over.
#[test]
fn the_second_amendment_has_its_own_single_runs_and_shows_the_kept_round() {
    let (dir, runs, plan) = scratch("main-job-second");
    let mut text = String::from("pinwheel-3 --seed 3\nsingle-0 --seed 0\nsingle-1 --seed 1\nfirst-round-3 --seed 3\nsingle-2 --seed 2\n");
    text.push_str(&plan_lines("every-10", 0..10));
    text.push_str("single-3 --seed 3\n");
    text.push_str(&plan_lines("every-10", 10..20));
    std::fs::write(&plan, &text).expect("plan");
    line(&runs, "pinwheel-3", (1.0, 0.2, 0.0), Some(true));
    line(&runs, "first-round-3", (1.0, 0.2, 0.0), Some(true));
    // The first amendment's single runs took far longer: they must not time this candidate.
    timed(&runs, "single-0", None, 4000);
    timed(&runs, "single-1", None, 4000);
    timed(&runs, "single-2", None, 400);
    timed(&runs, "single-3", None, 500);
    for s in 0..20 {
        timed(&runs, &format!("every-10-{s}"), Some(true), 100);
    }
    let race = race_json(
        "racer 1 (seed 9) was the first whose validation met the criteria",
        &[(3, 700, None), (9, 700, Some(0.25))],
    );
    std::fs::write(runs.join("every-10-3/nav-walls__dcp__0/race.json"), race).expect("race");
    let lines = load(&plan, &runs, &BTreeMap::new()).expect("loads");
    let page = render(&lines, &BTreeMap::new(), "abc1234", "a test machine");
    assert!(
        page.contains("### The second amendment's candidate: the first round that meets the criteria, rounds every 10 episodes"),
        "{page}"
    );
    assert!(
        page.contains("| 3 | 1, 9 | 700 | validation | 1.00 | 0.200 | 0.00 | yes | PASS | 100 | 100 | 1 | 1600, yes | 1600 | 0.250 |"),
        "the defaults' and the first candidate's ends, and the kept round's error: {page}"
    );
    assert!(
        page.contains("Seeds 0–9 (10 in) on a test machine: median 100 s against 400 s for `single-2`, 0.25. Seeds 10–19 (10 in) on a test machine: median 100 s against 500 s for `single-3`, 0.20."),
        "{page}"
    );
    assert!(
        page.contains("By the amendment's rule the candidate is **adopted**"),
        "{page}"
    );

    // The record keeps the kept round's error.
    let every_3 = lines.iter().find(|l| l.name == "every-10-3").expect("line");
    let row = record_row(every_3, "abc1234", "a test machine").expect("finished");
    assert!(row.ends_with("\t700\tvalidation\t0.250000"), "{row}");
    let record = dir.join("record.tsv");
    std::fs::write(&record, format!("{row}\n")).expect("record");
    let kept = read_record(&record).expect("reads");
    assert_eq!(
        kept["every-10-3"].race.as_ref().and_then(|r| r.kept_error),
        Some(0.25)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
