//! Generated navigation layouts: families of walled arenas that no agent was tuned on.
//!
//! Two kinds, each at difficulty levels 1 to 4, every layout fully determined by its seed:
//!
//! - **rings**: `level` nested square rings around the goal (half-sizes spread from 1 to 4),
//!   each closed but for one gap (the outer rings of level 3 and 4: two), of width 0.6 to 1.2,
//!   on a side and at a place drawn from the seed. The pinwheel is a hand-made relative.
//! - **maze**: a square maze of `2·level + 1` cells a side spanning `[-4, 4]²`, carved as a
//!   random spanning tree from the centre cell (a depth-first walk), so exactly one corridor path
//!   joins any two cells; its outer wall opens in two places. Corridors narrow and paths lengthen
//!   with the level; the time limit grows with it (200 steps per level).
//!
//! Starts are drawn on the arena's boundary, as in the built-in layouts. A layout is kept only if
//! the oracle (which plans on the walls) reaches the goal from every one of [`CHECK_STARTS`] test
//! starts; otherwise the next draw of the same seed is tried, so a seed always names one solvable
//! layout. The pass criteria and metrics are those of the pinwheel.

use super::oracle::Oracle;
use super::reward::Reward;
use super::scenario::{Metrics, PassCriteria, Scenario, StartRule, Wall};
use super::test_protocol::{evaluate_controller, EvalConfig};
use crate::seed::{self, SimRng};
use crate::Error;

/// Test starts the oracle must solve, every one, for a layout to be kept.
pub const CHECK_STARTS: usize = 200;
/// Draws tried per seed before giving up (none has been needed beyond a few).
const MAX_ATTEMPTS: u64 = 64;
/// Half-size of the arena (as the built-in layouts).
const ARENA: f64 = 6.0;
/// Half-size of the region the walls occupy.
const SPAN: f64 = 4.0;

/// Which family of layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Nested rings with gaps.
    Rings,
    /// A maze of corridors.
    Maze,
}

impl Kind {
    /// The kind's name on the command line and in scenario names.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Rings => "rings",
            Kind::Maze => "maze",
        }
    }
}

/// A generated layout and how it was checked.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The scenario, valid and solvable.
    pub scenario: Scenario,
    /// The draw of the seed that was kept (0: the first).
    pub attempt: u64,
}

/// The layout of `kind` at `level` (1..=4) for `seed`.
///
/// ```
/// use firmware_sim::nav::generator::{generate, Kind};
/// let g = generate(Kind::Rings, 2, 7).unwrap();
/// assert_eq!(g.scenario.name, "rings-2-seed7");
/// assert_eq!(g.scenario, generate(Kind::Rings, 2, 7).unwrap().scenario); // same seed, same layout
/// assert!(generate(Kind::Maze, 5, 7).is_err()); // levels are 1 to 4
/// ```
pub fn generate(kind: Kind, level: u8, seed: u64) -> Result<Generated, Error> {
    if !(1..=4).contains(&level) {
        return Err(Error::Config {
            field: "level",
            message: format!("must be 1, 2, 3 or 4, found {level}"),
        });
    }
    for attempt in 0..MAX_ATTEMPTS {
        let mut rng = seed::stream(seed, kind.name(), attempt);
        let walls = match kind {
            Kind::Rings => rings(level, &mut rng),
            Kind::Maze => maze(level, &mut rng),
        };
        let scenario = scenario(kind, level, seed, walls);
        scenario.validate()?;
        if oracle_solves(&scenario, seed)? {
            return Ok(Generated { scenario, attempt });
        }
    }
    Err(Error::Config {
        field: "seed",
        message: format!(
            "no solvable {} layout at level {level} in {MAX_ATTEMPTS} draws of seed {seed}",
            kind.name()
        ),
    })
}

/// Whether the oracle reaches the goal from every check start.
fn oracle_solves(scenario: &Scenario, seed: u64) -> Result<bool, Error> {
    let cfg = EvalConfig {
        episodes: CHECK_STARTS,
        seed,
        ..EvalConfig::default()
    };
    let report = evaluate_controller(&mut Oracle::new(scenario), scenario, &cfg)?;
    Ok(report.episodes.iter().all(|e| e.reached))
}

/// `level` square rings with gaps.
fn rings(level: u8, rng: &mut SimRng) -> Vec<Wall> {
    let mut walls = Vec::new();
    for k in 0..level {
        let half = if level == 1 {
            1.0
        } else {
            1.0 + f64::from(k) * (SPAN - 1.0) / f64::from(level - 1)
        };
        let gaps = if level >= 3 && k + 1 == level { 2 } else { 1 };
        // Distinct sides for the gaps of one ring.
        let mut sides = [0usize, 1, 2, 3];
        for i in 0..gaps {
            let j = i + seed::index(rng, 4 - i);
            sides.swap(i, j);
        }
        let mut openings = [None; 4];
        for &side in &sides[..gaps] {
            let width = 0.6 + 0.6 * seed::uniform(rng);
            // The gap's centre, at least 0.3 from either corner.
            let room = 2.0 * half - width - 0.6;
            let centre = -half + 0.3 + width / 2.0 + room * seed::uniform(rng);
            openings[side] = Some((round(centre - width / 2.0), round(centre + width / 2.0)));
        }
        square(half, &openings, &mut walls);
    }
    walls
}

