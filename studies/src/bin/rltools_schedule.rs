//! `rltools-schedule`: RLtools' TD3 Pendulum benchmark schedule, run by this project's DDPG
//! machinery, for the side-by-side comparison in `docs/performance.md` ("Side by side with
//! RLtools"; `scripts/bench-rltools.sh` runs it interleaved with RLtools' own benchmark).
//!
//! `cargo run --release -p studies --bin rltools-schedule [-- --seed S]`
//!
//! RLtools' `src/rl/environments/pendulum/td3/cpu/benchmark.cpp` (commit 9acdf5c) times 10,001
//! Pendulum steps: random actions for the first 100, then every step two critic updates (TD3's
//! twin critics, on one minibatch of 100) and every second step an actor update and the target
//! updates; actor 3→64→64→1 (ReLU, tanh output), critics 4→64→64→1, Adam (lr 1e-3), γ 0.99,
//! τ 0.005, exploration σ 0.1, a replay buffer of 10,000. Its timer covers the whole loop:
//! environment steps, acting, replay inserts and sampling, and all updates.
//!
//! This program runs the same loop at the same shapes with [`Agent`] and [`Ddpg`], the agent's
//! critics set as TD3's (twin critics, the Bellman target the minimum of the two target critics,
//! target-policy smoothing): each step after the first 100 makes one `critic_update`, which steps
//! both critics on one minibatch (RLtools' two critic updates), and every second step one
//! `actor_update` and one `soft_update` of all targets. One difference remains, counted in the
//! multiply-adds printed: our critic's backward pass also computes the first layer's input
//! gradient.
//!
//! `--threads N` (default: the cores available) runs the updates on N worker threads, as
//! `host-trainer train --threads N` does: the two critics' steps and their target passes side by
//! side. RLtools' benchmark runs on one thread.
//!
//! Output: one line, `schedule: SECONDS s, ... multiply-adds, ... G/s, kernels ISA, N threads`.
//! The timer covers the same loop as RLtools'; building the agent is outside it.

use std::time::Instant;

use firmware_sim::seed;
use host_trainer::algorithms::agent::Agent;
use host_trainer::algorithms::agent_config::AgentConfig;
use host_trainer::algorithms::ddpg::{self, Ddpg, Td3Config};
use host_trainer::buffers::replay::Transition;
use host_trainer::nn::hidden::Hidden;
use host_trainer::nn::workers::Workers;

/// Environment steps (RLtools: `STEP_LIMIT` 10,000, steps 0 through 10,000).
const STEPS: usize = 10_001;
/// Steps of random actions before training starts.
const WARMUP: usize = 100;
/// Pendulum's time limit.
const EPISODE: usize = 200;
/// Minibatch.
const BATCH: usize = 100;

/// Gym's Pendulum-v1 (the dynamics RLtools' Pendulum implements): torque in [-2, 2].
struct Pendulum {
    theta: f32,
    omega: f32,
}

impl Pendulum {
    fn reset(rng: &mut seed::SimRng) -> Pendulum {
        Pendulum {
            theta: seed::uniform_in(rng, -std::f32::consts::PI, std::f32::consts::PI),
            omega: seed::uniform_in(rng, -1.0, 1.0),
        }
    }

    fn observe(&self) -> Vec<f32> {
        vec![self.theta.cos(), self.theta.sin(), self.omega]
    }

    /// One step with a unit action in [-1, 1]; returns the reward.
    fn step(&mut self, unit: f32) -> f32 {
        let (g, m, l, dt) = (10.0f32, 1.0f32, 1.0f32, 0.05f32);
        let u = 2.0 * unit.clamp(-1.0, 1.0);
        let angle = (self.theta + std::f32::consts::PI).rem_euclid(2.0 * std::f32::consts::PI)
            - std::f32::consts::PI;
        let cost = angle * angle + 0.1 * self.omega * self.omega + 0.001 * u * u;
        let omega =
            self.omega + (3.0 * g / (2.0 * l) * self.theta.sin() + 3.0 / (m * l * l) * u) * dt;
        self.omega = omega.clamp(-8.0, 8.0);
        self.theta += self.omega * dt;
        -cost
    }
}

