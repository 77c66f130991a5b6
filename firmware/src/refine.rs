//! DCP's compare step on the device (feature `refine`): before each action, `T` proposals around
//! the actor's unit action (σ = 0.2), the best under the critic replacing it only if its Q is
//! higher (policy-core's `compare::refine_model`). The critic is a slot record in memory.x's
//! CRITIC region; `T` is the build's `REFINE_T`.

use policy_core::compare::refine_model;
use policy_core::model::{Model, Scratch};
use policy_core::{slot, Error, ModelKind};

use crate::proposals::{Proposals, SEED};
use crate::{ACT, OBS, W};

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
    /// Verifies the critic in `region` (a slot record) as one this firmware's actor can use: a
    /// critic of [`OBS`] observations and [`ACT`] actions that fits the scratch.
    pub fn boot(region: &'static [u8]) -> Result<Refiner, Error> {
        let critic = Model::from_blob(slot::read(region)?.blob)?;
        let header = critic.header();
        if header.kind != ModelKind::Critic {
            return Err(Error::WrongKind {
                expected: ModelKind::Critic,
                found: header.kind,
            });
        }
        critic.expect_sizes(OBS, ACT)?;
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
        obs: &[f32; OBS],
        scratch: &mut Scratch<W>,
    ) -> Option<[f32; ACT]> {
        refine_model::<ACT, W, _>(actor, &self.critic, obs, scratch, &mut self.rng, T, SIGMA)
            .ok()
            .map(|r| r.action)
    }
}
