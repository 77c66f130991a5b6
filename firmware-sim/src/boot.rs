//! Booting a blob the way the chip does: policy-core's runtime model verifies the bytes once,
//! then they must fit the observation and action sizes the plant declares; a blob that does not
//! boot leaves the loop in the safe state (zero action), and the caller reports why.

use crate::controller::{BlobPolicy, Controller, SafeState};
use crate::env::Env;
use crate::Error;

/// The observation and action sizes a plant declares: what a booted blob must fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlantSizes {
    /// Observation size.
    pub observations: usize,
    /// Action size.
    pub actions: usize,
}

impl PlantSizes {
    /// The sizes of any plant, read from its [`Env`] spaces.
    pub fn of_env(env: &dyn Env) -> PlantSizes {
        PlantSizes {
            observations: env.observation_space().dim(),
            actions: env.action_space().dim(),
        }
    }
}

/// Boots a blob as [`boot`] does; a blob that does not boot gives the safe state (zero action of
/// the plant's size) and the reason, which the report then carries
/// ([`Report::mark_boot_failure`](crate::nav::test_protocol::Report::mark_boot_failure)).
///
/// ```
/// use firmware_sim::boot::{boot_or_safe_state, PlantSizes};
/// let plant = PlantSizes { observations: 2, actions: 2 };
/// let (safe, error) = boot_or_safe_state(b"not a blob", &plant);
/// assert_eq!(safe.name(), "safe-state");
/// assert!(error.unwrap().to_string().contains("magic"));
/// ```
pub fn boot_or_safe_state<'a>(
    blob: &'a [u8],
    plant: &PlantSizes,
) -> (Box<dyn Controller + 'a>, Option<Error>) {
    or_safe_state(boot(blob, plant), plant)
}

/// A booted controller, or, if booting failed, the safe state (zero action of the plant's
/// size) and the reason: what every boot path falls back to.
pub fn or_safe_state<'a, C: Controller + 'a>(
    booted: Result<C, Error>,
    plant: &PlantSizes,
) -> (Box<dyn Controller + 'a>, Option<Error>) {
    match booted {
        Ok(policy) => (Box::new(policy), None),
        Err(e) => {
            let safe = SafeState {
                observations: plant.observations,
                actions: plant.actions,
            };
            (Box::new(safe), Some(e))
        }
    }
}

/// Boots a blob as the firmware would, and checks it fits the plant's sizes.
///
/// ```
/// use firmware_sim::boot::{boot, PlantSizes};
/// use policy_core::{ActionBounds, Normalizer, Policy};
/// let mut p = Policy::<2, 32, 1, 2>::ZERO;
/// p.normalizer = Normalizer::identity(5.0);
/// p.bounds = ActionBounds::symmetric(0.25);
/// let blob = p.to_blob("ok").unwrap();
/// let nav = PlantSizes { observations: 2, actions: 2 };
/// assert!(boot(&blob, &nav).is_ok());
/// let other = PlantSizes { observations: 6, actions: 2 };
/// let err = boot(&blob, &other).unwrap_err().to_string();
/// assert_eq!(err, "observation size: the plant needs 6, found 2");
/// let err = boot(b"DCPB", &nav).unwrap_err().to_string();
/// assert!(err.starts_with("blob rejected"), "{err}");
/// ```
pub fn boot<'a>(blob: &'a [u8], plant: &PlantSizes) -> Result<BlobPolicy<'a>, Error> {
    let policy = BlobPolicy::boot(blob)?;
    let fits = policy
        .model()
        .expect_sizes(plant.observations, plant.actions);
    fits.map_err(plant_error)?;
    Ok(policy)
}

/// Checks any controller (a blob, a reference controller, the trainer's own) against the
/// plant's declared sizes, with policy-core's one size check; a booted blob was checked by it
/// already ([`boot`]).
pub(crate) fn check_sizes(c: &dyn Controller, plant: &PlantSizes) -> Result<(), Error> {
    policy_core::model::check_sizes(
        (plant.observations, plant.actions),
        (c.observations(), c.actions()),
    )
    .map_err(plant_error)
}

/// The plant's sizes are what did not fit: said as firmware-sim says it for any controller,
/// not as a blob rejected on its own.
pub(crate) fn plant_error(e: policy_core::Error) -> Error {
    match e {
        policy_core::Error::SizeMismatch {
            what,
            expected,
            found,
        } => Error::SizeMismatch {
            what,
            expected,
            found,
        },
        other => Error::from(other),
    }
}
