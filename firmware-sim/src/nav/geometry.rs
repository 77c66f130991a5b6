//! Exact motion among zero-thickness wall segments: slide along walls, never through them.
//!
//! A wall is a segment with no thickness. Moving into it keeps only the component of the motion
//! parallel to it; a step can slide along several walls in turn and stops in a corner.
//!
//! Why it is robust: positions are `f64` and the mover keeps a tiny clearance
//! [`CLEARANCE`] (1e-5) from every wall. Motion is swept against each wall's "capsule" (the
//! points within the clearance of the segment), so a move stops where it would come closer than
//! the clearance; the remaining motion is projected onto the free directions and swept again,
//! at most [`MAX_SUBMOVES`] times. Because the mover is always about 1e-5 away from every wall
//! while rounding errors are about 1e-15, which side of a wall it is on is never in doubt, and a
//! final check refuses any sub-move whose path comes within half the clearance of a wall. So no
//! step size and no rounding can carry the mover through a wall (tunnelling), and even the `f32`
//! observation (rounding error below 5e-7 in a 6-unit arena) stays on the right side.
//!
//! ```
//! use firmware_sim::nav::geometry::{resolve, CLEARANCE, Segment, Vec2};
//! // A horizontal wall at y = 0; the mover is above it and steps down and to the right.
//! let wall = Segment::new(Vec2::new(-5.0, 0.0), Vec2::new(5.0, 0.0));
//! let m = resolve(Vec2::new(0.0, 0.1), Vec2::new(0.2, -0.3), &[wall]);
//! assert!(m.touched);
//! assert!((m.end.x - 0.2).abs() < 1e-12); // the parallel component survives in full
//! assert!((m.end.y - CLEARANCE).abs() < 1e-12); // the normal one is stopped at the wall
//! ```

use serde::{Deserialize, Serialize};

/// Distance the mover keeps from every wall.
pub const CLEARANCE: f64 = 1e-5;
/// Most sweeps one step may take (each contact or slide costs one).
pub const MAX_SUBMOVES: usize = 16;
/// A mover within `CLEARANCE * (1 + CONTACT_SLACK)` of a wall is in contact with it.
const CONTACT_SLACK: f64 = 1e-6;
/// Most walls the mover can touch at once (more is impossible in any sane layout; the final
/// path check still guards against crossing if it ever happened).
const MAX_CONTACTS: usize = 8;

/// A point or displacement in the plane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vec2 {
    /// First coordinate.
    pub x: f64,
    /// Second coordinate.
    pub y: f64,
}

impl Vec2 {
    /// The origin.
    pub const ZERO: Vec2 = Vec2 { x: 0.0, y: 0.0 };

    /// A vector from its coordinates.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Dot product.
    pub fn dot(self, o: Vec2) -> f64 {
        self.x * o.x + self.y * o.y
    }

    /// The z component of the cross product (positive when `o` is counter-clockwise of `self`).
    pub fn cross(self, o: Vec2) -> f64 {
        self.x * o.y - self.y * o.x
    }

    /// Euclidean length.
    pub fn norm(self) -> f64 {
        self.dot(self).sqrt()
    }

    /// `self * k`.
    pub fn scale(self, k: f64) -> Vec2 {
        Vec2::new(self.x * k, self.y * k)
    }

    /// The vector turned a quarter turn counter-clockwise.
    pub fn perp(self) -> Vec2 {
        Vec2::new(-self.y, self.x)
    }
}

impl core::ops::Add for Vec2 {
    type Output = Vec2;
    fn add(self, o: Vec2) -> Vec2 {
        Vec2::new(self.x + o.x, self.y + o.y)
    }
}

impl core::ops::Sub for Vec2 {
    type Output = Vec2;
    fn sub(self, o: Vec2) -> Vec2 {
        Vec2::new(self.x - o.x, self.y - o.y)
    }
}

/// A wall: the segment from `a` to `b`, zero thickness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// One end.
    pub a: Vec2,
    /// The other end.
    pub b: Vec2,
}

