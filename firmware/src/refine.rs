//! DCP's compare step on the device (feature `refine`): before each action, `T` proposals around
//! the actor's unit action (σ = 0.2), the best under the critic replacing it only if its Q is
//! higher (policy-core's `compare::refine_model`). The critic is a slot record in memory.x's
//! CRITIC region; `T` is the build's `REFINE_T`.
//!
//! The observation size is the running actor's, like the plain firmware's; the action size is
//! fixed at [`A`] = 2 (the navigation task's), because policy-core's compare step keeps its
//! proposals in `[f32; A]` arrays: an actor or critic of another action size is refused at boot
//! with its reason (a `FAIL critic` line).

use policy_core::compare::refine_model;
use policy_core::model::{Model, Scratch};
use policy_core::{slot, Error, ModelKind};

use crate::proposals::{Proposals, SEED};
use crate::W;

/// The action size of the compare step (see the module docs).
pub const A: usize = 2;

/// Proposals per tick (`REFINE_T` at build time, default 16).
pub const T: usize = parse(env!("REFINE_T"));
/// The proposals' standard deviation in the unit box: the σc the trainer's DCP uses.
pub const SIGMA: f32 = 0.2;

/// A decimal number at compile time (build.rs has checked it).
const fn parse(text: &str) -> usize {
    let bytes = text.as_bytes();
    let (mut i, mut n) = (0, 0);
    while i < bytes.len() {
        n = n * 10 + (bytes[i] - b'0') as usize;
        i += 1;
    }
    n
}

/// The critic and the proposals' random stream.
pub struct Refiner {
    critic: Model<'static>,
    rng: Proposals,
}

impl Refiner {
    /// Verifies the critic in `region` (a slot record) as one the running `actor` can use: a
    /// critic of the actor's observations and [`A`] actions (the actor's too) that fits the
    /// scratch. Without an actor (the safe state) only the critic's own action size is checked.
    pub fn boot(region: &'static [u8], actor: Option<&Model<'_>>) -> Result<Refiner, Error> {
        let critic = Model::from_blob(slot::read(region)?.blob)?;
        let header = critic.header();
        if header.kind != ModelKind::Critic {
            return Err(Error::WrongKind {
                expected: ModelKind::Critic,
                found: header.kind,
            });
        }
        let observations =
            actor.map_or(header.shape.observations, |a| a.header().shape.observations);
        critic.expect_sizes(observations.into(), A)?;
        if let Some(actor) = actor {
            actor.expect_sizes(observations.into(), A)?;
        }
        let needed = header.shape.scratch_width(header.kind);
        if needed > W {
            return Err(Error::ScratchTooSmall { needed, found: W });
        }
        Ok(Refiner {
            critic,
            rng: Proposals(SEED),
        })
    }

    /// The refined action, or `None` on an error (the caller keeps the actor's action).
    pub fn step(
        &mut self,
        actor: &Model<'_>,
        obs: &[f32],
        scratch: &mut Scratch<W>,
    ) -> Option<[f32; A]> {
        refine_model::<A, W, _>(actor, &self.critic, obs, scratch, &mut self.rng, T, SIGMA)
            .ok()
            .map(|r| r.action)
    }
}
