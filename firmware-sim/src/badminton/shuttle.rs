//! The shuttle: f64 state, quadratic drag, semi-implicit Euler, and the events of a flight.
//!
//! `dv/dt = g - k‖v‖v` with `g = (0, 0, -9.81)` and `k = g / v_t²`; one step is
//! `v ← v + dt·a(v)`, then `p ← p + dt·v`. Whatever happens inside a step (crossing the net
//! plane, touching the floor) is interpolated linearly between the step's two ends.
//!
//! ```
//! use firmware_sim::badminton::court::Court;
//! use firmware_sim::badminton::shuttle::{Fate, Physics, Shuttle};
//! let court = Court { half_length: 6.7, half_width: 2.59, net_height: 1.55 };
//! let physics = Physics { gravity: 9.81, drag: 9.81 / 6.8 / 6.8, dt: 0.001 };
//! // A clear from (-2, 0, 1.2) at 50° and 25 m/s lands in the far half.
//! let (e, s) = (50f64.to_radians(), 25.0);
//! let start = Shuttle { p: [-2.0, 0.0, 1.2], v: [s * e.cos(), 0.0, s * e.sin()] };
//! let flight = physics.predict(start, 1.0, &court, 1.2);
//! assert!(matches!(flight.fate, Fate::In(at) if at[0] > 0.0 && at[0] < 6.7));
//! // Straight down at the hitter's feet: it never crossed, a net ball.
//! let down = Shuttle { p: [-2.0, 0.0, 1.2], v: [0.0, 0.0, -5.0] };
//! assert_eq!(physics.predict(down, 1.0, &court, 1.2).fate, Fate::Net);
//! ```

use super::court::{Court, Vec2, Vec3};

/// Shuttle state in the world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shuttle {
    /// Position, m.
    pub p: Vec3,
    /// Velocity, m/s.
    pub v: Vec3,
}

/// The integrator and its constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Physics {
    /// Gravity, m/s².
    pub gravity: f64,
    /// Drag coefficient k, m⁻¹.
    pub drag: f64,
    /// Step, s.
    pub dt: f64,
}

/// How a flight ends if nobody catches it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fate {
    /// Lands in the receiving half at this point (world frame); lines count as in.
    In(Vec2),
    /// Lands outside the receiving half at this point (world frame).
    Out(Vec2),
    /// Crosses the net plane below the net, or lands on the hitter's own side.
    Net,
}

impl Fate {
    /// Whether the ball is the hitter's fault (out or net).
    pub fn is_fault(&self) -> bool {
        !matches!(self, Fate::In(_))
    }
}

/// What a step of a flight did, as [`Flight::advance`] sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Nothing: the flight goes on.
    Flying,
    /// The flight ended, at this point (the interpolated crossing or landing point).
    Ended(Fate, Vec3),
}

/// A flight being followed step by step: which side receives and whether it has crossed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flight {
    /// +1 when the receiver owns x > 0 (the hitter is player 0), -1 otherwise.
    pub side: f64,
    /// The shuttle has crossed the net plane above the net.
    pub crossed: bool,
}

/// A whole flight computed ahead: its fate, where it falls through the hitting height on its way
/// down in the receiving half, and its length in steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// How it ends if nobody catches it.
    pub fate: Fate,
    /// The point (world frame) where it falls through `hit_height` after crossing, if it does.
    pub descent: Option<Vec3>,
    /// Steps to the end.
    pub steps: u64,
}

impl Physics {
    /// The physics of a scenario.
    pub fn of(config: &super::Config) -> Physics {
        Physics {
            gravity: config.shuttle.gravity,
            drag: config.drag(),
            dt: config.shuttle.dt,
        }
    }

    /// One semi-implicit Euler step.
    ///
    /// ```
    /// use firmware_sim::badminton::shuttle::{Physics, Shuttle};
    /// let physics = Physics { gravity: 10.0, drag: 0.0, dt: 0.5 };
    /// let mut s = Shuttle { p: [0.0; 3], v: [1.0, 0.0, 0.0] };
    /// physics.step(&mut s);
    /// assert_eq!(s.v, [1.0, 0.0, -5.0]);
    /// assert_eq!(s.p, [0.5, 0.0, -2.5]); // the new velocity moves the position
    /// ```
    #[inline]
    pub fn step(&self, s: &mut Shuttle) {
        let v = s.v;
        let kv = self.drag * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let dt = self.dt;
        s.v = [
            v[0] - dt * kv * v[0],
            v[1] - dt * kv * v[1],
            v[2] - dt * (self.gravity + kv * v[2]),
        ];
        s.p = [
            s.p[0] + dt * s.v[0],
            s.p[1] + dt * s.v[1],
            s.p[2] + dt * s.v[2],
        ];
    }

