//! `host-trainer reproduce`: the quick grid of experiment 1 in two slices, merged; re-running
//! skips what finished; a failed run counts; bad input is one line and writes nothing.

use std::path::Path;

use host_trainer::reproduce::grid::{Experiment, Grid, Slice};
use host_trainer::reproduce::{folder, Part};

use crate::support::{
    assert_ok, assert_one_line, assert_one_line_error, command, entries, s, scratch,
};

fn reproduce(out: &Path, extra: &[&str]) -> std::process::Output {
    let mut c = command(&[
        "reproduce",
        "exp1",
        "--quick",
        "--seeds",
        "1",
        "--out",
        s(out),
        "--quiet",
    ]);
    c.args(extra).output().expect("reproduce runs")
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

const GRID: Grid = Grid {
    experiment: Experiment::Exp1,
    seeds: 1,
    quick: true,
};

#[test]
fn two_slices_merge_into_the_page_and_a_rerun_skips_what_finished() {
    let out = scratch("reproduce-slices");
    let total = GRID.runs().len();
    let first = reproduce(&out, &["--slice", "0/2", "--jobs", "2"]);
    assert_ok(&first);
    let half = GRID.slice(Slice { index: 0, count: 2 }).len();
    assert!(
        stdout(&first).contains(&format!(
            "part 0/2 of exp1 --seeds 1 --quick: {half} runs, {half} trained"
        )),
        "{}",
        stdout(&first)
    );
    assert_eq!(
        stdout(&first).matches("finished ").count(),
        half,
        "a line per run"
    );
    // Half the grid: the merge writes the page, lists the other half, and exits 1.
    let early = reproduce(&out, &["--merge"]);
    assert_eq!(early.status.code(), Some(1));
    assert_one_line(
        &early,
        &[&format!("{} of {total} runs are missing", total - half)],
    );
    let page = std::fs::read_to_string(out.join("exp1.md")).expect("page");
    assert_eq!(page.matches(" seed 0\n").count(), total - half);

    assert_ok(&reproduce(&out, &["--slice", "1/2", "--jobs", "2"]));
    let merged = reproduce(&out, &["--merge"]);
    assert_ok(&merged);
    let page = std::fs::read_to_string(out.join("exp1.md")).expect("page");
    for needle in [
        "## Table 1",
        "| dcp-paper | 6×64 | 1 / 0 / 0 |",
        "## Table 2",
        "| ddpg | LR+GR | 1 / 0 / 0 |",
        "## Table 3",
        "| td3 | 0.5 | ",
        "No verdict: a quick grid",
        "## Run time per agent",
        "figures/fig7-steps-to-goal.svg",
        "## Missing runs\n\nNone.",
        "| 0/2 | ",
        "| 1/2 | ",
    ] {
        assert!(page.contains(needle), "{needle:?} not in the page:\n{page}");
    }
    for figure in [
        "fig4-trajectories-walls.svg",
        "fig5-trajectories-open.svg",
        "fig6-settled-error.svg",
        "fig7-steps-to-goal.svg",
    ] {
        let svg = std::fs::read_to_string(out.join("figures").join(figure)).expect("figure");
        assert!(svg.starts_with("<svg"), "{figure}");
    }

    // The whole grid again: every run is skipped, the page is rebuilt.
    let again = reproduce(&out, &[]);
    assert_ok(&again);
    assert!(
        stdout(&again).contains(&format!(
            "{total} runs, 0 trained, {total} already finished, 0 failed"
        )),
        "{}",
        stdout(&again)
    );
    let parts = Part::all(&out);
    assert_eq!(parts.len(), 3, "parts 0/1, 0/2 and 1/2");
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn the_added_seeds_train_into_the_grids_cells_and_join_the_page() {
    let out = scratch("reproduce-added");
    let added = GRID.added_runs().len();
    assert_eq!(added, 36);
    // Before the grid: the added runs alone, recorded as their own part; the page says the
    // grid's runs are missing (exit 1) and the section counts the added ones in.
    let first = reproduce(&out, &["--added-seeds", "--jobs", "2"]);
    assert_eq!(first.status.code(), Some(1), "{}", stdout(&first));
    assert!(
        stdout(&first).contains(&format!(
            "the added seeds of exp1 --seeds 1 --quick: {added} runs, {added} trained"
        )),
        "{}",
        stdout(&first)
    );
    assert!(out.join("parts/added.json").is_file());
    // The cell folders hold them beside the grid's seed 0, which the grid then trains.
    assert!(out
        .join("runs/walls-4x48-lr-ddpg/nav-walls__ddpg__4")
        .is_dir());
    assert_ok(&reproduce(&out, &["--jobs", "2"]));
    let page = std::fs::read_to_string(out.join("exp1.md")).expect("page");
    for needle in [
        "## Claims 2 and 3 with the added seeds",
        "claim 3's with seeds 0–5",
        "36 of them in",
        "| added | ",
        "## Missing runs\n\nNone.",
    ] {
        assert!(page.contains(needle), "{needle:?} not in the page:\n{page}");
    }
    // Again: nothing to train.
    let again = reproduce(&out, &["--added-seeds"]);
    assert_ok(&again);
    assert!(
        stdout(&again).contains(&format!(
            "{added} runs, 0 trained, {added} already finished"
        )),
        "{}",
        stdout(&again)
    );
    // Experiment 2 has no added seeds; a merge or a slice does not go with them.
    let exp2 = command(&[
        "reproduce",
        "exp2",
        "--quick",
        "--seeds",
        "1",
        "--out",
        s(&out),
        "--added-seeds",
    ])
    .output()
    .expect("runs");
    assert_one_line_error(&exp2, &["exp2 has no added seeds"]);
    for other in [&["--merge"][..], &["--slice", "0/2"]] {
        let o = reproduce(&out, &[&["--added-seeds"][..], other].concat());
        assert_eq!(o.status.code(), Some(2), "{other:?}");
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn a_failed_run_counts_as_failed_in_the_tables() {
    let out = scratch("reproduce-failed");
    // A file where a run's folder goes: that run cannot start.
    let grid = Grid { seeds: 1, ..GRID };
    let victim = &grid.runs()[0];
    let cell = Grid::cell_dir(&out, &victim.cell);
    std::fs::create_dir_all(&cell).expect("cell");
    std::fs::write(cell.join("nav-walls__dcp__0"), "in the way").expect("write");
    let run = reproduce(&out, &["--jobs", "2"]);
    assert_eq!(
        run.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let page = std::fs::read_to_string(out.join("exp1.md")).expect("page");
    assert!(
        page.contains("| dcp | 2×32 | 0 / 1 / 0 | 0.00 (1 seed) |"),
        "the failed run's row:\n{page}"
    );
    let outcome = folder::outcome(&out, &grid, victim).expect("reads");
    assert!(matches!(outcome, folder::Outcome::Failed(_)), "{outcome:?}");
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn bad_input_is_one_line_and_writes_nothing() {
    let base = scratch("reproduce-bad");
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let o = s(&out);
    let missing = base.join("missing").join("deeper");
    for (args, needle, code) in [
        (vec!["exp3", "--out", o], "exp3", 2),
        (
            vec!["exp1", "--quick", "--out", o, "--jobs", "0"],
            "--jobs",
            2,
        ),
        (
            vec!["exp1", "--quick", "--out", o, "--slice", "2/2"],
            "slice 2 of 2",
            2,
        ),
        (
            vec!["exp1", "--quick", "--out", o, "--slice", "1-2"],
            "I/N",
            2,
        ),
        (
            vec!["exp1", "--quick", "--out", o, "--slice", "0/2", "--merge"],
            "--merge",
            2,
        ),
        (
            vec!["exp1", "--quick", "--out", o, "--seeds", "0"],
            "--seeds",
            2,
        ),
        (
            vec!["exp1", "--out", o, "--seeds", "3"],
            "at least 5 seeds",
            2,
        ),
        (
            vec!["exp1", "--quick", "--out", s(&missing)],
            "does not exist",
            2,
        ),
        (
            vec!["exp1", "--quick", "--out", o, "--merge"],
            "holds no grid",
            2,
        ),
    ] {
        let mut full = vec!["reproduce"];
        full.extend(args);
        let result = command(&full).output().expect("runs");
        assert_one_line_error(&result, &[needle]);
        assert_eq!(result.status.code(), Some(code), "{full:?}");
        assert!(
            entries(&out).is_empty(),
            "{full:?} left {:?}",
            entries(&out)
        );
    }
    assert!(!missing.exists());

    // A folder of another grid, and a run folder of other settings under a grid's name: refused
    // before anything is written.
    let grid_file = out.join(folder::GRID_FILE);
    std::fs::write(
        &grid_file,
        r#"{"experiment":"exp1","seeds":2,"quick":true}"#,
    )
    .expect("write");
    for extra in [vec![], vec!["--merge"]] {
        let mut full = vec!["reproduce", "exp1", "--quick", "--seeds", "1", "--out", o];
        full.extend(extra);
        let result = command(&full).output().expect("runs");
        assert_one_line_error(
            &result,
            &["exp1 --seeds 2 --quick", "not `exp1 --seeds 1 --quick`"],
        );
        assert_eq!(entries(&out), [folder::GRID_FILE]);
    }
    std::fs::remove_file(&grid_file).expect("remove");
    let cell = Grid::cell_dir(&out, &GRID.runs()[0].cell);
    let run = cell.join("nav-walls__dcp__0");
    std::fs::create_dir_all(&run).expect("run dir");
    let mut other = GRID.runs()[0].cell.config(true);
    other.episodes += 1;
    std::fs::write(run.join("config.toml"), other.to_toml()).expect("config");
    std::fs::write(run.join("checkpoint.postcard"), "x").expect("checkpoint");
    let result = reproduce(&out, &[]);
    assert_one_line_error(&result, &["episodes = 4 recorded, 3 in the sweep"]);
    assert_eq!(entries(&out), ["runs"], "no grid recorded, nothing run");
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn experiment_two_trains_its_teams_in_slices_and_measures_them() {
    let out = scratch("reproduce-exp2");
    let run = |extra: &[&str]| {
        let mut c = command(&[
            "reproduce",
            "exp2",
            "--quick",
            "--seeds",
            "1",
            "--out",
            s(&out),
            "--quiet",
        ]);
        c.args(extra).output().expect("reproduce runs")
    };
    assert_ok(&run(&["--slice", "1/2"]));
    let early = run(&["--merge"]);
    assert_eq!(early.status.code(), Some(1));
    assert_one_line(&early, &["3 of 5 runs are missing"]);
    assert_ok(&run(&["--slice", "0/2"]));
    assert_ok(&run(&["--merge"]));
    let page = std::fs::read_to_string(out.join("exp2.md")).expect("page");
    for needle in [
        "## Table 5: catch success",
        "| dcp-t16 | 1 of 1 |",
        "| scripted (reference) | – | 1.000 |",
        "## Table 6: serve error",
        "## Table 7",
        "## Table 4: team scores",
        "| ddpg | dcp-t16 | 1 |",
        "| ppo | scripted (reference) | 1 |",
        "| dcp-t4 | random (reference) | 1 |",
        "## Influence of T",
        "No verdict: a quick grid",
        "## Missing runs\n\nNone.",
    ] {
        assert!(page.contains(needle), "{needle:?} not in the page:\n{page}");
    }
    for figure in [
        "fig10-13-contributions.svg",
        "fig14-influence-of-t.svg",
        "fig15-catch-q-ddpg.svg",
        "fig16-serve-q-dcp-t16.svg",
    ] {
        assert!(out.join("figures").join(figure).is_file(), "{figure}");
    }
    let again = run(&[]);
    assert_ok(&again);
    assert!(
        stdout(&again).contains("5 runs, 0 trained, 5 already finished"),
        "{}",
        stdout(&again)
    );
    // A team folder of other settings under a grid team's name is refused.
    let team = out.join("teams").join("badminton__ppo__0");
    let config = team.join("config.toml");
    let text = std::fs::read_to_string(&config).expect("config");
    std::fs::write(&config, text.replace("points = 40", "points = 41")).expect("write");
    assert_one_line_error(&run(&[]), &[s(&team), "not the grid's setting"]);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// A second process of the same part is refused before any run starts, named as the part
/// already running on that grid (it was once "one train, export or sweep writes a folder at a
/// time", as if another command held the folder).
#[test]
fn a_second_process_of_the_same_part_is_refused() {
    let out = scratch("reproduce-lock");
    let part = out.join("parts").join("0-of-1");
    std::fs::create_dir_all(&part).expect("part dir");
    let held = host_trainer::run::lock::acquire(&part).expect("the lock");
    let refused = reproduce(&out, &[]);
    assert_one_line_error(
        &refused,
        &[
            "part 0/1 of this grid is already running there (host-trainer process",
            "wait for it or stop it",
        ],
    );
    assert!(!String::from_utf8_lossy(&refused.stderr).contains("train, export or sweep"));
    assert!(!out.join("runs").exists(), "no run started");
    drop(held);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// A damaged finished run once blocked the whole grid with "config file …/eval.json: …" and no
/// hint, and a success rate of 7.5 went into the tables; an unknown key in `grid.json` passed.
/// Each is now one line naming the run (or the record) and what to do.
#[test]
fn a_damaged_run_or_grid_record_is_named_with_the_way_out() {
    let out = scratch("reproduce-damaged");
    std::fs::write(
        out.join("grid.json"),
        r#"{"experiment": "exp1", "seeds": 1, "quick": true}"#,
    )
    .expect("grid");
    let victim = &GRID.runs()[0];
    let run = Grid::cell_dir(&out, &victim.cell).join("nav-walls__dcp__0");
    std::fs::create_dir_all(&run).expect("run");
    let run_name = run.display().to_string();

    std::fs::write(run.join("eval.json"), r#"{"scenario": "nav-w"#).expect("cut");
    let merged = reproduce(&out, &["--merge"]);
    assert_one_line_error(&merged, &[&run_name, "damaged", "eval.json", "remove"]);
    assert!(!String::from_utf8_lossy(&merged.stderr).contains("config file"));

    let edited = r#"{"success_rate": 7.5, "stuck_rate": 0.0, "mean_error": 0.1}"#;
    std::fs::write(run.join("eval.json"), edited).expect("edited");
    let merged = reproduce(&out, &["--merge"]);
    assert_one_line_error(&merged, &[&run_name, "success_rate = 7.5", "remove"]);
    assert!(!out.join("exp1.md").exists(), "no page from a damaged run");

    std::fs::remove_dir_all(&run).expect("remove the run");
    std::fs::write(
        out.join("grid.json"),
        r#"{"experiment": "exp1", "seeds": 1, "quick": true, "quik": false}"#,
    )
    .expect("grid");
    let merged = reproduce(&out, &["--merge"]);
    assert_one_line_error(&merged, &["grid.json", "not a grid record", "quik"]);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// The whole grid and `--slice 0/2` on one `--out` at once were not refused (each part locks
/// only its own folder), so both trained the same runs. A part whose runs overlap a running
/// part's is refused naming it; a part that shares no run with it goes ahead.
#[test]
fn a_part_overlapping_a_running_part_is_refused() {
    let out = scratch("reproduce-overlap");
    let whole = out.join("parts").join("0-of-1");
    std::fs::create_dir_all(&whole).expect("part dir");
    let held = host_trainer::run::lock::acquire(&whole).expect("the lock");
    let refused = reproduce(&out, &["--slice", "0/2"]);
    assert_one_line_error(&refused, &["part 0/1", "shares runs with part 0/2"]);
    assert!(!out.join("runs").exists(), "no run started");
    drop(held);

    let half = out.join("parts").join("0-of-2");
    std::fs::create_dir_all(&half).expect("part dir");
    let held = host_trainer::run::lock::acquire(&half).expect("the lock");
    // Slice 1/56 holds odd runs only, none of slice 0/2's.
    assert_ok(&reproduce(&out, &["--slice", "1/56"]));
    drop(held);
    std::fs::remove_dir_all(&out).expect("cleanup");
}
