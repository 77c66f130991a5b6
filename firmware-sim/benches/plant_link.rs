//! The plant link's own cost: steps of a plant that does nothing (`NullPlant`, 2 observations,
//! 2 actions), in process and through the link to `firmware-sim serve-plant --null 2,2` as a
//! child process (a request and an answer framed, written to a pipe, read by a reader thread,
//! decoded, checked), and the same for navigation's plant (`serve-plant --scenario nav-walls`).
//!
//! - `plant_link/null/in-process`, `plant_link/null/child-process`;
//! - `plant_link/nav-walls/in-process`, `plant_link/nav-walls/child-process`.
//!
//! Throughput is in steps. The difference per step between a pair is what the link adds to each
//! environment step of a training run (docs/performance.md, "The plant link").
//! `cargo bench -p firmware-sim --bench plant_link`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use firmware_sim::env::Env;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::NavEnv;
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
use firmware_sim::plant_link::null::NullPlant;

/// Steps per measured iteration: one episode of either plant.
const STEPS: u64 = 200;

/// One episode under a fixed action sequence; the sum of the observations, so nothing is
/// optimised away.
fn episode(env: &mut dyn Env, seed: u64) -> f32 {
    let mut sum = env.reset(seed).iter().sum::<f32>();
    for i in 0..STEPS {
        let a = ((i % 7) as f32 - 3.0) / 12.0;
        let step = env.step(&[a, -a]);
        sum += step.observation.iter().sum::<f32>();
        if step.terminated || step.truncated {
            env.reset(seed + i);
        }
    }
    sum
}

fn bench_pair(c: &mut Criterion, name: &str, mut local: Box<dyn Env>, serve: &str) {
    let command = format!("{} serve-plant {serve}", env!("CARGO_BIN_EXE_firmware-sim"));
    let mut child = ChildPlant::spawn(&command, Timeouts::default()).expect("the plant starts");
    let mut group = c.benchmark_group(format!("plant_link/{name}"));
    group.throughput(Throughput::Elements(STEPS));
    let mut seed = 0;
    group.bench_function("in-process", |b| {
        b.iter(|| {
            seed += 1;
            episode(local.as_mut(), seed)
        })
    });
    group.bench_function("child-process", |b| {
        b.iter(|| {
            seed += 1;
            episode(&mut child, seed)
        })
    });
    group.finish();
    assert!(Env::failure(&child).is_none(), "the plant failed");
}

fn plant_link(c: &mut Criterion) {
    bench_pair(c, "null", Box::new(NullPlant::new(2, 2)), "--null 2,2");
    let mut scenario = Scenario::builtin("nav-walls").expect("builtin");
    scenario.reward = firmware_sim::nav::Reward::Gr;
    let nav = NavEnv::new(&scenario).expect("plant");
    bench_pair(
        c,
        "nav-walls",
        Box::new(nav),
        "--scenario nav-walls --reward gr",
    );
}

criterion_group!(benches, plant_link);
criterion_main!(benches);