    /// Follows a flight to its end without anyone catching it.
    pub fn predict(&self, start: Shuttle, side: f64, court: &Court, hit_height: f64) -> Prediction {
        let mut flight = Flight {
            side,
            crossed: false,
        };
        let (mut s, mut descent, mut steps) = (start, None, 0);
        loop {
            let before = s;
            self.step(&mut s);
            steps += 1;
            if let Event::Ended(fate, _) = flight.advance(&before, &s, court) {
                return Prediction {
                    fate,
                    descent: descent.or(match fate {
                        Fate::In(at) | Fate::Out(at) => Some([at[0], at[1], 0.0]),
                        Fate::Net => None,
                    }),
                    steps,
                };
            }
            if flight.crossed && before.p[2] > hit_height && s.p[2] <= hit_height {
                descent = Some(lerp(
                    &before.p,
                    &s.p,
                    fraction(before.p[2] - hit_height, s.p[2] - hit_height),
                ));
            }
        }
    }
}

impl Flight {
    /// A flight hit by player `hitter` (0 or 1).
    pub fn by(hitter: usize) -> Flight {
        Flight {
            side: super::court::sign(hitter),
            crossed: false,
        }
    }

    /// Judges the step from `before` to `after`: a crossing of the net plane (above the net:
    /// crossed; below: a net ball), a landing (in, out, or on the hitter's own side: net).
    /// When both happen inside one step, the earlier decides.
    #[inline(always)]
    pub fn advance(&mut self, before: &Shuttle, after: &Shuttle, court: &Court) -> Event {
        let (x0, x1) = (self.side * before.p[0], self.side * after.p[0]);
        // Most steps neither cross the net plane nor reach the floor: that test stays inline.
        if after.p[2] > 0.0 && (self.crossed || x1 <= 0.0 || x0 > 0.0) {
            return Event::Flying;
        }
        self.judge(before, after, court)
    }

    #[inline(never)]
    fn judge(&mut self, before: &Shuttle, after: &Shuttle, court: &Court) -> Event {
        let (x0, x1) = (self.side * before.p[0], self.side * after.p[0]);
        let crossing = (!self.crossed && x0 <= 0.0 && x1 > 0.0).then(|| fraction(x0, x1));
        let landing = (after.p[2] <= 0.0).then(|| fraction(before.p[2], after.p[2]));
        match (crossing, landing) {
            (Some(tc), Some(tl)) if tl <= tc => self.land(before, after, tl, court),
            (Some(tc), _) => {
                let at = lerp(&before.p, &after.p, tc);
                if at[2] < court.net_height {
                    return Event::Ended(Fate::Net, at);
                }
                self.crossed = true;
                match landing {
                    Some(tl) => self.land(before, after, tl, court),
                    None => Event::Flying,
                }
            }
            (None, Some(tl)) => self.land(before, after, tl, court),
            (None, None) => Event::Flying,
        }
    }

    fn land(&self, before: &Shuttle, after: &Shuttle, t: f64, court: &Court) -> Event {
        let at = lerp(&before.p, &after.p, t);
        let point = [at[0], at[1]];
        if !self.crossed {
            return Event::Ended(Fate::Net, at);
        }
        let own = [self.side * at[0], self.side * at[1]];
        let fate = if court.in_receiving_half(own) {
            Fate::In(point)
        } else {
            Fate::Out(point)
        };
        Event::Ended(fate, at)
    }
}

/// Where, between `a` (at 0) and `b` (at 1), a linear quantity with these end values is 0.
fn fraction(a: f64, b: f64) -> f64 {
    if a == b {
        1.0
    } else {
        (a / (a - b)).clamp(0.0, 1.0)
    }
}

fn lerp(a: &Vec3, b: &Vec3, t: f64) -> Vec3 {
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
    ]
}
