//! A golden trajectory of the nav-walls plant in process, committed in
//! `tests/data/plant-link-trajectory.json`: for each episode its seed, then for each step the
//! action and what the plant answered (observations, rewards and applied motions as `f32`
//! bits). The Python package replays the same actions through the plant link
//! (`python/tests/test_trajectory.py`: FirmwareSimEnv over `firmware-sim serve-plant`) and must
//! get the same bits, so a Gymnasium user trains on exactly the plant host-trainer trains on.
//! `UPDATE_GOLDEN=1` rewrites the file.
//!
//! The actions head for the centre until the walls stop them, send one action far outside the
//! box and one NaN (both carried out as the plant's saturation says), slide along, leave the
//! arena (a terminal step), step past an episode's end, and run one episode to its time limit.

use firmware_sim::env::Env;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::NavEnv;
use serde_json::{json, Value};

const GOLDEN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/plant-link-trajectory.json"
);

const MAX_STEP: f32 = 0.25;

/// A JSON array of the golden file's (it is written by this file: arrays where expected).
fn array(v: &Value) -> &Vec<Value> {
    v.as_array().expect("an array")
}

fn bits(values: &[f32]) -> Value {
    values.iter().map(|v| v.to_bits()).collect()
}

/// One episode's actions, from its start `s`: toward the centre, then the odd ones.
fn actions(s: &[f32], steps: usize) -> Vec<[f32; 2]> {
    let n = (s[0] * s[0] + s[1] * s[1]).sqrt();
    let inward = [-s[0] / n * MAX_STEP, -s[1] / n * MAX_STEP];
    let along = [-inward[1], inward[0]];
    (0..steps)
        .map(|i| match i {
            0..=39 => inward,
            40 => [12.0 * inward[0], -7.5],
            41 => [f32::NAN, MAX_STEP],
            42..=54 => along,
            _ => [0.0, if i % 2 == 0 { MAX_STEP } else { -MAX_STEP }],
        })
        .collect()
}

/// Straight out of the arena from the start, past the end of the episode.
fn leaving(s: &[f32]) -> Vec<[f32; 2]> {
    vec![[s[0] * 10.0, s[1] * 10.0]; 4]
}

fn episode(env: &mut NavEnv, seed: u64, plan: impl Fn(&[f32]) -> Vec<[f32; 2]>) -> Value {
    let start = env.reset(seed);
    let steps: Vec<Value> = plan(&start)
        .iter()
        .map(|action| {
            let s = env.step(action);
            json!({
                "action": bits(action),
                "observation": bits(&s.observation),
                "reward": s.reward.to_bits(),
                "terminated": s.terminated,
                "truncated": s.truncated,
                "margin_touched": s.info.margin_touched,
                "applied": bits(&s.info.applied),
                "success": s.info.success,
            })
        })
        .collect();
    json!({"seed": seed, "observation": bits(&start), "steps": steps})
}

fn golden() -> Value {
    let scenario = Scenario::builtin("nav-walls").expect("a built-in scenario");
    let mut env = NavEnv::new(&scenario).expect("nav-walls builds");
    let episodes = vec![
        episode(&mut env, 0, |s| actions(s, 60)),
        episode(&mut env, 1, |s| actions(s, 60)),
        episode(&mut env, 2, |s| actions(s, 60)),
        episode(&mut env, 3, leaving),
        episode(&mut env, 4, |s| actions(s, 203)),
    ];
    json!({
        "about": "nav-walls in process under fixed actions: f32 values as their bits; written by \
                  firmware-sim's tests/plant_link_trajectory.rs with UPDATE_GOLDEN=1",
        "scenario": "nav-walls",
        "episodes": episodes,
    })
}

/// The file as JSON with one line per step, so a diff shows which step changed.
fn to_text(golden: &Value) -> String {
    let mut out = String::from("{\n");
    for key in ["about", "scenario"] {
        out += &format!("  \"{key}\": {},\n", golden[key]);
    }
    out += "  \"episodes\": [\n";
    let episodes = array(&golden["episodes"]);
    for (e, episode) in episodes.iter().enumerate() {
        out += &format!(
            "    {{\"seed\": {}, \"observation\": {}, \"steps\": [\n",
            episode["seed"], episode["observation"]
        );
        let steps = array(&episode["steps"]);
        for (i, step) in steps.iter().enumerate() {
            let comma = if i + 1 < steps.len() { "," } else { "" };
            out += &format!("      {step}{comma}\n");
        }
        let comma = if e + 1 < episodes.len() { "," } else { "" };
        out += &format!("    ]}}{comma}\n");
    }
    out + "  ]\n}\n"
}

#[test]
fn trajectory_equals_the_committed_golden_file() {
    let fresh = golden();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(GOLDEN, to_text(&fresh)).expect("write the golden file");
    }
    let text = std::fs::read_to_string(GOLDEN).expect(
        "the golden file (UPDATE_GOLDEN=1 cargo test -p firmware-sim --test integration plant_link)",
    );
    let committed: Value = serde_json::from_str(&text).expect("the golden file is JSON");
    assert_eq!(
        committed, fresh,
        "nav-walls moved differently; if on purpose, run with UPDATE_GOLDEN=1"
    );
}

/// The trajectory is only worth checking across the link if it reaches the plant's corners.
#[test]
fn trajectory_touches_walls_clips_and_ends_every_way() {
    let golden = golden();
    let steps: Vec<&Value> = array(&golden["episodes"])
        .iter()
        .flat_map(|e| array(&e["steps"]))
        .collect();
    let flag = |key: &str| steps.iter().filter(|s| s[key] == json!(true)).count();
    let in_box = |b: &Value| {
        let a = f32::from_bits(
            b.as_u64()
                .and_then(|b| u32::try_from(b).ok())
                .expect("f32 bits"),
        );
        a.abs() <= MAX_STEP // false for NaN too
    };
    let outside = steps
        .iter()
        .filter(|s| !array(&s["action"]).iter().all(in_box))
        .count();
    assert!(flag("margin_touched") >= 10, "walls touched");
    assert!(flag("terminated") >= 1 && flag("truncated") >= 1);
    assert!(flag("success") >= 1, "some episode settles near the centre");
    assert!(outside >= 3, "actions outside the box and NaN");
}
