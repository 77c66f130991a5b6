//! Booting from the A/B flash slots, exactly as the example firmware does.
//!
//! The choice is policy-core's [`slot::choose`] with policy-core's [`Model::for_policy`] as the
//! verification, the same two calls the firmware makes, so the closed loop runs the slot the chip
//! will run: the newer slot whose blob verifies and fits the plant and the scratch width, else
//! the older one, else the safe state with both reasons.

use policy_core::model::Model;
use policy_core::slot::{self, SlotId, Status};

use crate::boot::{or_safe_state, PlantSizes};
use crate::controller::{BlobPolicy, Controller, SCRATCH_WIDTH};
use crate::error::Error;

/// The example firmware's activation scratch width (`W` in `firmware/src/main.rs`): a blob with a
/// wider layer is refused there, so it is refused here by default too.
pub const FIRMWARE_SCRATCH_WIDTH: usize = 64;

/// What booting from the slots gave: the controller that runs (a slot's policy or the safe
/// state), the boot error if it is the safe state, and what became of each slot.
pub struct SlotBoot<'a> {
    /// The controller the loop runs.
    pub controller: Box<dyn Controller + 'a>,
    /// Why neither slot runs, when the controller is the safe state.
    pub error: Option<Error>,
    /// The slot that runs, if one does.
    pub running: Option<SlotId>,
    /// Slot A's status.
    pub a: Status,
    /// Slot B's status.
    pub b: Status,
}

impl core::fmt::Debug for SlotBoot<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SlotBoot")
            .field("controller", &self.controller.name())
            .field("error", &self.error)
            .field("running", &self.running)
            .field("a", &self.a)
            .field("b", &self.b)
            .finish()
    }
}

impl SlotBoot<'_> {
    /// One line per slot and the outcome, for the CLI.
    pub fn describe(&self) -> String {
        let running = match self.running {
            Some(id) => format!("slot {id} runs"),
            None => "no slot runs: safe state".to_string(),
        };
        format!("slot A: {}\nslot B: {}\n{running}\n", self.a, self.b)
    }
}

/// Boots from slot images `a` and `b` (an absent slot is an empty slice) for a plant of these
/// sizes, with a scratch of `scratch_width` (at most firmware-sim's own, 1024).
///
/// ```
/// use firmware_sim::boot::PlantSizes;
/// use firmware_sim::slots::{boot_slots, FIRMWARE_SCRATCH_WIDTH};
/// use policy_core::{slot, ActionBounds, Normalizer, Policy};
/// let mut p = Policy::<2, 32, 1, 2>::ZERO;
/// p.normalizer = Normalizer::identity(5.0);
/// p.bounds = ActionBounds::symmetric(0.25);
/// let blob = p.to_blob("ok").unwrap();
/// let a = slot::record(&blob, 1, 1 << 17).unwrap();
/// let mut b = slot::record(&blob, 2, 1 << 17).unwrap();
/// b[40] ^= 0xFF; // a bad transfer into the newer slot
/// let nav = PlantSizes { observations: 2, actions: 2 };
/// let boot = boot_slots(&a, &b, &nav, FIRMWARE_SCRATCH_WIDTH).unwrap();
/// assert_eq!(boot.running, Some(slot::SlotId::A));
/// assert!(boot.error.is_none());
/// assert!(boot.describe().contains("slot B: failed: checksum mismatch"));
/// ```
pub fn boot_slots<'a>(
    a: &'a [u8],
    b: &'a [u8],
    plant: &PlantSizes,
    scratch_width: usize,
) -> Result<SlotBoot<'a>, Error> {
    if !(1..=SCRATCH_WIDTH).contains(&scratch_width) {
        return Err(Error::Config {
            field: "scratch width",
            message: format!("must be in 1..={SCRATCH_WIDTH}, found {scratch_width}"),
        });
    }
    let boot = slot::choose(a, b, |blob| {
        Model::for_policy(blob, plant.observations, plant.actions, scratch_width)
    });
    let running = boot.running.as_ref().map(|(id, _)| *id);
    let booted = match boot.running {
        Some((_, model)) => Ok(BlobPolicy::from_model(model)?),
        None => Err(Error::NoSlot {
            a: boot.a,
            b: boot.b,
        }),
    };
    let (controller, error) = or_safe_state(booted, plant);
    Ok(SlotBoot {
        controller,
        error,
        running,
        a: boot.a,
        b: boot.b,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use policy_core::{ActionBounds, Normalizer, Policy};

    const NAV: PlantSizes = PlantSizes {
        observations: 2,
        actions: 2,
    };

    fn blob(width_hint: f32) -> Vec<u8> {
        let mut p = Policy::<2, 32, 1, 2>::ZERO;
        p.normalizer = Normalizer::identity(5.0);
        p.bounds = ActionBounds::symmetric(0.25);
        p.trunk.output.b[0] = width_hint;
        p.to_blob("slot test").expect("test value")
    }

    #[test]
    fn the_newer_slot_runs_and_acts() {
        let a = slot::record(&blob(-10.0), 1, 1 << 17).expect("test value");
        let b = slot::record(&blob(10.0), 2, 1 << 17).expect("test value");
        let mut boot = boot_slots(&a, &b, &NAV, FIRMWARE_SCRATCH_WIDTH).expect("test value");
        assert_eq!(boot.running, Some(SlotId::B));
        let mut act = [0.0; 2];
        boot.controller.act(&[0.0, 0.0], &mut act);
        assert_eq!(act, [0.25, 0.0]); // B's bias, not A's
        assert_eq!(boot.a, Status::Standby { sequence: 1 });
    }

    #[test]
    fn no_runnable_slot_gives_the_safe_state_and_both_reasons() {
        let wrong_plant = PlantSizes {
            observations: 6,
            actions: 2,
        };
        let a = slot::record(&blob(1.0), 1, 1 << 17).expect("test value");
        let mut boot = boot_slots(&a, &[0xFF; 64], &wrong_plant, 64).expect("test value");
        assert!(boot.running.is_none());
        let text = boot.error.as_ref().expect("test value").to_string();
        assert!(text.contains("observation size mismatch"), "{text}");
        assert!(text.contains("empty slot"), "{text}");
        let mut act = [1.0; 2];
        boot.controller.act(&[0.0; 6], &mut act);
        assert_eq!(act, [0.0, 0.0]);
    }

    #[test]
    fn the_scratch_width_is_the_firmwares_and_bounded() {
        let a = slot::record(&blob(1.0), 1, 1 << 17).expect("test value");
        // The 2x32 actor needs 32: a 16-wide firmware refuses it, as the chip would.
        let boot = boot_slots(&a, &[], &NAV, 16).expect("test value");
        assert!(boot.running.is_none());
        assert!(boot_slots(&a, &[], &NAV, 0).is_err());
        assert!(boot_slots(&a, &[], &NAV, SCRATCH_WIDTH + 1).is_err());
    }
}
