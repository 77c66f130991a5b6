//! Training updates per second: one minibatch of 64, critic step + actor step + soft target
//! update, 4×48 actor and critic on the navigation shapes (2 observations, 2 actions).
//!
//! `cargo bench -p host-trainer --bench update`; criterion reports time per update and
//! (Throughput::Elements(1)) updates per second.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use host_trainer::agent::{self, Agent};
use host_trainer::dcp::{self, Dcp};
use host_trainer::ddpg::{self, Ddpg};
use host_trainer::replay::Transition;
use host_trainer::seed;

/// An agent with 10,000 random navigation transitions in its buffer.
fn agent() -> Agent {
    let config = agent::Config::default();
    let mut agent = Agent::new(
        config,
        2,
        &[-0.25; 2],
        &[0.25; 2],
        &mut seed::stream(0, "init"),
    )
    .expect("agent");
    let mut rng = seed::stream(0, "data");
    for _ in 0..10_000 {
        let mut draw = |scale: f32| scale * (2.0 * seed::uniform(&mut rng) - 1.0);
        let obs = vec![draw(6.0), draw(6.0)];
        let action = vec![draw(1.0), draw(1.0)];
        let next_obs = vec![obs[0] + 0.25 * action[0], obs[1] + 0.25 * action[1]];
        let reward = -(next_obs[0].hypot(next_obs[1])) / 6.0;
        agent.remember(&Transition {
            obs,
            action,
            reward,
            next_obs,
            terminal: false,
        });
    }
    agent
}

fn updates(c: &mut Criterion) {
    let mut group = c.benchmark_group("update_4x48_batch64");
    group
        .throughput(Throughput::Elements(1))
        .measurement_time(Duration::from_secs(5))
        .sample_size(30);
    let mut rngs = [
        seed::stream(1, "replay"),
        seed::stream(1, "dropout"),
        seed::stream(1, "proposals"),
    ];

    let ddpg = Ddpg::new(ddpg::Config::default());
    let mut a = agent();
    group.bench_function("ddpg", |b| {
        b.iter(|| {
            let [replay, dropout, _] = &mut rngs;
            let s = a.sample(replay);
            let critic = a.critic_update(&s, dropout);
            let actor = ddpg.actor_update(&mut a, &s, dropout);
            a.soft_update();
            black_box((critic, actor))
        })
    });

    for t in [1usize, 4, 16] {
        let dcp = Dcp::new(
            dcp::Config {
                t,
                ..dcp::Config::default()
            },
            0.2,
        );
        let mut a = agent();
        group.bench_with_input(BenchmarkId::new("dcp", format!("T={t}")), &t, |b, _| {
            b.iter(|| {
                let [replay, dropout, proposals] = &mut rngs;
                let s = a.sample(replay);
                let critic = a.critic_update(&s, dropout);
                let actor = dcp.actor_update(&mut a, &s, proposals, dropout);
                a.soft_update();
                black_box((critic, actor))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, updates);
criterion_main!(benches);
