//! The court, the two halves and the players' frames.
//!
//! x runs along the court with the net at x = 0, y across, z up. Player 0 owns x < 0 and sees
//! the world as it is; player 1 owns x > 0 and sees the world turned 180° about z
//! (x' = -x, y' = -y), so each plays from x' < 0 toward +x'. The turn is a sign flip, exact in
//! floating point, so a mirrored rally is bit for bit the mirror of the original.
//!
//! ```
//! use firmware_sim::badminton::court::{to_own, Court};
//! let court = Court { half_length: 6.7, half_width: 2.59, net_height: 1.55 };
//! assert_eq!(to_own(1, [3.0, -1.0, 2.0]), [-3.0, 1.0, 2.0]);
//! assert_eq!(court.clip_to_own_half([0.5, -4.0]), ([0.0, -2.59], true));
//! assert!(court.in_receiving_half([6.7, 2.59])); // lines are in
//! assert!(!court.in_receiving_half([6.71, 0.0]));
//! ```

use super::config::CourtConfig;

/// A point or vector in space, metres.
pub type Vec3 = [f64; 3];

/// A point on the floor, metres.
pub type Vec2 = [f64; 2];

/// The court's dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Court {
    /// Half the length (6.7).
    pub half_length: f64,
    /// Half the width (2.59).
    pub half_width: f64,
    /// Net height (1.55).
    pub net_height: f64,
}

impl Court {
    /// The court of a scenario.
    pub fn of(c: &CourtConfig) -> Court {
        Court {
            half_length: c.half_length,
            half_width: c.half_width,
            net_height: c.net_height,
        }
    }

    /// Whether a landing point, in the hitter's frame, is in the receiving half `[0, L] × [-W, W]`
    /// (lines count as in).
    pub fn in_receiving_half(&self, p: Vec2) -> bool {
        (0.0..=self.half_length).contains(&p[0]) && p[1].abs() <= self.half_width
    }

    /// A point of the own half `[-L, 0] × [-W, W]` (own frame) nearest to `p`, and whether `p` was
    /// outside it (a margin clipped the target). Non-finite coordinates become 0.
    pub fn clip_to_own_half(&self, p: Vec2) -> (Vec2, bool) {
        let finite = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (x, y) = (finite(p[0]), finite(p[1]));
        let clipped = [
            x.clamp(-self.half_length, 0.0),
            y.clamp(-self.half_width, self.half_width),
        ];
        (clipped, clipped != p)
    }

    /// Whether a point (own frame) lies on the boundary of the own half: a player there is
    /// touching a margin (the net or a line).
    pub fn on_margin(&self, p: Vec2) -> bool {
        p[0] == 0.0 || p[0] == -self.half_length || p[1].abs() == self.half_width
    }
}

/// The sign that turns world coordinates into player `player`'s frame: +1 for player 0, -1 for
/// player 1.
pub fn sign(player: usize) -> f64 {
    if player == 0 {
        1.0
    } else {
        -1.0
    }
}

/// A point or vector of space in player `player`'s frame (the turn is its own inverse, so this
/// also maps own-frame values back to the world).
pub fn to_own(player: usize, v: Vec3) -> Vec3 {
    let s = sign(player);
    [s * v[0], s * v[1], v[2]]
}

/// A floor point in player `player`'s frame (its own inverse too).
pub fn to_own2(player: usize, v: Vec2) -> Vec2 {
    let s = sign(player);
    [s * v[0], s * v[1]]
}

/// Euclidean distance.
pub fn distance(a: Vec3, b: Vec3) -> f64 {
    squared_distance(a, b).sqrt()
}

/// Squared Euclidean distance.
#[inline]
pub fn squared_distance(a: Vec3, b: Vec3) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}
