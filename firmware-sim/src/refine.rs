//! DCP's compare step in the loop: an actor blob and its critic blob, and before each action the
//! best of T proposals around the actor's action under the critic, as a chip could run it
//! (policy-core's [`refine_model`]).

use std::cell::Cell;
use std::rc::Rc;

use policy_core::compare::refine_model;
use policy_core::model::{Model, Scratch};
use policy_core::ModelKind;

use crate::controller::{Controller, SCRATCH_WIDTH};
use crate::error::Error;
use crate::seed::{stream, SimRng};

/// The largest action size the compare step is compiled for (policy-core's [`refine_model`]
/// holds proposals in arrays of the action size, as a chip would).
pub const MAX_REFINE_ACTIONS: usize = 4;

/// The most proposals per tick (host-trainer's DCP allows as many).
pub const MAX_T: usize = 4096;

/// Ticks run and ticks on which a proposal beat the actor's own action.
#[derive(Clone, Debug, Default)]
pub struct RefineCounts {
    ticks: Rc<Cell<u64>>,
    replaced: Rc<Cell<u64>>,
}

impl RefineCounts {
    /// (ticks, ticks on which a proposal replaced the actor's action).
    pub fn get(&self) -> (u64, u64) {
        (self.ticks.get(), self.replaced.get())
    }
}

/// An actor run through the compare step with its critic.
pub struct RefiningPolicy<'a> {
    actor: Model<'a>,
    critic: Model<'a>,
    scratch: Box<Scratch<SCRATCH_WIDTH>>,
    rng: SimRng,
    t: usize,
    sigma: f32,
    counts: RefineCounts,
}

impl core::fmt::Debug for RefiningPolicy<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("RefiningPolicy")
            .field("name", &self.name())
            .finish_non_exhaustive()
    }
}

impl<'a> RefiningPolicy<'a> {
    /// An actor model (already booted and checked against the plant) with a critic blob that
    /// must fit it: a critic taking the actor's observations and actions. Proposals draw from
    /// the stream `"refine"` of `seed`.
    ///
    /// ```
    /// use firmware_sim::controller::Controller;
    /// use firmware_sim::refine::RefiningPolicy;
    /// use policy_core::model::Model;
    /// static ACTOR: &[u8] = include_bytes!("../../policy-core/tests/golden/actor_2x32.postcard");
    /// static CRITIC: &[u8] = include_bytes!("../../policy-core/tests/golden/critic_2x32.postcard");
    /// let actor = Model::from_blob(ACTOR).unwrap();
    /// let mut p = RefiningPolicy::new(actor, CRITIC, 16, 0.2, 0).unwrap();
    /// let mut a = [0.0; 2];
    /// p.act(&[3.0, -1.0], &mut a);
    /// assert!(a.iter().all(|x| x.is_finite() && x.abs() <= 0.25));
    /// assert_eq!(p.counts().get().0, 1);
    /// assert!(RefiningPolicy::new(Model::from_blob(ACTOR).unwrap(), ACTOR, 16, 0.2, 0).is_err());
    /// ```
    pub fn new(
        actor: Model<'a>,
        critic: &'a [u8],
        t: usize,
        sigma: f32,
        seed: u64,
    ) -> Result<RefiningPolicy<'a>, Error> {
        let config = |message: String| Error::Config {
            field: "--critic/--refine",
            message,
        };
        if actor.header().kind != ModelKind::Actor {
            return Err(config(format!(
                "the compare step needs an actor blob, found a {}",
                actor.header().kind
            )));
        }
        let actions = actor.header().shape.actions as usize;
        if !(1..=MAX_REFINE_ACTIONS).contains(&actions) {
            return Err(config(format!(
                "the compare step runs actors of 1..={MAX_REFINE_ACTIONS} actions, found {actions}"
            )));
        }
        if !(sigma.is_finite() && sigma > 0.0) || t > MAX_T {
            return Err(config(format!(
                "expected T in 0..={MAX_T} and σ finite and > 0, found T {t}, σ {sigma}"
            )));
        }
        let critic = Model::from_blob(critic)?;
        if critic.header().kind != ModelKind::Critic {
            return Err(policy_core::Error::WrongKind {
                expected: ModelKind::Critic,
                found: critic.header().kind,
            }
            .into());
        }
        // The critic must score the actor's observations and actions.
        let observations = actor.header().shape.observations as usize;
        critic.expect_sizes(observations, actions)?;
        Ok(RefiningPolicy {
            actor,
            critic,
            scratch: Box::new(Scratch::new()),
            rng: stream(seed, "refine", 0),
            t,
            sigma,
            counts: RefineCounts::default(),
        })
    }

    /// The tick counters (shared: they stay readable after the policy is boxed).
    pub fn counts(&self) -> RefineCounts {
        self.counts.clone()
    }

    fn try_act(&mut self, obs: &[f32], action: &mut [f32]) -> Result<(), policy_core::Error> {
        let replaced = match action.len() {
            1 => self.refine_into::<1>(obs, action)?,
            2 => self.refine_into::<2>(obs, action)?,
            3 => self.refine_into::<3>(obs, action)?,
            _ => self.refine_into::<4>(obs, action)?,
        };
        self.counts.ticks.set(self.counts.ticks.get() + 1);
        let r = &self.counts.replaced;
        r.set(r.get() + u64::from(replaced));
        Ok(())
    }

    /// One compare step into `action` (of length `A`); whether a proposal won.
    fn refine_into<const A: usize>(
        &mut self,
        obs: &[f32],
        action: &mut [f32],
    ) -> Result<bool, policy_core::Error> {
        let r = refine_model::<A, SCRATCH_WIDTH, _>(
            &self.actor,
            &self.critic,
            obs,
            &mut self.scratch,
            &mut self.rng,
            self.t,
            self.sigma,
        )?;
        for (o, v) in action.iter_mut().zip(r.action) {
            *o = v;
        }
        Ok(r.winner > 0)
    }
}

impl Controller for RefiningPolicy<'_> {
    fn name(&self) -> String {
        format!(
            "blob {:?} {}x{} {} + critic, compare T {} σ {}",
            self.actor.header().label.as_str(),
            self.actor.header().shape.depth,
            self.actor.header().shape.width,
            self.actor.header().activation,
            self.t,
            self.sigma
        )
    }
    fn observations(&self) -> usize {
        self.actor.header().shape.observations as usize
    }
    fn actions(&self) -> usize {
        self.actor.header().shape.actions as usize
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        // Sizes were checked at boot; anything else gets the safe action, not a panic.
        if self.try_act(obs, action).is_err() {
            action.fill(0.0);
        }
    }
}