impl Segment {
    /// The segment from `a` to `b`.
    pub const fn new(a: Vec2, b: Vec2) -> Self {
        Self { a, b }
    }

    /// Length of the segment.
    ///
    /// ```
    /// use firmware_sim::nav::geometry::{Segment, Vec2};
    /// assert_eq!(Segment::new(Vec2::new(0.0, 0.0), Vec2::new(3.0, 4.0)).length(), 5.0);
    /// ```
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }

    /// The point of the segment closest to `p`.
    ///
    /// ```
    /// use firmware_sim::nav::geometry::{Segment, Vec2};
    /// let s = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
    /// assert_eq!(s.closest_point(Vec2::new(0.5, 1.0)), Vec2::new(0.5, 0.0));
    /// assert_eq!(s.closest_point(Vec2::new(-3.0, 1.0)), Vec2::new(0.0, 0.0));
    /// ```
    pub fn closest_point(&self, p: Vec2) -> Vec2 {
        let w = self.b - self.a;
        let len2 = w.dot(w);
        if len2 == 0.0 {
            return self.a;
        }
        let t = ((p - self.a).dot(w) / len2).clamp(0.0, 1.0);
        self.a + w.scale(t)
    }

    /// Distance from `p` to the segment.
    ///
    /// ```
    /// use firmware_sim::nav::geometry::{Segment, Vec2};
    /// let s = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
    /// assert_eq!(s.distance(Vec2::new(1.0, 3.0)), 3.0);
    /// assert_eq!(s.distance(Vec2::new(5.0, 4.0)), 5.0);
    /// ```
    pub fn distance(&self, p: Vec2) -> f64 {
        (p - self.closest_point(p)).norm()
    }

    /// Whether the two segments cross or touch (orientation test).
    ///
    /// ```
    /// use firmware_sim::nav::geometry::{Segment, Vec2};
    /// let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
    /// assert!(a.intersects(&Segment::new(Vec2::new(1.0, -1.0), Vec2::new(1.0, 1.0))));
    /// assert!(a.intersects(&Segment::new(Vec2::new(2.0, 0.0), Vec2::new(3.0, 1.0)))); // touching
    /// assert!(!a.intersects(&Segment::new(Vec2::new(3.0, 0.0), Vec2::new(4.0, 0.0))));
    /// ```
    pub fn intersects(&self, o: &Segment) -> bool {
        let d1 = (self.b - self.a).cross(o.a - self.a);
        let d2 = (self.b - self.a).cross(o.b - self.a);
        let d3 = (o.b - o.a).cross(self.a - o.a);
        let d4 = (o.b - o.a).cross(self.b - o.a);
        d1 * d2 <= 0.0 && d3 * d4 <= 0.0 && !(d1 == 0.0 && d2 == 0.0 && !self.overlaps_collinear(o))
    }

    fn overlaps_collinear(&self, o: &Segment) -> bool {
        let in_box = |p: Vec2, s: &Segment| {
            p.x >= s.a.x.min(s.b.x)
                && p.x <= s.a.x.max(s.b.x)
                && p.y >= s.a.y.min(s.b.y)
                && p.y <= s.a.y.max(s.b.y)
        };
        in_box(o.a, self) || in_box(o.b, self) || in_box(self.a, o) || in_box(self.b, o)
    }

    /// Smallest distance between a point of `self` and a point of `o`.
    ///
    /// ```
    /// use firmware_sim::nav::geometry::{Segment, Vec2};
    /// let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
    /// let b = Segment::new(Vec2::new(1.0, 1.0), Vec2::new(1.0, 3.0));
    /// assert_eq!(a.distance_to_segment(&b), 1.0);
    /// let c = Segment::new(Vec2::new(1.0, -1.0), Vec2::new(1.0, 1.0));
    /// assert_eq!(a.distance_to_segment(&c), 0.0);
    /// ```
    pub fn distance_to_segment(&self, o: &Segment) -> f64 {
        if self.intersects(o) {
            return 0.0;
        }
        self.distance(o.a)
            .min(self.distance(o.b))
            .min(o.distance(self.a))
            .min(o.distance(self.b))
    }

    /// The earliest `t` in `[0, 1]` at which `p + t r` comes within [`CLEARANCE`] of the
    /// segment, if it does and `p` is not already that close.
    fn sweep(&self, p: Vec2, r: Vec2) -> Option<f64> {
        let side = self.sweep_side(p, r);
        let caps = [self.a, self.b].map(|e| sweep_circle(p - e, r));
        [side, caps[0], caps[1]]
            .into_iter()
            .flatten()
            .min_by(f64::total_cmp)
    }

    /// Entry through one of the two long sides of the capsule.
    fn sweep_side(&self, p: Vec2, r: Vec2) -> Option<f64> {
        let w = self.b - self.a;
        let len = w.norm();
        if len == 0.0 {
            return None;
        }
        let tau = w.scale(1.0 / len);
        let n = tau.perp();
        let s0 = n.dot(p - self.a);
        let sr = n.dot(r);
        if s0.abs() <= CLEARANCE * (1.0 + CONTACT_SLACK) || s0 * sr >= 0.0 {
            return None;
        }
        let t = (CLEARANCE.copysign(s0) - s0) / sr;
        let u = tau.dot(p + r.scale(t) - self.a);
        ((0.0..=1.0).contains(&t) && (0.0..=len).contains(&u)).then_some(t)
    }
}

