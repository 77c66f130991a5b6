//! A plant that does nothing: every observation is zeros, every reward 0, and an episode is cut
//! after a fixed number of steps. Served over the link (`firmware-sim serve-plant --null`), it
//! measures what the link itself costs per step (`cargo bench -p firmware-sim --bench
//! plant_link`), with no physics to hide it.

use crate::env::{BoxSpace, Env, Step, StepInfo};

/// Steps per episode of the null plant (the navigation tasks' time limit).
pub const EPISODE_STEPS: u32 = 200;

/// The plant that does nothing, of any size.
#[derive(Clone, Debug)]
pub struct NullPlant {
    observation_space: BoxSpace,
    action_space: BoxSpace,
    steps: u32,
}

impl NullPlant {
    /// A null plant of `observations` values observed and `actions` values acted, each in
    /// `[-1, 1]`.
    ///
    /// ```
    /// use firmware_sim::env::Env;
    /// use firmware_sim::plant_link::null::NullPlant;
    /// let mut plant = NullPlant::new(3, 1);
    /// assert_eq!(plant.reset(7), [0.0; 3]);
    /// let step = plant.step(&[0.5]);
    /// assert_eq!((step.reward, step.terminated, step.info.applied), (0.0, false, vec![0.5]));
    /// ```
    pub fn new(observations: usize, actions: usize) -> NullPlant {
        let unit = |n| BoxSpace {
            low: vec![-1.0; n],
            high: vec![1.0; n],
        };
        NullPlant {
            observation_space: unit(observations),
            action_space: unit(actions),
            steps: 0,
        }
    }
}

impl Env for NullPlant {
    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    fn reset(&mut self, _seed: u64) -> Vec<f32> {
        self.steps = 0;
        vec![0.0; self.observation_space.dim()]
    }

    fn step(&mut self, action: &[f32]) -> Step {
        self.steps += 1;
        Step {
            observation: vec![0.0; self.observation_space.dim()],
            reward: 0.0,
            terminated: false,
            truncated: self.steps >= EPISODE_STEPS,
            info: StepInfo {
                applied: action.iter().map(|&a| a.clamp(-1.0, 1.0)).collect(),
                margin_touched: false,
                success: None,
            },
        }
    }
}
