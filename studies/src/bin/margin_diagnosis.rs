//! `margin-diagnosis`: why does a run park at a margin: does its replay hold no way round (exploration fails), or
//! does its critic know the way round while the actor does not follow (the actor update fails)?
//! Measured along a run, from the checkpoints it wrote on the way.
//!
//! ```sh
//! cargo run --release -p studies --bin margin-diagnosis -- [--ring 1.0] \
//!     [--ring-out ring.csv] CHECKPOINT...
//! cargo run --release -p studies --bin margin-diagnosis -- runs/nav-walls__dcp__0/checkpoints/*
//! ```
//!
//! `train --keep-checkpoints` keeps a copy of every checkpoint the run writes (every
//! `checkpoint_every` episodes) in `RUN/checkpoints/`: the run's state at those episodes. For
//! each copy of a DCP, DDPG or TD3 run on a navigation plant whose centre is enclosed by an
//! inner square ring of half-size `--ring` (1.0, the pinwheel's), it prints one CSV row:
//!
//! - **replay**: the transitions stored, the share that end inside the inner ring, the share in
//!   the band just outside it (up to 0.5 beyond the ring: where a parked policy sits) and the
//!   number that cross into the ring from outside, which only the ring's gap allows;
//! - **policy**: the exported actor through firmware-sim's test protocol (100 starts, seed 0):
//!   success rate, mean settled error, stuck rate;
//! - **stuck ends**: at the end position of each episode that ended stuck, the critic's best
//!   action over a 21 × 21 grid of the unit box (a*) against the actor's (a0): how often a* is
//!   itself blocked by the wall (the critic rates the push best), the mean Q(s, a*) − Q(s, a0),
//!   the mean distance |a* − a0| in the unit box, and the share of stuck ends from which *walking
//!   the critic's argmax* (an 11 × 11 grid each step, up to the time limit) comes within 0.25 of
//!   the centre: whether what the critic prefers is a real way round, not an artefact of its
//!   extrapolation;
//! - **ring**: the same on 32 points around the ring, 0.02 outside it (against the wall, where a
//!   parked policy sits): the share of points whose a* is free (the critic knows a move that is
//!   not a push: along the wall or away from it) and Q(s, a0) at the north gap minus its mean
//!   over the ring (> 0: the critic values the gap more than the closed sides).
//!
//! `--ring-out FILE` also writes every ring point's values, one row per checkpoint and point.

use std::io::Write;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use firmware_sim::env::Env;
use firmware_sim::nav::geometry::Vec2;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use firmware_sim::nav::NavEnv;
use host_trainer::algorithms::Learner;
use host_trainer::run::checkpoint::Checkpoint;
use policy_core::model::{Model, Scratch};
use studies::walls::{blocked, unit_grid};

/// Grid points per action dimension for the critic's argmax.
const GRID: usize = 21;
/// Grid points per action dimension when walking the critic's argmax.
const WALK_GRID: usize = 11;
/// How close to the centre a critic walk must come.
const WALK_REACH: f32 = 0.25;
/// Points on the ring scan.
const RING_POINTS: usize = 32;
/// How far outside the ring the scan lies: against the wall, closer than a blocked push moves.
const RING_OFFSET: f32 = 0.02;
/// The band outside the ring whose share of the replay is counted.
const BAND: f32 = 0.5;

type Wide = Scratch<256>;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("margin-diagnosis: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut ring, mut ring_out, mut files) = (1.0f32, None, Vec::new());
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--ring" => {
                let v = args.next().context("--ring needs a half-size")?;
                ring = v.parse().with_context(|| format!("--ring {v}"))?;
            }
            "--ring-out" => ring_out = Some(args.next().context("--ring-out needs a file")?),
            _ if arg.starts_with('-') => bail!("unknown option {arg}"),
            _ => files.push(arg),
        }
    }
    if files.is_empty() {
        bail!("usage: margin-diagnosis [--ring HALF_SIZE] [--ring-out FILE] CHECKPOINT...");
    }
    let mut ring_file = match &ring_out {
        Some(path) => {
            let mut f = std::fs::File::create(path).with_context(|| path.clone())?;
            writeln!(
                f,
                "episode,point,x,y,q_actor,q_best,best_blocked,a0_x,a0_y,best_x,best_y"
            )?;
            Some(f)
        }
        None => None,
    };
    println!(
        "episode,replay,inside_share,band_share,inward_crossings,success,settled_error,stuck,\
         stuck_ends,stuck_best_blocked,stuck_q_gap,stuck_apart,critic_walk_reach,ring_best_free,\
         ring_gap_value"
    );
    for file in &files {
        let row = diagnose(file, ring, ring_file.as_mut())?;
        println!("{row}");
    }
    Ok(())
}

