//! How fast the simulator runs, and whether the loop is dominated by inference.
//!
//! - `plant/nav-walls`, `plant/nav-open`: `NavEnv::step` alone (13 walls vs none), with a fixed
//!   cycle of actions that slides along walls and resets when an episode ends.
//! - `act/4x48`: the booted blob's `act` alone (policy-core's runtime model over the blob bytes).
//! - `loop/4x48/nav-walls`: whole test episodes of the firmware loop (sensor, timed `act`,
//!   actuator, plant, metrics), 200 ticks each.
//! - `loop/straight/nav-walls`: the same loop with a controller that costs nothing, i.e. the
//!   loop's own overhead.
//!
//! `cargo bench -p firmware-sim --bench loop_speed`; the numbers are in the README.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use firmware_sim::controller::{BlobPolicy, Controller};
use firmware_sim::env::Env;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::straight::Straight;
use firmware_sim::nav::test_protocol::{evaluate, evaluate_controller, EvalConfig};
use firmware_sim::nav::NavEnv;
use policy_core::{ActionBounds, Normalizer, Policy};

/// A 4×48 actor with fixed pseudo-random weights, as a blob.
fn blob_4x48() -> Vec<u8> {
    let mut p = Box::new(Policy::<2, 48, 3, 2>::ZERO);
    p.normalizer = Normalizer::identity(5.0);
    p.bounds = ActionBounds::symmetric(0.25);
    let mut state = 1u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32 * 0.4 - 0.2
    };
    p.input
        .w
        .iter_mut()
        .chain(p.input.b.iter_mut())
        .for_each(|v| *v = next());
    for layer in p.trunk.hidden.iter_mut() {
        layer
            .w
            .iter_mut()
            .chain(layer.b.iter_mut())
            .for_each(|v| *v = next());
    }
    p.trunk.output.w.iter_mut().for_each(|v| *v = next());
    p.to_blob("bench 4x48").expect("blob")
}

fn plant(c: &mut Criterion) {
    let mut group = c.benchmark_group("plant");
    group.throughput(Throughput::Elements(1));
    for name in ["nav-walls", "nav-open"] {
        let mut env = NavEnv::new(&Scenario::builtin(name).expect("builtin")).expect("env");
        let actions = [
            [-0.25f32, 0.2],
            [0.1, 0.25],
            [0.25, -0.05],
            [-0.2, -0.25],
            [0.0, 0.25],
        ];
        let (mut k, mut seed) = (0usize, 0u64);
        env.reset(seed);
        group.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % actions.len();
                let s = env.step(black_box(&actions[k]));
                if s.terminated || s.truncated {
                    seed += 1;
                    env.reset(seed);
                }
                s.reward
            })
        });
    }
    group.finish();
}

fn act(c: &mut Criterion) {
    let blob = blob_4x48();
    let mut policy = BlobPolicy::boot(&blob).expect("boot");
    let mut group = c.benchmark_group("act");
    group.throughput(Throughput::Elements(1));
    let mut out = [0.0f32; 2];
    group.bench_function("4x48", |b| {
        b.iter(|| {
            policy.act(black_box(&[2.5, -1.25]), &mut out);
            out
        })
    });
    group.finish();
}

fn closed_loop(c: &mut Criterion) {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let cfg = EvalConfig {
        episodes: 1,
        ..EvalConfig::default()
    };
    let blob = blob_4x48();
    let mut group = c.benchmark_group("loop");
    // Ticks per iteration as run (an episode that leaves the arena ends early).
    let ticks = evaluate(&blob, &s, &cfg).expect("eval").total_steps;
    group.throughput(Throughput::Elements(ticks));
    group.bench_function("4x48/nav-walls", |b| {
        b.iter(|| {
            evaluate(black_box(&blob), &s, &cfg)
                .expect("eval")
                .success_rate
        })
    });
    let ticks = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg)
        .expect("eval")
        .total_steps;
    group.throughput(Throughput::Elements(ticks));
    group.bench_function("straight/nav-walls", |b| {
        b.iter(|| {
            evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg)
                .expect("eval")
                .success_rate
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    targets = plant, act, closed_loop
}
criterion_main!(benches);
