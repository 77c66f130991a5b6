//! The `straight` reference controller: it heads for the centre at full speed and ignores the
//! walls, the naive policy a wall catches. [`step_toward`] is the step every navigation
//! reference controller takes toward its target.

use crate::controller::Controller;

/// Heads straight for the centre at full speed: the naive policy a wall catches.
#[derive(Clone, Copy, Debug)]
pub struct Straight {
    /// Largest step per axis.
    pub max_step: f32,
}

impl Controller for Straight {
    fn name(&self) -> String {
        "straight".into()
    }
    fn observations(&self) -> usize {
        2
    }
    fn actions(&self) -> usize {
        2
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        let to = step_toward([obs[0], obs[1]], [0.0, 0.0], self.max_step);
        action.copy_from_slice(&to);
    }
}

/// The step from `from` toward `to`: the full step along the direction (largest component
/// `max_step`, so the direction is kept exactly inside the box), or exactly the remaining
/// offset when it is shorter. A non-finite input gives no motion.
///
/// ```
/// use firmware_sim::nav::straight::step_toward;
/// assert_eq!(step_toward([4.0, 2.0], [0.0, 0.0], 0.25), [-0.25, -0.125]);
/// assert_eq!(step_toward([0.1, 0.0], [0.0, 0.0], 0.25), [-0.1, 0.0]);
/// assert_eq!(step_toward([f32::NAN, 0.0], [0.0, 0.0], 0.25), [0.0, 0.0]);
/// ```
pub fn step_toward(from: [f32; 2], to: [f32; 2], max_step: f32) -> [f32; 2] {
    let d = [to[0] - from[0], to[1] - from[1]];
    // `f32::max` ignores NaN, so finiteness is checked per component.
    if !d.iter().all(|v| v.is_finite()) {
        return [0.0, 0.0];
    }
    let big = d[0].abs().max(d[1].abs());
    if big <= max_step {
        return d;
    }
    let k = max_step / big;
    [d[0] * k, d[1] * k]
}
