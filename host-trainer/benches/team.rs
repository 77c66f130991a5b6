//! A badminton team's training throughput: one point (played and learnt) per iteration, for a
//! team of 16 players of DDPG, DCP with T = 1, 4 and 16, and PPO, each first trained for 1,500
//! points so that every learner is past its warm-up and updating on every transition. The
//! teams run one after the other in the same process, so their ratios compare.
//!
//! `cargo bench -p host-trainer --bench team`; criterion reports the time per point, and as its
//! throughput, points per second. A point's cost grows with its rally (every hit is a
//! transition, and each transition one update of its learner), so the figure holds for teams
//! at this stage of training; `host-trainer team` prints the points per second of a whole run.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use firmware_sim::badminton::{self, Badminton};
use host_trainer::algorithms::Algo;
use host_trainer::team::config::TeamConfig;
use host_trainer::team::training::Team;

/// A team of 16 of `algo` (DCP with `t` proposals) after `warm` points of training.
fn trained(algo: Algo, t: usize, warm: usize) -> (Team, TeamConfig, Badminton) {
    let mut config = TeamConfig {
        algo,
        points: warm + 1_000_000,
        ..TeamConfig::default()
    };
    config.dcp.t = t;
    let plant = badminton::Config::builtin();
    let mut team = Team::new(&config, &plant).expect("team");
    let mut game = Badminton::new(&plant).expect("plant");
    for _ in 0..warm {
        team.play_point(&config, &mut game).expect("point");
    }
    (team, config, game)
}

fn points(c: &mut Criterion) {
    let mut group = c.benchmark_group("team_point");
    group.throughput(Throughput::Elements(1));
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(10));
    for (name, algo, t) in [
        ("ddpg", Algo::Ddpg, 16),
        ("dcp-t1", Algo::Dcp, 1),
        ("dcp-t4", Algo::Dcp, 4),
        ("dcp-t16", Algo::Dcp, 16),
        ("ppo", Algo::Ppo, 16),
    ] {
        let (mut team, config, mut game) = trained(algo, t, 1_500);
        group.bench_function(BenchmarkId::from_parameter(name), |b| {
            b.iter(|| team.play_point(&config, &mut game).expect("point"))
        });
    }
    group.finish();
}

criterion_group!(benches, points);
criterion_main!(benches);
