//! Training updates per second on the navigation shapes (2 observations, 2 actions), 4×48
//! networks: DDPG and DCP (one minibatch of 64: critic step + actor step + soft target update),
//! DQN (one minibatch of 64: Huber step + soft update) and PPO (the update at the end of one
//! 2,048-step rollout: GAE and 10 epochs of 32 minibatches of 64).
//!
//! `cargo bench -p host-trainer --bench update`; criterion reports time per update and, as its
//! throughput, multiply-adds per second of the update's network passes (counted in
//! [`multiply_adds`]).
//!
//! `update_threads/{algorithm}/threads=N` runs DDPG, the paper's DCP (T = 16) and DCP as
//! adopted (twin critics, target smoothing, 3-step returns) with the updates on N worker
//! threads (`train --threads N`), one after the other in the same run, so their ratios compare:
//! `cargo bench -p host-trainer --bench update -- update_threads`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use firmware_sim::seed;
use host_trainer::algorithms::agent::Agent;
use host_trainer::algorithms::agent_config::AgentConfig;
use host_trainer::algorithms::algorithm::{Algorithm, Step};
use host_trainer::algorithms::dcp::{self, Dcp};
use host_trainer::algorithms::ddpg::{self, Ddpg, Td3Config};
use host_trainer::algorithms::dqn::{self, Dqn};
use host_trainer::algorithms::ppo::{self, Ppo};
use host_trainer::buffers::replay::Transition;
use host_trainer::nn::workers::Workers;

/// An agent with 10,000 random navigation transitions in its buffer.
fn agent() -> Agent {
    let config = AgentConfig::default();
    let mut agent = Agent::new(
        config,
        2,
        &[-0.25; 2],
        &[0.25; 2],
        &mut seed::training_stream(0, "init"),
    )
    .expect("agent");
    let mut rng = seed::training_stream(0, "data");
    for _ in 0..10_000 {
        let mut draw = |scale: f32| scale * (2.0 * seed::uniform_f32(&mut rng) - 1.0);
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
            truncated: false,
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
        seed::training_stream(1, "replay"),
        seed::training_stream(1, "dropout"),
        seed::training_stream(1, "proposals"),
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
                ..dcp::Config::paper()
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

/// `steps` random navigation steps through an algorithm's `act` and `learn` (no plant).
fn feed(algo: &mut dyn Algorithm, steps: usize) {
    let mut rng = seed::training_stream(0, "data");
    let mut obs = vec![0.0f32; 2];
    algo.start_episode(0, 1);
    for i in 0..steps {
        let mut draw = |scale: f32| scale * (2.0 * seed::uniform_f32(&mut rng) - 1.0);
        if i % 200 == 0 {
            obs = vec![draw(6.0), draw(6.0)];
        }
        let action = algo.act(&obs);
        let next_obs = vec![obs[0] + action[0], obs[1] + action[1]];
        algo.learn(&Step {
            obs: &obs,
            reward: -(next_obs[0].hypot(next_obs[1])) / 6.0,
            next_obs: &next_obs,
            terminated: false,
            truncated: i % 200 == 199,
            total_steps: i as u64 + 1,
        })
        .expect("finite");
        obs = next_obs;
    }
}

fn baselines(c: &mut Criterion) {
    let mut group = c.benchmark_group("update_4x48_batch64");
    group
        .measurement_time(Duration::from_secs(5))
        .sample_size(30);

    // DQN: per row, the target network and the online network forward, the online backward.
    let shared = AgentConfig::default();
    let own = dqn::Config::default();
    let mut dqn = Dqn::new(&own, &shared, 0, 2, &[-0.25; 2], &[0.25; 2]).expect("dqn");
    feed(&mut dqn, 10_000);
    let q = dqn.q.multiply_adds();
    group.throughput(Throughput::Elements(64 * 4 * q));
    group.bench_function("dqn", |b| b.iter(|| black_box(dqn.update())));

    // PPO: per row and epoch, actor and value network forward and backward.
    let own = ppo::Config::default();
    let rollout = own.rollout;
    let epochs = own.epochs as u64;
    let mut ppo = Ppo::new(&own, &shared, 0, 2, &[-0.25; 2], &[0.25; 2]).expect("ppo");
    feed(&mut ppo, rollout - 1); // one step short: the rollout is full but not yet learned
    let per_row = 3 * (ppo.actor.multiply_adds() + ppo.value.multiply_adds());
    group.throughput(Throughput::Elements(
        epochs * (rollout as u64 - 1) * per_row,
    ));
    group.bench_function("ppo_rollout_2047", |b| b.iter(|| black_box(ppo.update())));
    group.finish();
}

/// One actor-critic update of DDPG or DCP with the updates on `threads` worker threads.
fn threads(c: &mut Criterion) {
    let mut group = c.benchmark_group("update_threads");
    group
        .measurement_time(Duration::from_secs(5))
        .sample_size(30);
    let paper = dcp::Config {
        t: 16,
        ..dcp::Config::paper()
    };
    let runs = [
        ("ddpg", None),
        ("dcp-paper-T16", Some(paper)),
        ("dcp-adopted", Some(dcp::Config::default())),
    ];
    for (name, dcp_config) in runs {
        for threads in [1usize, 2] {
            let mut a = agent();
            if let Some(config) = &dcp_config {
                let critics = config.critics(&Td3Config::default());
                a.set_critics(critics, &mut seed::training_stream(0, "init"));
            }
            a.set_workers(Workers::new(threads).expect("worker threads"));
            let t = dcp_config.as_ref().map(|c| c.t as u64);
            let twin = u64::from(a.twin.is_some());
            // A twin critic adds, per row, its target's pass and its own step (4C) and, scoring
            // the proposals, (T + 1) C.
            let extra = a.config.batch as u64
                * twin
                * a.critic.multiply_adds()
                * (4 + t.map_or(0, |t| t + 1));
            group.throughput(Throughput::Elements(multiply_adds(&a, t) + extra));
            let ddpg = Ddpg::new(ddpg::Config::default());
            let dcp = dcp_config.clone().map(|c| Dcp::new(c, 0.2));
            let mut rngs = [
                seed::training_stream(1, "replay"),
                seed::training_stream(1, "dropout"),
                seed::training_stream(1, "proposals"),
                seed::training_stream(1, "smoothing"),
            ];
            let id = BenchmarkId::new(name, format!("threads={threads}"));
            group.bench_function(id, |b| {
                b.iter(|| {
                    let [replay, dropout, proposals, smoothing] = &mut rngs;
                    let s = a.sample(replay);
                    let critic = a.critic_update_with(&s, dropout, Some(smoothing));
                    let actor = match &dcp {
                        Some(dcp) => dcp.actor_update(&mut a, &s, proposals, dropout).loss,
                        None => ddpg.actor_update(&mut a, &s, dropout).loss,
                    };
                    a.soft_update();
                    black_box((critic, actor))
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, updates, baselines, threads);
criterion_main!(benches);
