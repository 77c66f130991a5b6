//! How fast the badminton plant runs (the aim: 1,000 points of scripted against
//! scripted in under a second on one core, so that training is bound by learning).
//!
//! - `badminton/physics-step`: one shuttle step (`Physics::step`) alone: physics steps per
//!   second.
//! - `badminton/points/scripted-vs-scripted`: 100 whole points from 0-0 with the same seed, the
//!   players' decisions included (the scripted serve solves its clear's speed on the plant's own
//!   physics): points per second. The physics steps those 100 points run are printed before
//!   the measurement, so steps per second inside a match follow from the same figure.
//!
//! `cargo bench -p firmware-sim --bench badminton_speed`; the numbers are in the README.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use firmware_sim::badminton::play::{play_match, Length};
use firmware_sim::badminton::reference::PlayerKind;
use firmware_sim::badminton::shuttle::{Physics, Shuttle};
use firmware_sim::badminton::Config;

const POINTS: u32 = 100;

fn physics_step(c: &mut Criterion) {
    let physics = Physics::of(&Config::builtin());
    let launch = Shuttle {
        p: [-2.0, 0.0, 1.2],
        v: [20.0, 3.0, 25.0],
    };
    let mut s = launch;
    let mut group = c.benchmark_group("badminton");
    group.throughput(Throughput::Elements(1));
    group.bench_function("physics-step", |b| {
        b.iter(|| {
            physics.step(black_box(&mut s));
            if s.p[2] <= 0.0 {
                s = launch;
            }
            s.p[2]
        })
    });
    group.finish();
}

fn points(c: &mut Criterion) {
    let config = Config::builtin();
    let kinds = [PlayerKind::Scripted, PlayerKind::Scripted];
    let play = || play_match(&config, &kinds, Length::Points(POINTS), 0, false, |_| {});
    let steps = play().expect("match").physics_steps;
    println!("badminton/points: {POINTS} points of scripted vs scripted run {steps} physics steps");
    let mut group = c.benchmark_group("badminton/points");
    group.throughput(Throughput::Elements(u64::from(POINTS)));
    group.sample_size(10);
    group.bench_function("scripted-vs-scripted", |b| {
        b.iter(|| play().expect("match").points)
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(5)).warm_up_time(Duration::from_secs(1));
    targets = physics_step, points
}
criterion_main!(benches);