/// Entry into the disc of radius [`CLEARANCE`] around a wall end, for a mover at offset `f`
/// from it moving by `r`.
fn sweep_circle(f: Vec2, r: Vec2) -> Option<f64> {
    let a = r.dot(r);
    let b = f.dot(r);
    let c = f.dot(f) - CLEARANCE * CLEARANCE;
    if a == 0.0 || c <= 0.0 || b >= 0.0 {
        return None;
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / a;
    (0.0..=1.0).contains(&t).then_some(t)
}

/// The outcome of one resolved move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Where the mover ends.
    pub end: Vec2,
    /// Whether a wall removed any part of the motion.
    pub touched: bool,
}

/// Moves from `p` by `delta` among `walls`: slides along walls, stops in corners, never crosses.
///
/// `p` must keep the clearance from every wall (see [`push_out`]); the end point does too.
pub fn resolve(p: Vec2, delta: Vec2, walls: &[Segment]) -> Motion {
    resolve_traced(p, delta, walls, |_, _| {})
}

/// [`resolve`], calling `submove(from, to)` for every straight piece of the path (for tests and
/// plots: each piece is checked clear of every wall before it is taken).
pub fn resolve_traced(
    p: Vec2,
    delta: Vec2,
    walls: &[Segment],
    mut submove: impl FnMut(Vec2, Vec2),
) -> Motion {
    // The whole path, slides included, stays within |delta| of p (each slide only shortens
    // the remaining motion), so walls whose bounding box is farther cannot matter.
    let mut nearby = [Segment::new(Vec2::ZERO, Vec2::ZERO); MAX_NEARBY];
    let walls = match nearby_walls(p, delta.norm() + 2.0 * CLEARANCE, walls, &mut nearby) {
        Some(n) => &nearby[..n],
        None => walls,
    };
    let mut at = p;
    let mut remaining = delta;
    let mut touched = false;
    for _ in 0..MAX_SUBMOVES {
        let (free, blocked) = constrain(at, remaining, walls);
        touched |= blocked;
        remaining = free;
        if remaining.dot(remaining) < 1e-24 {
            return Motion { end: at, touched };
        }
        let hit = walls
            .iter()
            .filter_map(|w| w.sweep(at, remaining))
            .min_by(f64::total_cmp);
        let t = hit.unwrap_or(1.0);
        let next = at + remaining.scale(t);
        if !path_is_clear(at, next, walls) {
            return Motion {
                end: at,
                touched: true,
            };
        }
        submove(at, next);
        at = next;
        if hit.is_none() {
            return Motion { end: at, touched };
        }
        touched = true;
        remaining = remaining.scale(1.0 - t);
    }
    // Out of sweeps: the rest of the motion is dropped (only in deep, narrow corners).
    Motion {
        end: at,
        touched: true,
    }
}

