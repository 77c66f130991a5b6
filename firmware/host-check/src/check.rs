//! The comparison that gates CI: the firmware's actions against policy-core on the host.
//!
//! Tolerance: none. Both sides run the same arithmetic (f32 multiply then add in a fixed order,
//! no fused multiply-add, `libm::tanhf` in software), so every action must have the same bits.

use anyhow::{bail, Result};

use crate::blobs;
use crate::log::FirmwareLog;
use crate::observations::OBSERVATIONS;

/// Outcome of a successful comparison.
#[derive(Debug)]
pub struct Comparison {
    /// Observations compared.
    pub cases: usize,
    /// Largest |target - host| over all actions (0 when bit-exact).
    pub max_abs_diff: f32,
}

/// Compares every action the firmware printed with the host's; fails on any differing bit, on an
/// observation that is not the shared list's, or on a missing case. With `print`, one line per case.
pub fn compare(blob: &[u8], log: &FirmwareLog, print: bool) -> Result<Comparison> {
    compare_with(blob, None, log, print)
}

/// [`compare`], for a firmware that may have run DCP's compare step (a `REFINE t` line): then
/// the host recomputes it with the `critic` blob.
pub fn compare_with(
    blob: &[u8],
    critic: Option<&[u8]>,
    log: &FirmwareLog,
    print: bool,
) -> Result<Comparison> {
    log.require_success()?;
    let host = match (log.refine, critic) {
        (None, None) => blobs::actions(blob, &OBSERVATIONS)?,
        (Some(t), Some(critic)) => blobs::refined_actions(blob, critic, &OBSERVATIONS, t)?,
        (Some(t), None) => bail!("the firmware ran the compare step (T = {t}): give --critic"),
        (None, Some(_)) => bail!("--critic given but the firmware ran no compare step"),
    };
    if log.observations.len() != OBSERVATIONS.len() || log.actions.len() != OBSERVATIONS.len() {
        bail!(
            "expected {} observations and actions from the firmware, found {} and {}",
            OBSERVATIONS.len(),
            log.observations.len(),
            log.actions.len()
        );
    }
    let mut mismatches = 0;
    let mut max_abs_diff = 0.0f32;
    for (k, (obs, want)) in OBSERVATIONS.iter().zip(&host).enumerate() {
        let (Some(seen_obs), Some(got)) = (log.observations.get(&k), log.actions.get(&k)) else {
            bail!("case {k} missing from the firmware's output");
        };
        if *seen_obs != [obs[0].to_bits(), obs[1].to_bits()] {
            bail!("case {k}: the firmware acted on {seen_obs:08x?}, expected {obs:?}: observation lists differ");
        }
        let got = [f32::from_bits(got[0]), f32::from_bits(got[1])];
        let same = got
            .iter()
            .zip(want)
            .all(|(g, w)| g.to_bits() == w.to_bits());
        for (g, w) in got.iter().zip(want) {
            max_abs_diff = max_abs_diff.max((g - w).abs());
        }
        mismatches += usize::from(!same);
        if print {
            println!(
            "  case {k}: obs [{:>12e}, {:>12e}]  target [{:+.9}, {:+.9}]  host [{:+.9}, {:+.9}]  {}",
            obs[0], obs[1], got[0], got[1], want[0], want[1],
            if same { "bit-exact" } else { "MISMATCH" }
            );
        }
    }
    if mismatches > 0 {
        bail!("{mismatches} of {} cases differ from the host (max |diff| {max_abs_diff:e}); bit-exact required", host.len());
    }
    Ok(Comparison {
        cases: host.len(),
        max_abs_diff,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blobs::{generate, parse_shape};

    fn firmware_output(blob: &[u8], flip: Option<usize>) -> String {
        let acts = blobs::actions(blob, &OBSERVATIONS).unwrap();
        let mut out = String::new();
        for (k, (o, a)) in OBSERVATIONS.iter().zip(&acts).enumerate() {
            let a0 = a[0].to_bits() ^ u32::from(flip == Some(k));
            out += &format!(
                "OBS {k} {:08x} {:08x}\nACT {k} {a0:08x} {:08x}\n",
                o[0].to_bits(),
                o[1].to_bits(),
                a[1].to_bits()
            );
        }
        out + "DONE\n"
    }

    #[test]
    fn identical_bits_pass() {
        let blob = generate(
            parse_shape("2x32").unwrap(),
            1,
            policy_core::Activation::Tanh,
            policy_core::Encoding::F32,
        )
        .unwrap();
        let log = FirmwareLog::parse(&firmware_output(&blob, None)).unwrap();
        assert_eq!(compare(&blob, &log, false).unwrap().max_abs_diff, 0.0);
    }

    #[test]
    fn quantised_blobs_are_checked_from_their_own_bytes() {
        for encoding in [policy_core::Encoding::F16, policy_core::Encoding::Int8] {
            let blob = generate(
                parse_shape("2x32").unwrap(),
                1,
                policy_core::Activation::Relu,
                encoding,
            )
            .unwrap();
            let log = FirmwareLog::parse(&firmware_output(&blob, None)).unwrap();
            assert_eq!(compare(&blob, &log, false).unwrap().cases, 10);
            assert!(compare(
                &blob,
                &FirmwareLog::parse(&firmware_output(&blob, Some(3))).unwrap(),
                false
            )
            .is_err());
        }
    }

    /// A firmware log of the compare step (`REFINE t`) is checked against the refined actions
    /// and needs the critic; the plain actions do not pass for it.
    #[test]
    fn a_refining_firmware_is_checked_with_its_critic() {
        let actor = include_bytes!("../../../policy-core/tests/golden/actor_2x32.postcard");
        let critic = include_bytes!("../../../policy-core/tests/golden/critic_2x32.postcard");
        let refined = blobs::refined_actions(actor, critic, &OBSERVATIONS, 16).unwrap();
        let plain = blobs::actions(actor, &OBSERVATIONS).unwrap();
        assert_ne!(refined, plain, "16 proposals change some action");
        let log_of = |acts: &[[f32; 2]]| {
            let mut out = String::from("REFINE 16\n");
            for (k, (o, a)) in OBSERVATIONS.iter().zip(acts).enumerate() {
                out += &format!(
                    "OBS {k} {:08x} {:08x}\nACT {k} {:08x} {:08x}\n",
                    o[0].to_bits(),
                    o[1].to_bits(),
                    a[0].to_bits(),
                    a[1].to_bits()
                );
            }
            FirmwareLog::parse(&(out + "DONE\n")).unwrap()
        };
        assert!(compare_with(actor, Some(critic), &log_of(&refined), false).is_ok());
        assert!(compare_with(actor, Some(critic), &log_of(&plain), false).is_err());
        assert!(compare_with(actor, None, &log_of(&refined), false).is_err());
    }

    #[test]
    fn one_flipped_bit_fails() {
        let blob = generate(
            parse_shape("2x32").unwrap(),
            1,
            policy_core::Activation::Tanh,
            policy_core::Encoding::F32,
        )
        .unwrap();
        let log = FirmwareLog::parse(&firmware_output(&blob, Some(3))).unwrap();
        let err = compare(&blob, &log, false).unwrap_err().to_string();
        assert!(err.contains("1 of 10 cases differ"), "{err}");
    }
}