fn diagnose(path: &str, ring: f32, ring_file: Option<&mut std::fs::File>) -> Result<String> {
    let checkpoint = Checkpoint::load(path.as_ref())?;
    let scenario = Scenario::from_toml_str(&checkpoint.scenario_toml)
        .map_err(|e| anyhow::anyhow!("{path}: its plant: {e}"))?;
    let Learner::ActorCritic(learner) = &checkpoint.learner else {
        bail!("{path}: not a DCP, DDPG or TD3 run");
    };
    let agent = &learner.agent;

    // Replay coverage.
    let inside = |p: &[f32]| p[0].abs().max(p[1].abs()) < ring;
    let in_band = |p: &[f32]| {
        let d = p[0].abs().max(p[1].abs());
        d >= ring && d < ring + BAND
    };
    let (mut n, mut ends_inside, mut band, mut inward) = (0usize, 0usize, 0usize, 0usize);
    for (s, s2) in agent.replay.moves() {
        n += 1;
        ends_inside += usize::from(inside(s2));
        band += usize::from(in_band(s2));
        inward += usize::from(!inside(s) && inside(s2));
    }
    let share = |k: usize| k as f64 / n.max(1) as f64;

    // The policy as exported, through the test protocol.
    let actor_bytes = agent.actor_blob("diagnosis")?;
    let critic_bytes = agent.critic_blob("diagnosis")?;
    let actor = Model::from_blob(&actor_bytes).map_err(|e| anyhow::anyhow!("actor: {e}"))?;
    let critic = Model::from_blob(&critic_bytes).map_err(|e| anyhow::anyhow!("critic: {e}"))?;
    let report = evaluate(&actor_bytes, &scenario, &EvalConfig::default())?;
    let mut probe = Probe {
        actor: &actor,
        critic: &critic,
        plant: NavEnv::new(&scenario)?,
        max_step: scenario.max_step,
        scratch: Box::new(Wide::new()),
    };

    // Stuck ends.
    let (mut stuck, mut best_blocked, mut gap, mut apart, mut walked) =
        (0usize, 0usize, 0.0f64, 0.0f64, 0usize);
    for episode in report.episodes.iter().filter(|e| e.stuck) {
        let end = [episode.end[0] as f32, episode.end[1] as f32];
        let p = probe.at(end)?;
        stuck += 1;
        best_blocked += usize::from(p.best_blocked);
        gap += f64::from(p.q_best - p.q_actor);
        apart += f64::from((p.a0[0] - p.best[0]).hypot(p.a0[1] - p.best[1]));
        walked += usize::from(probe.critic_walk_reaches(end, scenario.time_limit)?);
    }

    // The ring scan: RING_POINTS evenly spaced along the square at ring + RING_OFFSET, starting
    // at the north gap's approach (0, r) and going clockwise.
    let r = ring + RING_OFFSET;
    let (mut free, mut values) = (0usize, Vec::with_capacity(RING_POINTS));
    let mut rows = Vec::new();
    for k in 0..RING_POINTS {
        let xy = square_point(r, k as f32 / RING_POINTS as f32);
        let p = probe.at(xy)?;
        free += usize::from(!p.best_blocked);
        values.push(f64::from(p.q_actor));
        rows.push(format!(
            "{},{k},{:.3},{:.3},{:.4},{:.4},{},{:.3},{:.3},{:.3},{:.3}",
            checkpoint.episode,
            xy[0],
            xy[1],
            p.q_actor,
            p.q_best,
            u8::from(p.best_blocked),
            p.a0[0],
            p.a0[1],
            p.best[0],
            p.best[1]
        ));
    }
    if let Some(f) = ring_file {
        for row in rows {
            writeln!(f, "{row}")?;
        }
    }
    let mean_value = values.iter().sum::<f64>() / values.len() as f64;
    let per_stuck = |x: f64| if stuck > 0 { x / stuck as f64 } else { 0.0 };
    Ok(format!(
        "{},{n},{:.4},{:.4},{inward},{:.2},{:.3},{:.2},{stuck},{},{:.3},{:.3},{:.2},{:.3},{:.3}",
        checkpoint.episode,
        share(ends_inside),
        share(band),
        report.success_rate,
        report.mean_error,
        report.stuck_rate,
        if stuck > 0 {
            format!("{:.2}", best_blocked as f64 / stuck as f64)
        } else {
            "-".into()
        },
        per_stuck(gap),
        per_stuck(apart),
        per_stuck(walked as f64),
        free as f64 / RING_POINTS as f64,
        values[0] - mean_value,
    ))
}

