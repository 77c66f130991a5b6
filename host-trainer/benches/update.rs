//! Training updates per second: one minibatch of 64, critic step + actor step + soft target
//! update, 4×48 actor and critic on the navigation shapes (2 observations, 2 actions).
//!
//! `cargo bench -p host-trainer --bench update`; criterion reports time per update and, as its
//! throughput, multiply-adds per second of the update's network passes (counted in
//! [`multiply_adds`]).

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

/// Multiply-adds of one update at batch 64 with `agent`'s networks, with `t` proposals for DCP
/// (`None`: DDPG). Per row, A for the actor and C for the critic (`Net::multiply_adds`: 7,104 and
/// 7,152 for 4×48 on the navigation shapes); a backward pass costs two forwards (weight and input
/// gradients).
/// - critic step: target actor and target critic forward, critic forward and backward: A + 4C;
/// - DDPG actor step: actor forward, critic forward, dQ/d(input), actor backward: 3A + 2C;
/// - DCP actor step: actor forward (reused for the regression), the critic on T + 1 actions per
///   state, actor backward: 3A + (T + 1) C.
fn multiply_adds(agent: &Agent, t: Option<u64>) -> u64 {
    let (a, c) = (agent.actor.multiply_adds(), agent.critic.multiply_adds());
    let actor = match t {
        None => 3 * a + 2 * c,
        Some(t) => 3 * a + (t + 1) * c,
    };
    agent.config.batch as u64 * (a + 4 * c + actor)
}

fn updates(c: &mut Criterion) {
    let mut group = c.benchmark_group("update_4x48_batch64");
    let mut a = agent();
    group
        .throughput(Throughput::Elements(multiply_adds(&a, None)))
        .measurement_time(Duration::from_secs(5))
        .sample_size(30);
    let mut rngs = [
        seed::stream(1, "replay"),
        seed::stream(1, "dropout"),
        seed::stream(1, "proposals"),
    ];

    let ddpg = Ddpg::new(ddpg::Config::default());
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
        group.throughput(Throughput::Elements(multiply_adds(&a, Some(t as u64))));
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
