//! An actor of several heads in the loop: the actor blob outputs K actions per observation and
//! its critic blob chooses one each tick, as a chip could run it (policy-core's
//! [`choose_head`]). DCP's `heads` setting trains such actors; the pair of blobs is the policy.

use std::cell::RefCell;
use std::rc::Rc;

use policy_core::compare::choose_head;
use policy_core::model::{Model, Scratch};
use policy_core::ModelKind;

use crate::boot::{or_safe_state, plant_error, PlantSizes};
use crate::controller::{Controller, SCRATCH_WIDTH};
use crate::error::Error;

/// How often each head was chosen, shared so it stays readable after the policy is boxed.
#[derive(Clone, Debug, Default)]
pub struct HeadCounts(Rc<RefCell<Vec<u64>>>);

impl HeadCounts {
    /// Ticks on which each head was chosen, head 0 first.
    pub fn get(&self) -> Vec<u64> {
        self.0.borrow().clone()
    }
}

/// An actor of K heads and the critic that chooses among them.
pub struct HeadsPolicy<'a> {
    actor: Model<'a>,
    critic: Model<'a>,
    scratch: Box<Scratch<SCRATCH_WIDTH>>,
    units: Vec<f32>,
    actions: usize,
    counts: HeadCounts,
}

impl core::fmt::Debug for HeadsPolicy<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HeadsPolicy")
            .field("name", &self.name())
            .finish_non_exhaustive()
    }
}

impl<'a> HeadsPolicy<'a> {
    /// Boots the actor and critic blobs and checks them against the plant: the actor takes the
    /// plant's observations and outputs a whole number K ≥ 1 of its actions; the critic takes
    /// the observations and one head's actions.
    ///
    /// ```
    /// use firmware_sim::boot::PlantSizes;
    /// use firmware_sim::controller::Controller;
    /// use firmware_sim::heads::HeadsPolicy;
    /// static ACTOR: &[u8] = include_bytes!("../../policy-core/tests/golden/actor_2x32.postcard");
    /// static CRITIC: &[u8] = include_bytes!("../../policy-core/tests/golden/critic_2x32.postcard");
    /// let nav = PlantSizes { observations: 2, actions: 2 };
    /// let mut p = HeadsPolicy::boot(ACTOR, CRITIC, &nav).unwrap();
    /// let mut a = [0.0; 2];
    /// p.act(&[3.0, -1.0], &mut a);
    /// assert_eq!(p.heads(), 1);
    /// assert_eq!(p.counts().get(), vec![1]);
    /// // The critic scores two actions, so it cannot judge heads of one.
    /// let one = PlantSizes { observations: 2, actions: 1 };
    /// assert!(HeadsPolicy::boot(ACTOR, CRITIC, &one).is_err());
    /// ```
    pub fn boot(
        actor: &'a [u8],
        critic: &'a [u8],
        plant: &PlantSizes,
    ) -> Result<HeadsPolicy<'a>, Error> {
        let actor = Model::from_blob(actor)?;
        let critic = Model::from_blob(critic)?;
        for (model, kind) in [(&actor, ModelKind::Actor), (&critic, ModelKind::Critic)] {
            if model.header().kind != kind {
                let found = model.header().kind;
                return Err(policy_core::Error::WrongKind {
                    expected: kind,
                    found,
                }
                .into());
            }
        }
        let outputs = actor.header().shape.actions as usize;
        let actions = plant.actions;
        if actions == 0 || outputs % actions != 0 {
            return Err(Error::Config {
                field: "--heads",
                message: format!(
                    "the actor's {outputs} outputs are not a whole number of the plant's {actions} actions"
                ),
            });
        }
        actor
            .expect_sizes(plant.observations, outputs)
            .map_err(plant_error)?;
        critic.expect_sizes(plant.observations, actions)?;
        let counts = HeadCounts(Rc::new(RefCell::new(vec![0; outputs / actions])));
        Ok(HeadsPolicy {
            actor,
            critic,
            scratch: Box::new(Scratch::new()),
            units: vec![0.0; outputs],
            actions,
            counts,
        })
    }

    /// [`HeadsPolicy::boot`], or the safe state and the reason, as
    /// [`boot_or_safe_state`](crate::boot::boot_or_safe_state) does for one blob.
    pub fn boot_or_safe_state(
        actor: &'a [u8],
        critic: &'a [u8],
        plant: &PlantSizes,
    ) -> (Box<dyn Controller + 'a>, Option<Error>) {
        or_safe_state(HeadsPolicy::boot(actor, critic, plant), plant)
    }

    /// The actor's heads K.
    pub fn heads(&self) -> usize {
        self.units.len() / self.actions
    }

    /// How often each head was chosen (shared: readable after the policy is boxed).
    pub fn counts(&self) -> HeadCounts {
        self.counts.clone()
    }
}

impl Controller for HeadsPolicy<'_> {
    fn name(&self) -> String {
        let h = self.actor.header();
        format!(
            "blob {:?} {}x{} {} of {} heads + critic",
            h.label.as_str(),
            h.shape.depth,
            h.shape.width,
            h.activation,
            self.heads()
        )
    }
    fn observations(&self) -> usize {
        self.actor.header().shape.observations as usize
    }
    fn actions(&self) -> usize {
        self.actions
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        let chosen = choose_head(
            &self.actor,
            &self.critic,
            obs,
            &mut self.scratch,
            &mut self.units,
            action,
        );
        // Sizes were checked at boot; anything else gets the safe action, not a panic.
        match chosen {
            Ok(k) => {
                if let Some(c) = self.counts.0.borrow_mut().get_mut(k) {
                    *c += 1;
                }
            }
            Err(_) => action.fill(0.0),
        }
    }
}
