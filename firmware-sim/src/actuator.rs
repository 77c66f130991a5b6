//! The actuator of the firmware loop: the last line of defence before the plant.
//!
//! Whatever the controller writes (NaN, infinities, huge values), what leaves the actuator is
//! finite and inside the action box: non-finite commands become 0, everything is saturated at
//! the box bounds, an optional rate limit bounds the change per tick, and a stuck fault freezes
//! one dimension.

use serde::{Deserialize, Serialize};

/// From `from_tick` on, actuator dimension `dim` keeps the value it had just before.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ActuatorStuck {
    /// The stuck dimension.
    pub dim: usize,
    /// First tick (0-based) at which it is stuck.
    pub from_tick: u32,
}

/// Actuator settings (saturation is always on; the rest is off by default).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActuatorModel {
    /// Largest change of each dimension per tick, or `None` for no limit.
    pub rate_limit: Option<f32>,
}

/// An actuator in use during one episode.
#[derive(Debug)]
pub(crate) struct Actuator {
    low: Vec<f32>,
    high: Vec<f32>,
    model: ActuatorModel,
    stuck: Option<ActuatorStuck>,
    previous: Vec<f32>,
    /// Commands that were not finite and were replaced by 0.
    pub(crate) sanitized: u64,
}

impl Actuator {
    pub(crate) fn new(
        low: &[f32],
        high: &[f32],
        model: ActuatorModel,
        stuck: Option<ActuatorStuck>,
    ) -> Self {
        Self {
            low: low.to_vec(),
            high: high.to_vec(),
            model,
            stuck,
            previous: vec![0.0; low.len()],
            sanitized: 0,
        }
    }

    /// Turns the controller's command into what the plant receives at `tick`.
    pub(crate) fn drive(&mut self, tick: u32, command: &[f32], out: &mut [f32]) {
        for (i, o) in out.iter_mut().enumerate() {
            let c = command.get(i).copied().unwrap_or(0.0);
            let mut a = if c.is_finite() {
                c
            } else {
                self.sanitized += 1;
                0.0
            };
            if let Some(r) = self.model.rate_limit {
                a = a.clamp(self.previous[i] - r, self.previous[i] + r);
            }
            if matches!(self.stuck, Some(s) if s.dim == i && tick >= s.from_tick) {
                a = self.previous[i];
            }
            *o = a.clamp(self.low[i], self.high[i]);
            self.previous[i] = *o;
        }
    }

    /// Whether `action` is finite and inside the box (checked before every plant step).
    pub(crate) fn in_bounds(&self, action: &[f32]) -> bool {
        action
            .iter()
            .zip(self.low.iter().zip(&self.high))
            .all(|(a, (lo, hi))| a.is_finite() && a >= lo && a <= hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn any_command() -> impl Strategy<Value = f32> {
        prop_oneof![
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(f32::NEG_INFINITY),
            any::<f32>(),
            -1.0f32..1.0
        ]
    }

    proptest! {
        /// Whatever the controller writes, with or without rate limit and stuck fault, the
        /// plant receives finite values inside the box, and the rate limit holds.
        #[test]
        fn output_is_finite_in_bounds_and_rate_limited(
            commands in proptest::collection::vec((any_command(), any_command()), 1..50),
            rate in proptest::option::of(0.001f32..0.5),
            stuck_at in proptest::option::of(0u32..50),
        ) {
            let stuck = stuck_at.map(|from_tick| ActuatorStuck { dim: 1, from_tick });
            let mut act = Actuator::new(&[-0.25, -0.25], &[0.25, 0.25], ActuatorModel { rate_limit: rate }, stuck);
            let mut prev = [0.0f32; 2];
            for (tick, (x, y)) in commands.into_iter().enumerate() {
                let mut out = [0.0f32; 2];
                act.drive(tick as u32, &[x, y], &mut out);
                prop_assert!(act.in_bounds(&out), "{out:?}");
                if let Some(r) = rate {
                    prop_assert!(out.iter().zip(&prev).all(|(a, p)| (a - p).abs() <= r * 1.0001));
                }
                if matches!(stuck, Some(s) if tick as u32 >= s.from_tick) {
                    prop_assert_eq!(out[1], prev[1]);
                }
                prev = out;
            }
        }
    }
}