/// The point a fraction `t` of the way round the square of half-size `r`, clockwise from the
/// middle of its north side.
fn square_point(r: f32, t: f32) -> [f32; 2] {
    let d = (t * 8.0 * r) % (8.0 * r); // distance along the perimeter
    let (x, y) = match d {
        d if d < r => (d, r),                         // north side, east half
        d if d < 3.0 * r => (r, r - (d - r)),         // east side, going south
        d if d < 5.0 * r => (r - (d - 3.0 * r), -r),  // south side, going west
        d if d < 7.0 * r => (-r, -r + (d - 5.0 * r)), // west side, going north
        d => (-r + (d - 7.0 * r), r),                 // north side, west half
    };
    [x, y]
}

/// What the actor and the critic say at one position.
struct Point {
    a0: [f32; 2],
    best: [f32; 2],
    q_actor: f32,
    q_best: f32,
    best_blocked: bool,
}

struct Probe<'a> {
    actor: &'a Model<'a>,
    critic: &'a Model<'a>,
    plant: NavEnv,
    max_step: f32,
    scratch: Box<Wide>,
}

impl Probe<'_> {
    fn at(&mut self, s: [f32; 2]) -> Result<Point> {
        let e = |e: policy_core::Error| anyhow::anyhow!("{e}");
        let mut a0 = [0.0f32; 2];
        self.actor
            .act_unit(&s, &mut self.scratch, &mut a0)
            .map_err(e)?;
        let q_actor = self.critic.q(&s, &a0, &mut self.scratch).map_err(e)?;
        let (mut q_best, mut best) = (f32::NEG_INFINITY, [0.0f32; 2]);
        for a in unit_grid(GRID) {
            let q = self.critic.q(&s, &a, &mut self.scratch).map_err(e)?;
            if q > q_best {
                (q_best, best) = (q, a);
            }
        }
        let best_blocked = self.blocked(s, best);
        Ok(Point {
            a0,
            best,
            q_actor,
            q_best,
            best_blocked,
        })
    }

    /// Whether walking the critic's argmax over a coarse grid from `start` comes within
    /// `WALK_REACH` of the centre within `steps` steps.
    fn critic_walk_reaches(&mut self, start: [f32; 2], steps: u32) -> Result<bool> {
        let e = |e: policy_core::Error| anyhow::anyhow!("{e}");
        self.plant.reset(0);
        self.plant
            .set_position(Vec2::new(f64::from(start[0]), f64::from(start[1])));
        let mut s = start;
        for _ in 0..steps {
            if s[0].hypot(s[1]) < WALK_REACH {
                return Ok(true);
            }
            let (mut q_best, mut best) = (f32::NEG_INFINITY, [0.0f32; 2]);
            for a in unit_grid(WALK_GRID) {
                let q = self.critic.q(&s, &a, &mut self.scratch).map_err(e)?;
                if q > q_best {
                    (q_best, best) = (q, a);
                }
            }
            let step = self
                .plant
                .step(&[best[0] * self.max_step, best[1] * self.max_step]);
            s = [step.observation[0], step.observation[1]];
            if step.terminated || step.truncated {
                break;
            }
        }
        Ok(s[0].hypot(s[1]) < WALK_REACH)
    }

    /// Whether the plant moves less than [`studies::walls::BLOCKED`] of the commanded step
    /// from `s`.
    fn blocked(&mut self, s: [f32; 2], a: [f32; 2]) -> bool {
        let at = Vec2::new(f64::from(s[0]), f64::from(s[1]));
        blocked(&mut self.plant, at, a, self.max_step)
    }
}