/// Most nearby walls copied to the stack; with more, every wall is checked.
const MAX_NEARBY: usize = 32;

/// Copies the walls whose bounding box comes within `reach` of `p` into `out`; `None` if there
/// are more than `out` holds.
fn nearby_walls(p: Vec2, reach: f64, walls: &[Segment], out: &mut [Segment]) -> Option<usize> {
    let mut n = 0;
    for w in walls {
        let far = p.x + reach < w.a.x.min(w.b.x)
            || p.x - reach > w.a.x.max(w.b.x)
            || p.y + reach < w.a.y.min(w.b.y)
            || p.y - reach > w.a.y.max(w.b.y);
        if !far {
            *out.get_mut(n)? = *w;
            n += 1;
        }
    }
    Some(n)
}

/// Removes from `r` every component that points into a wall the mover at `p` touches.
///
/// With one active contact this is the projection onto the wall's direction. With several, it
/// is the longest single projection that respects every contact, or nothing (a corner).
fn constrain(p: Vec2, r: Vec2, walls: &[Segment]) -> (Vec2, bool) {
    let mut normals = [Vec2::ZERO; MAX_CONTACTS];
    let mut count = 0;
    for w in walls {
        if count == MAX_CONTACTS {
            break;
        }
        if let Some(n) = contact_normal(p, w) {
            normals[count] = n;
            count += 1;
        }
    }
    let normals = &normals[..count];
    if normals.iter().all(|n| r.dot(*n) >= 0.0) {
        return (r, false);
    }
    let respects = |c: Vec2| normals.iter().all(|m| c.dot(*m) >= -1e-12 * r.norm());
    let best = normals
        .iter()
        .filter(|n| r.dot(**n) < 0.0)
        .map(|n| r - n.scale(r.dot(*n)))
        .filter(|c| respects(*c))
        .max_by(|a, b| a.dot(*a).total_cmp(&b.dot(*b)));
    (best.unwrap_or(Vec2::ZERO), true)
}

/// The unit normal pointing from a touched wall to the mover, if the mover touches it.
///
/// Beside the wall the normal is the wall's own (exact: a radial direction computed from a
/// 1e-5 offset would be tilted by rounding and leak normal motion into the slide); at a wall
/// end it points radially away from the end.
fn contact_normal(p: Vec2, w: &Segment) -> Option<Vec2> {
    let c = w.closest_point(p);
    let d = (p - c).norm();
    if d > CLEARANCE * (1.0 + CONTACT_SLACK) {
        return None;
    }
    let dir = w.b - w.a;
    let len = dir.norm();
    if len == 0.0 {
        return (d > 0.0).then(|| (p - c).scale(1.0 / d));
    }
    if (c != w.a && c != w.b) || d == 0.0 {
        let n = dir.perp().scale(1.0 / len);
        return Some(if n.dot(p - w.a) < 0.0 {
            n.scale(-1.0)
        } else {
            n
        });
    }
    Some((p - c).scale(1.0 / d))
}

/// Whether the straight path from `p` to `q` keeps at least half the clearance from every wall.
fn path_is_clear(p: Vec2, q: Vec2, walls: &[Segment]) -> bool {
    let path = Segment::new(p, q);
    walls
        .iter()
        .all(|w| w.distance_to_segment(&path) >= 0.5 * CLEARANCE)
}

