//! The plant/environment interface shared by training (host-trainer) and the firmware loop.
//!
//! Two views of one idea:
//! - [`Plant`], for any plant: declared observation and action boxes of any size per agent;
//!   several agents, each deciding at its own decision points while the plant runs its physics
//!   between them. Every call says who decides next and closes the transitions that ended:
//!   per agent, the reward since its previous decision, its next observation, and whether the
//!   episode ended for it (terminal) or was cut (truncated). On- and off-policy learners alike
//!   keep one open `(observation, action)` per agent and complete it from an [`Outcome`].
//! - [`Env`], Gymnasium-style, for the common case of one agent that decides every step:
//!   `reset(seed)` then `step(action)` until `terminated` or `truncated`. Every `Env` is a
//!   one-agent [`Plant`] (the blanket impl below), so navigation runs on the same interface.
//!
//! The policy sees only the observation; `info` tells the harness what really happened at the
//! margins (the motion the plant applied, whether a margin was touched).

/// A box `low[i] <= x[i] <= high[i]`.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxSpace {
    /// Lower bounds, one per dimension.
    pub low: Vec<f32>,
    /// Upper bounds, one per dimension.
    pub high: Vec<f32>,
}

impl BoxSpace {
    /// Number of dimensions.
    pub fn dim(&self) -> usize {
        self.low.len()
    }
}

/// What the plant did in a step, for the harness and the metrics; never shown to the policy.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// The motion the plant actually applied (after walls, limits, faults), in action units.
    pub applied: Vec<f32>,
    /// Whether the step touched a hard margin (a wall, a joint limit).
    pub margin_touched: bool,
    /// The plant's own verdict on the episode so far, if it has one (a goal reached): what a
    /// test protocol for any plant counts as success (docs/own-plant.md).
    pub success: Option<bool>,
}

/// The result of one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// The next observation.
    pub observation: Vec<f32>,
    /// The reward for this step.
    pub reward: f32,
    /// The episode ended in a terminal state (goal reached, left the arena).
    pub terminated: bool,
    /// The episode was cut by the time limit (not a terminal state for bootstrapping).
    pub truncated: bool,
    /// Ground truth about the step, for the harness.
    pub info: StepInfo,
}

/// A one-agent plant with declared observation and action boxes, deciding every step.
pub trait Env {
    /// The observation box (used for documentation and sanity checks; observations may be
    /// outside it only when the plant says so).
    fn observation_space(&self) -> &BoxSpace;
    /// The action box the actuator accepts; actions outside it are saturated by the plant.
    fn action_space(&self) -> &BoxSpace;
    /// Starts a new episode; the same seed gives the same start.
    fn reset(&mut self, seed: u64) -> Vec<f32>;
    /// Applies one action. Non-finite components are treated as 0 by every plant.
    fn step(&mut self, action: &[f32]) -> Step;
    /// Why the plant cannot go on, if it cannot: a plant in another process that exited, hung
    /// or answered out of its boxes. Such a plant ends every episode at once from then on, and
    /// the loop that runs it stops with this error. In-process plants never fail.
    fn failure(&self) -> Option<crate::Error> {
        None
    }
}

/// What one agent of a [`Plant`] is: its name and its boxes.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentSpec {
    /// Name used in reports, e.g. `p0.catch`.
    pub name: String,
    /// The observation box.
    pub observation_space: BoxSpace,
    /// The action box.
    pub action_space: BoxSpace,
}

/// The agent that must act now and what it sees.
#[derive(Clone, Debug, PartialEq)]
pub struct Decision {
    /// Index into [`Plant::agents`].
    pub agent: usize,
    /// Its observation.
    pub observation: Vec<f32>,
}

/// A transition of one agent that closed: from its previous decision to now.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// Index into [`Plant::agents`].
    pub agent: usize,
    /// Reward earned since its previous decision.
    pub reward: f32,
    /// Its next observation (at its next decision, or at the end of the episode).
    pub observation: Vec<f32>,
    /// The episode ended in a terminal state for this agent.
    pub terminated: bool,
    /// The episode was cut (not a terminal state for bootstrapping).
    pub truncated: bool,
    /// Ground truth, never shown to the agent: its body touched a hard margin during the
    /// transition (a wall; in badminton, a line or the net under its player's feet).
    pub margin_touched: bool,
}

/// What a [`Plant`] says after a reset or an action.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Turn {
    /// Who decides next; `None` once the episode has ended.
    pub decide: Option<Decision>,
    /// Transitions that closed since the previous call, in agent order.
    pub closed: Vec<Outcome>,
    /// Ground truth about the action just applied (empty after a reset): what the plant
    /// actually carried out and whether a margin was touched. A plant's own record of what
    /// happened between decisions (badminton's hits and how each flight ended) is on the plant.
    pub info: StepInfo,
}

/// A plant of any number of agents, each acting at its own decision points.
///
/// The plant runs its physics from one decision point to the next inside [`Plant::act`].
/// An agent's transitions link its own consecutive decisions: the [`Outcome`] that closes one
/// comes with the [`Turn`] in which that agent decides again, or with the end of the episode.
///
/// ```
/// use firmware_sim::env::Plant;
/// use firmware_sim::nav::NavEnv;
/// use firmware_sim::nav::scenario::Scenario;
/// // Navigation is the one-agent case: the same agent decides every step.
/// let mut nav = NavEnv::new(&Scenario::builtin("nav-open").unwrap()).unwrap();
/// assert_eq!(Plant::agents(&nav).len(), 1);
/// let turn = Plant::reset(&mut nav, 3);
/// let first = turn.decide.unwrap();
/// assert!(turn.closed.is_empty());
/// let turn = nav.act(&[0.0, 0.0]);
/// assert_eq!(turn.decide.unwrap().agent, 0);
/// assert_eq!(turn.closed[0].observation, first.observation);
/// ```
pub trait Plant: std::fmt::Debug {
    /// The agents, each with its boxes.
    fn agents(&self) -> Vec<AgentSpec>;
    /// Starts a new episode; the same seed gives the same start.
    fn reset(&mut self, seed: u64) -> Turn;
    /// Applies the action of the agent the last [`Turn`] named; runs the plant to the next
    /// decision point or the end of the episode. Non-finite components are treated as 0.
    fn act(&mut self, action: &[f32]) -> Turn;
    /// Why the plant cannot go on, if it cannot (see [`Env::failure`]).
    fn failure(&self) -> Option<crate::Error> {
        None
    }
}

/// Every one-agent [`Env`] is a [`Plant`] whose agent decides every step.
impl<E: Env + std::fmt::Debug> Plant for E {
    fn agents(&self) -> Vec<AgentSpec> {
        vec![AgentSpec {
            name: "agent".into(),
            observation_space: self.observation_space().clone(),
            action_space: self.action_space().clone(),
        }]
    }

    fn reset(&mut self, seed: u64) -> Turn {
        let observation = Env::reset(self, seed);
        Turn {
            decide: Some(Decision {
                agent: 0,
                observation,
            }),
            ..Turn::default()
        }
    }

    fn act(&mut self, action: &[f32]) -> Turn {
        let step = self.step(action);
        let ended = step.terminated || step.truncated;
        Turn {
            decide: (!ended).then(|| Decision {
                agent: 0,
                observation: step.observation.clone(),
            }),
            closed: vec![Outcome {
                agent: 0,
                reward: step.reward,
                observation: step.observation,
                terminated: step.terminated,
                truncated: step.truncated,
                margin_touched: step.info.margin_touched,
            }],
            info: step.info,
        }
    }

    fn failure(&self) -> Option<crate::Error> {
        Env::failure(self)
    }
}