/// The four sides of the square of half-size `h` (north, east, south, west), each whole or
/// split around its opening `(from, to)` (along x for north and south, along y for east and
/// west).
fn square(h: f64, openings: &[Option<(f64, f64)>; 4], walls: &mut Vec<Wall>) {
    let side = |i: usize, a: f64, b: f64| -> Wall {
        match i {
            0 => wall([a, h], [b, h]),
            1 => wall([h, a], [h, b]),
            2 => wall([a, -h], [b, -h]),
            _ => wall([-h, a], [-h, b]),
        }
    };
    for (i, opening) in openings.iter().enumerate() {
        match opening {
            None => walls.push(side(i, -h, h)),
            Some((from, to)) => {
                walls.push(side(i, -h, *from));
                walls.push(side(i, *to, h));
            }
        }
    }
}

/// A maze of `2·level + 1` cells a side on `[-SPAN, SPAN]²`, carved from the centre cell.
fn maze(level: u8, rng: &mut SimRng) -> Vec<Wall> {
    let n = 2 * usize::from(level) + 1;
    let cell = 2.0 * SPAN / n as f64;
    // open[c][d]: cell c's side d (0 north, 1 east, 2 south, 3 west) is open.
    let mut open = vec![[false; 4]; n * n];
    let mut seen = vec![false; n * n];
    let centre = (n / 2) * n + n / 2;
    let mut stack = vec![centre];
    seen[centre] = true;
    while let Some(&c) = stack.last() {
        let (row, col) = (c / n, c % n);
        let mut next = Vec::with_capacity(4);
        for d in 0..4 {
            let neighbour = match d {
                0 if row + 1 < n => Some(c + n),
                1 if col + 1 < n => Some(c + 1),
                2 if row > 0 => Some(c - n),
                3 if col > 0 => Some(c - 1),
                _ => None,
            };
            if let Some(m) = neighbour.filter(|&m| !seen[m]) {
                next.push((d, m));
            }
        }
        if next.is_empty() {
            stack.pop();
            continue;
        }
        let (d, m) = next[seed::index(rng, next.len())];
        open[c][d] = true;
        open[m][(d + 2) % 4] = true;
        seen[m] = true;
        stack.push(m);
    }
    // Two openings in the outer wall, on different sides.
    let first = seed::index(rng, 4);
    let second = (first + 1 + seed::index(rng, 3)) % 4;
    for side in [first, second] {
        let k = seed::index(rng, n);
        let c = match side {
            0 => (n - 1) * n + k,
            1 => k * n + n - 1,
            2 => k,
            _ => k * n,
        };
        open[c][side] = true;
    }
    // Walls: every closed north and east side, and the south and west sides of the border.
    let mut walls = Vec::new();
    let x = |col: usize| round(-SPAN + col as f64 * cell);
    for row in 0..n {
        for col in 0..n {
            let c = row * n + col;
            let (x0, x1, y0, y1) = (x(col), x(col + 1), x(row), x(row + 1));
            if !open[c][0] {
                walls.push(wall([x0, y1], [x1, y1]));
            }
            if !open[c][1] {
                walls.push(wall([x1, y0], [x1, y1]));
            }
            if row == 0 && !open[c][2] {
                walls.push(wall([x0, y0], [x1, y0]));
            }
            if col == 0 && !open[c][3] {
                walls.push(wall([x0, y0], [x0, y1]));
            }
        }
    }
    walls
}

fn wall(from: [f64; 2], to: [f64; 2]) -> Wall {
    Wall { from, to }
}

/// Coordinates to 1e-3, so the TOML file reads cleanly and round-trips exactly.
fn round(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

fn scenario(kind: Kind, level: u8, seed: u64, walls: Vec<Wall>) -> Scenario {
    let name = format!("{}-{level}-seed{seed}", kind.name());
    let description = match kind {
        Kind::Rings => format!("generated: {level} nested rings with gaps (seed {seed})"),
        Kind::Maze => {
            let n = 2 * usize::from(level) + 1;
            format!("generated: a {n}x{n} maze with two entrances (seed {seed})")
        }
    };
    let time_limit = match kind {
        Kind::Rings => 200,
        Kind::Maze => 200 * u32::from(level),
    };
    Scenario {
        name,
        description,
        arena_half_size: ARENA,
        max_step: 0.25,
        reward: Reward::Lr,
        gamma: 0.99,
        time_limit,
        goal_radius: 0.1,
        goal_hold: 10,
        start: StartRule::Boundary { inset: 0.25 },
        metrics: Metrics::default(),
        pass: PassCriteria {
            min_success_rate: 0.8,
            max_stuck_rate: 0.2,
        },
        walls,
    }
}
