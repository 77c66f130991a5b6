//! A player's body (a point on the floor of its own half, moving at most 4.5 m/s toward its
//! target) and how the agents' unit-box actions map onto targets and hits.
//!
//! ```
//! use firmware_sim::badminton::player::Body;
//! let mut body = Body::at([-2.0, 0.0]);
//! body.target = [-2.0, 2.0];
//! body.advance(4.5, 0.001);
//! assert!((body.position[1] - 0.0045).abs() < 1e-15);
//! ```

use super::config::HitConfig;
use super::court::{Court, Vec2, Vec3};

/// A player's floor position and target, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Where it is.
    pub position: Vec2,
    /// Where it is going (always inside its own half).
    pub target: Vec2,
}

impl Body {
    /// Standing at `p`, going nowhere.
    pub fn at(p: Vec2) -> Body {
        Body {
            position: p,
            target: p,
        }
    }

    /// Moves a straight line toward the target, at most `max_speed · dt`; returns the
    /// distance moved. The target lies in the own half, which is convex, so the path does too.
    #[inline]
    pub fn advance(&mut self, max_speed: f64, dt: f64) -> f64 {
        if self.position == self.target {
            return 0.0; // standing: most steps of a flight, once the player has arrived
        }
        let d = [
            self.target[0] - self.position[0],
            self.target[1] - self.position[1],
        ];
        let dist = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let reach = max_speed * dt;
        if dist <= reach {
            self.position = self.target;
            return dist;
        }
        let f = reach / dist;
        let moved = [self.position[0] + f * d[0], self.position[1] + f * d[1]];
        // The move is a convex combination of two points of the half; clamping to the box spanned
        // by them removes the last-bit rounding that could step across a line.
        let lo = |i: usize| self.position[i].min(self.target[i]);
        let hi = |i: usize| self.position[i].max(self.target[i]);
        self.position = [moved[0].clamp(lo(0), hi(0)), moved[1].clamp(lo(1), hi(1))];
        reach
    }
}

/// A component of an action, clamped to `[-1, 1]`; non-finite values count as 0.
pub fn unit(action: &[f32], i: usize) -> f64 {
    let a = action.get(i).copied().unwrap_or(0.0);
    if a.is_finite() {
        f64::from(a.clamp(-1.0, 1.0))
    } else {
        0.0
    }
}

/// A catch or reset action's target in the own frame: `x' = L·(u₀ - 1)/2 ∈ [-L, 0]`,
/// `y' = W·u₁`.
///
/// ```
/// use firmware_sim::badminton::court::Court;
/// use firmware_sim::badminton::player::target_of;
/// let court = Court { half_length: 6.7, half_width: 2.59, net_height: 1.55 };
/// assert_eq!(target_of(&[1.0, -1.0], &court), [0.0, -2.59]);
/// assert_eq!(target_of(&[-1.0, f32::NAN], &court), [-6.7, 0.0]);
/// ```
pub fn target_of(action: &[f32], court: &Court) -> Vec2 {
    let x = court.half_length * (unit(action, 0) - 1.0) / 2.0;
    court
        .clip_to_own_half([x, court.half_width * unit(action, 1)])
        .0
}

/// The action that asks for `target` (own frame): the inverse of [`target_of`].
pub fn action_for_target(target: Vec2, court: &Court) -> [f32; 2] {
    [
        (2.0 * target[0] / court.half_length + 1.0) as f32,
        (target[1] / court.half_width) as f32,
    ]
}

/// A serve action's hit velocity in the own frame: speed, elevation and azimuth mapped linearly
/// from the unit box onto the configured ranges; azimuth from +x', positive toward +y'.
///
/// ```
/// use firmware_sim::badminton::Config;
/// use firmware_sim::badminton::player::hit_velocity;
/// let hit = Config::builtin().hit;
/// let v = hit_velocity(&[-1.0, -1.0, 0.0], &hit); // 3 m/s at -30°, straight ahead
/// assert!((v[0] - 3.0 * 30f64.to_radians().cos()).abs() < 1e-12 && v[1] == 0.0 && v[2] < 0.0);
/// ```
pub fn hit_velocity(action: &[f32], hit: &HitConfig) -> Vec3 {
    let between = |u: f64, lo: f64, hi: f64| lo + (u + 1.0) / 2.0 * (hi - lo);
    let speed = between(unit(action, 0), hit.min_speed, hit.max_speed);
    let elevation = between(unit(action, 1), hit.min_elevation, hit.max_elevation).to_radians();
    let azimuth = (hit.max_azimuth * unit(action, 2)).to_radians();
    [
        speed * elevation.cos() * azimuth.cos(),
        speed * elevation.cos() * azimuth.sin(),
        speed * elevation.sin(),
    ]
}

/// The serve action that asks for a hit of this speed (m/s), elevation and azimuth (degrees):
/// the inverse of [`hit_velocity`], clamped to the box.
pub fn action_for_hit(speed: f64, elevation: f64, azimuth: f64, hit: &HitConfig) -> [f32; 3] {
    let unit_of =
        |v: f64, lo: f64, hi: f64| ((2.0 * (v - lo) / (hi - lo) - 1.0).clamp(-1.0, 1.0)) as f32;
    let azimuth = if hit.max_azimuth > 0.0 {
        (azimuth / hit.max_azimuth).clamp(-1.0, 1.0) as f32
    } else {
        0.0
    };
    [
        unit_of(speed, hit.min_speed, hit.max_speed),
        unit_of(elevation, hit.min_elevation, hit.max_elevation),
        azimuth,
    ]
}
