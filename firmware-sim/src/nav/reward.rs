//! The reward forms of experiment 1 (docs/design.md §2): local progress, global distance, and
//! their mean. None of them mentions walls.

use serde::{Deserialize, Serialize};

/// The reward forms of the paper; none of them mentions walls.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reward {
    /// Local reward: progress toward the centre in the step divided by the step length
    /// (`max_step`), about `[-1, 1]`.
    Lr,
    /// Global reward: minus the distance to the centre divided by the arena half-size.
    Gr,
    /// The mean of LR and GR.
    #[serde(alias = "lr+gr")]
    LrGr,
}

impl Reward {
    /// The reward of a step from distance `before` to distance `after` from the centre.
    ///
    /// ```
    /// use firmware_sim::nav::Reward;
    /// assert_eq!(Reward::Lr.of_step(3.0, 2.75, 0.25, 6.0), 1.0);
    /// assert_eq!(Reward::Gr.of_step(3.0, 3.0, 0.25, 6.0), -0.5);
    /// assert_eq!(Reward::LrGr.of_step(3.0, 3.0, 0.25, 6.0), -0.25);
    /// ```
    pub fn of_step(self, before: f64, after: f64, step_length: f32, arena_half_size: f64) -> f32 {
        let lr = (before - after) / f64::from(step_length);
        let gr = -after / arena_half_size;
        let r = match self {
            Reward::Lr => lr,
            Reward::Gr => gr,
            Reward::LrGr => 0.5 * lr + 0.5 * gr,
        };
        r as f32
    }

    /// The lowest reward one step inside the arena can earn.
    ///
    /// The longest step is the box diagonal `√2 · max_step`, so LR ≥ -√2; the farthest point of
    /// the arena is its corner at `√2 · h`, so GR ≥ -√2; their mean is bounded the same way.
    pub fn worst(self) -> f32 {
        -core::f32::consts::SQRT_2
    }

    /// The reward for leaving the arena: `worst / (1 - gamma)`, no better than the discounted
    /// sum of the worst reward forever, so leaving never pays better than staying.
    ///
    /// ```
    /// use firmware_sim::nav::Reward;
    /// let exit = Reward::Lr.exit_penalty(0.99);
    /// assert!((exit + 141.421).abs() < 1e-2);
    /// ```
    pub fn exit_penalty(self, gamma: f32) -> f32 {
        self.worst() / (1.0 - gamma)
    }
}

impl core::fmt::Display for Reward {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Reward::Lr => "LR",
            Reward::Gr => "GR",
            Reward::LrGr => "LR+GR",
        })
    }
}
