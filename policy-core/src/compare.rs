//! DCP's compare step on the device: propose actions around the actor's, keep the best under Q.
//!
//! In training, DCP regresses the actor toward the best of T Gaussian proposals around its own
//! action, scored by the critic against Q(s, P(s)). The same rule can run on the chip: at a
//! margin where the actor's action makes no progress, firmware may ask the critic for a better
//! adjacent action without any gradient.

use rand_core::Rng;

use crate::critic::Critic;
use crate::error::Error;
#[cfg(doc)]
use crate::model::argmax;
use crate::model::{Model, Scratch};
use crate::policy::Policy;

/// The outcome of one compare step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refined<const A: usize> {
    /// The chosen action, scaled into the policy's bounds.
    pub action: [f32; A],
    /// The chosen action in the unit box `[-1, 1]^A`.
    pub unit: [f32; A],
    /// `Q(s, chosen) - Q(s, P(s))`; 0 when the actor's own action was kept.
    pub advantage: f32,
    /// Which proposal won (1..=T), or 0 for the actor's own action.
    pub winner: usize,
}

/// The sampler the proposals use (it lives with its batch version in [`crate::normal`]).
pub use crate::normal::standard_normal;

/// Proposes `t` actions `clip(P(s) + N(0, sigma²), -1, 1)` around the actor's unit action and
/// returns the one with the highest Q, or the actor's own action if none beats it.
///
/// The result is never worse under the critic than the actor's own action: a proposal replaces
/// the incumbent only when its Q is strictly greater (a NaN never is). A non-finite or
/// non-positive `sigma`, or `t == 0`, returns the actor's action.
///
/// ```
/// use policy_core::{compare::refine, Critic, Policy};
/// use rand_core::{Infallible, TryRng};
/// # struct Lcg(u64);
/// # impl TryRng for Lcg {
/// #     type Error = Infallible;
/// #     fn try_next_u32(&mut self) -> Result<u32, Infallible> { Ok((self.try_next_u64()? >> 32) as u32) }
/// #     fn try_next_u64(&mut self) -> Result<u64, Infallible> { self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); Ok(self.0) }
/// #     fn try_fill_bytes(&mut self, d: &mut [u8]) -> Result<(), Infallible> { d.fill(0); Ok(()) }
/// # }
/// static ACTOR: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
/// static CRITIC: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
/// let policy = Policy::<2, 32, 1, 2>::from_blob(ACTOR).unwrap();
/// let critic = Critic::<2, 32, 1, 2>::from_blob(CRITIC).unwrap();
/// let obs = [3.0, -1.0];
/// let r = refine(&policy, &critic, &obs, &mut Lcg(7), 16, 0.2);
/// assert!(r.advantage >= 0.0);
/// assert!(critic.q(&obs, &r.unit) >= critic.q(&obs, &policy.act_unit(&obs)));
/// ```
pub fn refine<
    const S: usize,
    const H: usize,
    const L: usize,
    const A: usize,
    const CH: usize,
    const CL: usize,
    R,
>(
    policy: &Policy<S, H, L, A>,
    critic: &Critic<S, CH, CL, A>,
    obs: &[f32; S],
    rng: &mut R,
    t: usize,
    sigma: f32,
) -> Refined<A>
where
    R: Rng + ?Sized,
{
    let a0 = policy.act_unit(obs);
    let z = critic.normalizer.normalize(obs);
    let z = &z.data.0[0];
    let score = |unit: &[f32; A]| Ok::<f32, Error>(critic.q_normalized(z, unit));
    // The compiled critic cannot fail.
    let mut best = best_of(a0, rng, t, sigma, score).unwrap_or(Refined {
        action: [0.0; A],
        unit: a0,
        advantage: 0.0,
        winner: 0,
    });
    best.action = policy.bounds.scale(&best.unit);
    best
}

/// The compare rule itself, for any critic: `t` proposals around `a0`, each replacing the best
/// so far only when its Q beats it strictly (Q(a0) is the first incumbent). `action` is left
/// for the caller to scale.
fn best_of<const A: usize, R, E>(
    a0: [f32; A],
    rng: &mut R,
    t: usize,
    sigma: f32,
    mut q: impl FnMut(&[f32; A]) -> Result<f32, E>,
) -> Result<Refined<A>, E>
where
    R: Rng + ?Sized,
{
    let q0 = q(&a0)?;
    let mut best = Refined {
        action: [0.0; A],
        unit: a0,
        advantage: 0.0,
        winner: 0,
    };
    if sigma.is_finite() && sigma > 0.0 {
        for winner in 1..=t {
            let mut unit = a0;
            for u in &mut unit {
                *u = (*u + sigma * standard_normal(rng)).clamp(-1.0, 1.0);
            }
            let advantage = q(&unit)? - q0;
            if advantage > best.advantage {
                best = Refined {
                    action: [0.0; A],
                    unit,
                    advantage,
                    winner,
                };
            }
        }
    }
    Ok(best)
}

