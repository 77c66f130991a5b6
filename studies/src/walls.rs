//! How the studies of stuck policies probe a navigation plant's walls: whether an action is
//! blocked where a run ended, and the grid of unit actions over which a critic's best action is
//! searched.

use firmware_sim::env::Env;
use firmware_sim::nav::geometry::Vec2;
use firmware_sim::nav::NavEnv;

/// A step counts as blocked when the plant moves less than this fraction of it.
pub const BLOCKED: f32 = 0.2;

/// Whether the plant, put at `at`, moves less than [`BLOCKED`] of the commanded step `unit`
/// (an action in the unit box, scaled by `max_step`). `StepInfo::applied` is the motion the
/// plant carried out, in the action's units.
///
/// ```
/// use firmware_sim::nav::geometry::Vec2;
/// use firmware_sim::nav::scenario::Scenario;
/// use firmware_sim::nav::NavEnv;
/// use studies::walls::blocked;
///
/// let scenario = Scenario::resolve("nav-walls").unwrap();
/// let mut plant = NavEnv::new(&scenario).unwrap();
/// // In the open at the centre, a step east is carried out.
/// assert!(!blocked(&mut plant, Vec2::new(0.0, 0.0), [1.0, 0.0], scenario.max_step));
/// ```
pub fn blocked(plant: &mut NavEnv, at: Vec2, unit: [f32; 2], max_step: f32) -> bool {
    plant.reset(0);
    plant.set_position(at);
    let step = [unit[0] * max_step, unit[1] * max_step];
    let applied = plant.step(&step).info.applied;
    applied[0].hypot(applied[1]) < BLOCKED * max_step * unit[0].hypot(unit[1])
}

/// The `points` × `points` grid of the unit box, row by row: `[-1, -1]`, `[-1, -1 + 2/(points
/// − 1)]`, ..., `[1, 1]`. A critic's best action is the first grid point of the highest value.
///
/// ```
/// use studies::walls::unit_grid;
/// let grid: Vec<[f32; 2]> = unit_grid(3).collect();
/// assert_eq!(grid.len(), 9);
/// assert_eq!(grid[0], [-1.0, -1.0]);
/// assert_eq!(grid[1], [-1.0, 0.0]);
/// assert_eq!(grid[8], [1.0, 1.0]);
/// ```
pub fn unit_grid(points: usize) -> impl Iterator<Item = [f32; 2]> {
    let unit = move |k: usize| -1.0 + 2.0 * k as f32 / (points - 1) as f32;
    (0..points).flat_map(move |i| (0..points).map(move |j| [unit(i), unit(j)]))
}