/// The value after `--name` on the command line, if it parses.
fn flag<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::args()
        .skip_while(|a| a != name)
        .nth(1)
        .and_then(|s| s.parse().ok())
}

fn main() {
    let seed = flag("--seed").unwrap_or(0u64);
    let threads = flag("--threads")
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let config = AgentConfig {
        hidden: Hidden {
            depth: 2,
            width: 64,
        },
        lr_actor: 1e-3,
        lr_critic: 1e-3,
        l2: 0.0,
        batch: BATCH,
        sigma: 0.1,
        replay_capacity: 10_000,
        ..AgentConfig::default()
    };
    let mut rngs = ["init", "env", "explore", "replay", "dropout", "smoothing"]
        .map(|n| seed::training_stream(seed, n));
    let [init, env_rng, explore, replay, dropout, smoothing] = &mut rngs;
    let mut agent = match Agent::new(config, 3, &[-2.0], &[2.0], init) {
        Ok(agent) => agent,
        Err(e) => {
            eprintln!("rltools-schedule: {e}");
            std::process::exit(1);
        }
    };
    agent.set_critics(Td3Config::default().critics(), init);
    match Workers::new(threads) {
        Ok(workers) => agent.set_workers(workers),
        Err(e) => {
            eprintln!("rltools-schedule: {e}");
            std::process::exit(1);
        }
    }
    let ddpg = Ddpg::new(ddpg::Config::default());
    let mut noise = agent.noise_process(0);
    let (mut critic_updates, mut actor_updates, mut target_updates) = (0u64, 0u64, 0u64);

    let start = Instant::now();
    let mut env = Pendulum::reset(env_rng);
    for step in 0..STEPS {
        if step % EPISODE == 0 && step > 0 {
            env = Pendulum::reset(env_rng);
            noise = agent.noise_process(0);
        }
        let obs = env.observe();
        let action = if step < WARMUP {
            vec![seed::uniform_in(explore, -1.0, 1.0)]
        } else {
            agent.explore(&obs, &mut noise, explore)
        };
        let reward = env.step(action[0]);
        agent.remember(&Transition {
            obs,
            action,
            reward,
            next_obs: env.observe(),
            terminal: false,
            truncated: false,
        });
        if step >= WARMUP {
            let sample = agent.sample(replay);
            // Both critics: RLtools' two critic updates.
            agent.critic_update_with(&sample, dropout, Some(&mut *smoothing));
            critic_updates += 2;
            if step % 2 == 0 {
                ddpg.actor_update(&mut agent, &sample, dropout);
                agent.soft_update();
                actor_updates += 1;
                target_updates += 1;
            }
        }
    }
    let seconds = start.elapsed().as_secs_f64();

    // Per row, a step of both critics runs the target actor once and both target critics, and
    // each critic's forward and backward pass (weight and input gradients: twice the forward):
    // A + 2C + 2 × 3C; an actor update runs the actor forward, the critic forward, dQ/d(input)
    // through the critic, and the actor's backward (twice its forward): 3A + 2C.
    let (a, c) = (agent.actor.multiply_adds(), agent.critic.multiply_adds());
    let rows = BATCH as u64;
    let macs = critic_updates / 2 * rows * (a + 8 * c) + actor_updates * rows * (3 * a + 2 * c);
    if !agent.is_finite() {
        eprintln!("rltools-schedule: training diverged");
        std::process::exit(1);
    }
    println!(
        "schedule: {seconds:.3} s, {STEPS} env steps, {critic_updates} critic + {actor_updates} actor + \
         {target_updates} target updates, {:.2} G multiply-adds, {:.1} G/s, kernels {}, {threads} threads",
        macs as f64 / 1e9,
        macs as f64 / seconds / 1e9,
        instruction_set()
    );
}

/// The vector instructions the build lets the training kernels use.
fn instruction_set() -> &'static str {
    if cfg!(target_feature = "avx512f") {
        "avx512f+fma"
    } else if cfg!(all(target_feature = "avx2", target_feature = "fma")) {
        "avx2+fma"
    } else if cfg!(target_feature = "avx2") {
        "avx2"
    } else if cfg!(target_feature = "sse2") {
        "sse2"
    } else {
        "scalar"
    }
}
