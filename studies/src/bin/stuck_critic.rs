//! `stuck-critic`: why is a trained policy stuck at a wall: does its critic agree, or does the
//! actor fail to follow its critic?
//!
//! ```sh
//! cargo run --release -p studies --bin stuck-critic -- runs/nav-walls__dcp__0 [nav-walls]
//! ```
//!
//! Runs the run folder's `policy.postcard` through firmware-sim's test protocol (100 starts,
//! seed 0), and at the end position of every episode that ended stuck at a margin, searches the
//! exported `critic.postcard` over a 41 × 41 grid of unit actions for the critic's best action
//! a*. It then reports how often a* and the actor's own action a0 are blocked by a wall (the
//! plant moves less than 20 % of the commanded step), how far apart they are in the unit box,
//! and the critic's value gap Q(s, a*) - Q(s, a0).
//!
//! - a* blocked too: the critic itself rates pushing into the wall best. The actor is doing its
//!   job; the value estimate (and the exploration that feeds it) is what holds the policy there.
//! - a* free and far from a0: the critic knows a way out that the actor update does not reach
//!   (for DCP: further away than the proposals σc reach).
//!
//! Only 4×48 actors and critics (the default) are handled.

use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use firmware_sim::nav::geometry::Vec2;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use firmware_sim::nav::NavEnv;
use policy_core::{Critic, Policy};
use studies::walls::{blocked, unit_grid};

type Actor = Policy<2, 48, 3, 2>;
type Value = Critic<2, 48, 3, 2>;

/// Grid points per action dimension for the critic's argmax.
const GRID: usize = 41;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("stuck-critic: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first() else {
        bail!("usage: stuck-critic RUN_DIR [SCENARIO]");
    };
    let scenario = Scenario::resolve(args.get(1).map_or("nav-walls", String::as_str))?;
    let read = |name: &str| {
        let path = format!("{dir}/{name}");
        std::fs::read(&path).with_context(|| path)
    };
    let policy_bytes = read("policy.postcard")?;
    let actor = Actor::from_blob(&policy_bytes)
        .map_err(|e| anyhow::anyhow!("policy.postcard (must be a 4x48 actor): {e}"))?;
    let critic = Value::from_blob(&read("critic.postcard")?)
        .map_err(|e| anyhow::anyhow!("critic.postcard (must be a 4x48 critic): {e}"))?;
    let report = evaluate(&policy_bytes, &scenario, &EvalConfig::default())?;
    let mut plant = NavEnv::new(&scenario)?;
    let max_step = scenario.max_step;

    let (mut stuck, mut critic_blocked, mut actor_blocked) = (0, 0, 0);
    let (mut gap, mut apart, mut value) = (0.0f32, 0.0f32, 0.0f32);
    for episode in report.episodes.iter().filter(|e| e.stuck) {
        let s = [episode.end[0] as f32, episode.end[1] as f32];
        let a0 = actor.act_unit(&s);
        let z: [f32; 2] = critic.normalizer.normalize(&s).into();
        let (q_best, a_best) = argmax(&critic, &z);
        let end = Vec2::new(episode.end[0], episode.end[1]);
        let mut is_blocked = |a: [f32; 2]| blocked(&mut plant, end, a, max_step);
        stuck += 1;
        critic_blocked += usize::from(is_blocked(a_best));
        actor_blocked += usize::from(is_blocked(a0));
        let q0 = critic.q_normalized(&z, &a0);
        value += q0;
        gap += q_best - q0;
        apart += (a0[0] - a_best[0]).hypot(a0[1] - a_best[1]);
    }
    println!(
        "{dir}: {} test starts, {stuck} ended stuck at a margin",
        report.episodes.len()
    );
    if stuck > 0 {
        let n = stuck as f32;
        println!("  actor's action a0 blocked by the wall      {actor_blocked} of {stuck}");
        println!("  critic's best action a* blocked            {critic_blocked} of {stuck}");
        println!(
            "  mean |a0 - a*| in the unit box             {:.2}",
            apart / n
        );
        println!(
            "  mean Q(s, a*) - Q(s, a0)                   {:.3}",
            gap / n
        );
        println!(
            "  mean Q(s, a0), for scale                   {:.2}",
            value / n
        );
    }
    Ok(())
}

/// The critic's best action over a GRID × GRID grid of the unit box, for the normalised
/// observation `z` (normalised once, not once per grid point).
fn argmax(critic: &Value, z: &[f32; 2]) -> (f32, [f32; 2]) {
    let mut best = (f32::NEG_INFINITY, [0.0; 2]);
    for a in unit_grid(GRID) {
        let q = critic.q_normalized(z, &a);
        if q > best.0 {
            best = (q, a);
        }
    }
    best
}