/// Moves `p` the least amount needed to keep the clearance from every wall (used when a
/// start point or a new wall would violate it). A point exactly on a wall goes to the wall's
/// left side (seen from `a` to `b`).
///
/// ```
/// use firmware_sim::nav::geometry::{push_out, CLEARANCE, Segment, Vec2};
/// let wall = Segment::new(Vec2::new(-1.0, 0.0), Vec2::new(1.0, 0.0));
/// let p = push_out(Vec2::new(0.3, -1e-9), &[wall]);
/// assert!(p.y < -CLEARANCE && p.y > -2.0 * CLEARANCE);
/// ```
pub fn push_out(p: Vec2, walls: &[Segment]) -> Vec2 {
    let mut at = p;
    for _ in 0..MAX_SUBMOVES {
        let mut moved = false;
        for w in walls {
            if let Some(n) = contact_normal(at, w) {
                let c = w.closest_point(at);
                let d = (at - c).norm();
                if d < CLEARANCE * (1.0 + 2.0 * CONTACT_SLACK) {
                    at = at + n.scale(CLEARANCE * 1.001 - d);
                    moved = true;
                }
            }
        }
        if !moved {
            break;
        }
    }
    at
}

/// The smallest distance from `p` to any wall (infinite without walls).
///
/// ```
/// use firmware_sim::nav::geometry::{nearest_wall_distance, Segment, Vec2};
/// let walls = [Segment::new(Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0))];
/// assert_eq!(nearest_wall_distance(Vec2::new(0.5, 0.0), &walls), 1.0);
/// assert_eq!(nearest_wall_distance(Vec2::ZERO, &[]), f64::INFINITY);
/// ```
pub fn nearest_wall_distance(p: Vec2, walls: &[Segment]) -> f64 {
    walls
        .iter()
        .map(|w| w.distance(p))
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
        Segment::new(Vec2::new(ax, ay), Vec2::new(bx, by))
    }

    #[test]
    fn free_motion_is_exact() {
        let m = resolve(
            Vec2::new(1.0, 1.0),
            Vec2::new(0.25, -0.25),
            &[wall(3.0, 0.0, 3.0, 5.0)],
        );
        assert_eq!(m.end, Vec2::new(1.25, 0.75));
        assert!(!m.touched);
    }

    #[test]
    fn stops_in_a_right_angle_corner() {
        let walls = [wall(0.0, 0.0, 2.0, 0.0), wall(0.0, 0.0, 0.0, 2.0)];
        let m = resolve(Vec2::new(0.1, 0.05), Vec2::new(-0.25, -0.25), &walls);
        assert!((m.end.x - CLEARANCE).abs() < 1e-12 && (m.end.y - CLEARANCE).abs() < 1e-12);
        assert!(m.touched);
    }

    #[test]
    fn slides_along_two_walls_in_turn() {
        // Down onto the floor, then right along it into an obtuse ramp, then up the ramp.
        let walls = [wall(-1.0, 0.0, 1.0, 0.0), wall(1.0, 0.0, 2.0, 1.0)];
        let m = resolve(Vec2::new(0.9, 0.05), Vec2::new(0.25, -0.1), &walls);
        assert!(m.touched);
        assert!(
            m.end.x > 1.0 && m.end.y > 0.0,
            "climbed the ramp: {:?}",
            m.end
        );
        assert!(walls.iter().all(|w| w.distance(m.end) >= 0.5 * CLEARANCE));
    }

    #[test]
    fn passes_around_a_wall_end() {
        let m = resolve(
            Vec2::new(1.1, 0.1),
            Vec2::new(0.0, -0.2),
            &[wall(-1.0, 0.0, 1.0, 0.0)],
        );
        assert_eq!(m.end, Vec2::new(1.1, 0.1) + Vec2::new(0.0, -0.2));
        assert!(!m.touched);
    }

    #[test]
    fn a_point_on_a_wall_is_pushed_out() {
        let w = wall(-1.0, 0.0, 1.0, 0.0);
        let p = push_out(Vec2::new(0.0, 0.0), &[w]);
        assert!(w.distance(p) >= CLEARANCE);
    }
}
