use firmware_sim::env::Env;
use firmware_sim::nav::reference::reference;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use firmware_sim::nav::NavEnv;

use crate::util::random_blob;

fn noisy_config(seed: u64) -> EvalConfig {
    let mut cfg = EvalConfig {
        episodes: 8,
        seed,
        record_trajectories: true,
        ..EvalConfig::default()
    };
    cfg.sensor.noise_std = 0.02;
    cfg.sensor.quantum = 0.01;
    cfg.sensor.delay = true;
    cfg.faults = "dropout-stale:0.1,wall:60@-2/-2/2/-2"
        .parse()
        .expect("faults");
    cfg
}

#[test]
fn same_seed_gives_the_same_report_bit_for_bit() {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let blob = random_blob::<48, 3>(5, "determinism");
    let a = evaluate(&blob, &s, &noisy_config(11))
        .expect("eval")
        .without_timing();
    let b = evaluate(&blob, &s, &noisy_config(11))
        .expect("eval")
        .without_timing();
    assert_eq!(a, b);
    let ja = serde_json::to_vec(&a).expect("json");
    assert_eq!(ja, serde_json::to_vec(&b).expect("json"));
    let c = evaluate(&blob, &s, &noisy_config(12))
        .expect("eval")
        .without_timing();
    assert_ne!(
        a.episodes, c.episodes,
        "a different seed must give different starts"
    );
}

#[test]
fn same_seed_gives_the_same_plant_trajectory() {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let run = || {
        let mut env = NavEnv::new(&s).expect("env");
        let mut oracle = reference("oracle", &s).expect("oracle");
        let mut obs = env.reset(42);
        let mut out = vec![obs.clone()];
        let mut a = [0.0f32; 2];
        for _ in 0..200 {
            oracle.act(&obs, &mut a);
            let step = env.step(&a);
            obs = step.observation;
            out.push(obs.clone());
            if step.terminated || step.truncated {
                break;
            }
        }
        out
    };
    let (x, y) = (run(), run());
    let bits = |v: &Vec<Vec<f32>>| v.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&x), bits(&y));
}