/// [`refine`] for runtime models: an actor and a critic of any shape, straight from their blob
/// bytes (flash), with a caller's scratch. The same proposals, order and comparisons as
/// [`refine`], so on the same weights and random stream it returns the same bits.
///
/// Errors: `actor` is not an actor, `critic` not a critic, or their sizes do not fit `obs`, `A`
/// (the critic takes the observation and the actor's `A` actions) or the scratch.
///
/// ```
/// use policy_core::compare::{refine, refine_model};
/// use policy_core::model::{Model, Scratch};
/// use policy_core::{Critic, Policy};
/// use rand_core::{Infallible, TryRng};
/// # struct Lcg(u64);
/// # impl TryRng for Lcg {
/// #     type Error = Infallible;
/// #     fn try_next_u32(&mut self) -> Result<u32, Infallible> { Ok((self.try_next_u64()? >> 32) as u32) }
/// #     fn try_next_u64(&mut self) -> Result<u64, Infallible> { self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); Ok(self.0) }
/// #     fn try_fill_bytes(&mut self, d: &mut [u8]) -> Result<(), Infallible> { d.fill(0); Ok(()) }
/// # }
/// static ACTOR: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
/// static CRITIC: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
/// let (actor, critic) = (Model::from_blob(ACTOR).unwrap(), Model::from_blob(CRITIC).unwrap());
/// let mut scratch = Scratch::<64>::new();
/// let r = refine_model::<2, 64, _>(&actor, &critic, &[3.0, -1.0], &mut scratch, &mut Lcg(7), 16, 0.2)
///     .unwrap();
/// let policy = Policy::<2, 32, 1, 2>::from_blob(ACTOR).unwrap();
/// let q = Critic::<2, 32, 1, 2>::from_blob(CRITIC).unwrap();
/// assert_eq!(r, refine(&policy, &q, &[3.0, -1.0], &mut Lcg(7), 16, 0.2));
/// ```
#[allow(clippy::too_many_arguments)] // refine's arguments, plus the runtime's scratch
pub fn refine_model<const A: usize, const W: usize, R>(
    actor: &Model<'_>,
    critic: &Model<'_>,
    obs: &[f32],
    scratch: &mut Scratch<W>,
    rng: &mut R,
    t: usize,
    sigma: f32,
) -> Result<Refined<A>, Error>
where
    R: Rng + ?Sized,
{
    let mut a0 = [0.0; A];
    actor.act_unit(obs, scratch, &mut a0)?;
    let mut best = best_of(a0, rng, t, sigma, |unit| critic.q(obs, unit, scratch))?;
    best.action = best.unit;
    actor.scale(&mut best.action);
    Ok(best)
}

/// An actor of several heads on the device: the actor's output holds K actions of
/// `action.len()` one after the other (its bounds K times), and the critic chooses among them,
/// the head of largest Q(s, head) in the unit box by [`argmax`]'s rule (ties to the lowest head,
/// a NaN never wins). The chosen head's action, scaled into its bounds, goes to `action`;
/// `units` (K·A floats, the caller's: no allocation) ends holding every head's scaled action.
/// Returns the chosen head.
///
/// Errors: `actor` is not an actor, `critic` not a critic, `units` is not the actor's output
/// size or not a whole number of `action.len()` actions, or the sizes do not fit `obs` or the
/// scratch.
///
/// ```
/// use policy_core::compare::choose_head;
/// use policy_core::model::{Model, Scratch};
/// static ACTOR: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
/// static CRITIC: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
/// let (actor, critic) = (Model::from_blob(ACTOR).unwrap(), Model::from_blob(CRITIC).unwrap());
/// let mut scratch = Scratch::<32>::new();
/// // Two one-dimensional heads of this 2-output actor, each scored by a critic of two actions
/// // does not fit: the critic must take one head's actions.
/// let (mut units, mut action) = ([0.0f32; 2], [0.0f32; 1]);
/// assert!(choose_head(&actor, &critic, &[3.0, -1.0], &mut scratch, &mut units, &mut action).is_err());
/// // One head of two actions: the head is the actor's own action.
/// let (mut units, mut action) = ([0.0f32; 2], [0.0f32; 2]);
/// let head = choose_head(&actor, &critic, &[3.0, -1.0], &mut scratch, &mut units, &mut action);
/// let mut plain = [0.0f32; 2];
/// actor.act(&[3.0, -1.0], &mut scratch, &mut plain).unwrap();
/// assert_eq!((head, action), (Ok(0), plain));
/// ```
pub fn choose_head<const W: usize>(
    actor: &Model<'_>,
    critic: &Model<'_>,
    obs: &[f32],
    scratch: &mut Scratch<W>,
    units: &mut [f32],
    action: &mut [f32],
) -> Result<usize, Error> {
    let a = action.len();
    if a == 0 || units.len() % a != 0 {
        return Err(Error::SizeMismatch {
            what: "heads' outputs (a whole number of actions)",
            expected: a * (units.len() / a.max(1)).max(1),
            found: units.len(),
        });
    }
    actor.act_unit(obs, scratch, units)?;
    let mut best: Option<(usize, f32)> = None;
    for (k, head) in units.chunks(a).enumerate() {
        let q = critic.q(obs, head, scratch)?;
        // `argmax`'s rule, kept as a running best so no Q buffer is needed.
        match best {
            _ if q.is_nan() => {}
            Some((_, b)) if q <= b => {}
            _ => best = Some((k, q)),
        }
    }
    let k = best.map_or(0, |(k, _)| k);
    actor.scale(units);
    action.copy_from_slice(&units[k * a..(k + 1) * a]);
    Ok(k)
}
