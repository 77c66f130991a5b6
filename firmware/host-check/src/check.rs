//! The comparison that gates CI: the firmware's actions against policy-core on the host.
//!
//! Tolerance: none. Both sides run the same arithmetic (f32 multiply then add in a fixed order,
//! no fused multiply-add, `libm::tanhf` in software), so every action must have the same bits.

use anyhow::{bail, Result};

use crate::blobs;
use crate::log::FirmwareLog;

/// Outcome of a successful comparison.
#[derive(Debug)]
pub struct Comparison {
    /// Observations compared.
    pub cases: usize,
    /// Largest |target - host| over all actions (0 when bit-exact).
    pub max_abs_diff: f32,
}

/// Compares every action the firmware printed with the host's; fails on any differing bit, on an
/// observation that is not the shared list's (at the blob's size), or on a missing case. With
/// `print`, one line per case.
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
    if !log.action_codes.is_empty() {
        return compare_codes(blob, log, print);
    }
    let observations = blobs::observations(blob)?;
    let host = match (log.refine, critic) {
        (None, None) => blobs::actions(blob, &observations)?,
        (Some(t), Some(critic)) => blobs::refined_actions(blob, critic, &observations, t)?,
        (Some(t), None) => bail!("the firmware ran the compare step (T = {t}): give --critic"),
        (None, Some(_)) => bail!("--critic given but the firmware ran no compare step"),
    };
    if log.observations.len() != observations.len() || log.actions.len() != observations.len() {
        bail!(
            "expected {} observations and actions from the firmware, found {} and {}",
            observations.len(),
            log.observations.len(),
            log.actions.len()
        );
    }
    let mut mismatches = 0;
    let mut max_abs_diff = 0.0f32;
    for (k, (obs, want)) in observations.iter().zip(&host).enumerate() {
        let (Some(seen_obs), Some(got)) = (log.observations.get(&k), log.actions.get(&k)) else {
            bail!("case {k} missing from the firmware's output");
        };
        if *seen_obs != bits(obs) {
            bail!("case {k}: the firmware acted on {seen_obs:08x?}, expected {obs:?}: observation lists differ");
        }
        if got.len() != want.len() {
            bail!(
                "case {k}: the firmware printed {} action values, the blob has {}",
                got.len(),
                want.len()
            );
        }
        let got: Vec<f32> = got.iter().copied().map(f32::from_bits).collect();
        let same = bits(&got) == bits(want);
        for (g, w) in got.iter().zip(want) {
            max_abs_diff = max_abs_diff.max((g - w).abs());
        }
        mismatches += usize::from(!same);
        if print {
            println!(
                "  case {k}: obs [{}]  target [{}]  host [{}]  {}",
                list(obs, |v| format!("{v:>12e}")),
                list(&got, |v| format!("{v:+.9}")),
                list(want, |v| format!("{v:+.9}")),
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

/// [`compare`] for firmware-m0, which runs the integer entry: the observation codes must be the
/// shared table's (firmware-m0/src/codes.rs) and every unit code equal to the host's.
fn compare_codes(blob: &[u8], log: &FirmwareLog, print: bool) -> Result<Comparison> {
    let codes = blobs::observation_codes(blob)?;
    let host = blobs::action_codes(blob, &codes)?;
    if log.observation_codes.len() != codes.len() || log.action_codes.len() != codes.len() {
        bail!(
            "expected {} observation and action codes from the firmware, found {} and {}",
            codes.len(),
            log.observation_codes.len(),
            log.action_codes.len()
        );
    }
    let mut mismatches = 0;
    for (k, (obs, want)) in codes.iter().zip(&host).enumerate() {
        let (Some(seen), Some(got)) = (log.observation_codes.get(&k), log.action_codes.get(&k))
        else {
            bail!("case {k} missing from the firmware's output");
        };
        if seen != obs {
            bail!("case {k}: the firmware acted on codes {seen:?}, expected {obs:?}: code lists differ");
        }
        let same = got == want;
        mismatches += usize::from(!same);
        if print {
            println!(
                "  case {k}: codes {obs:?}  target {got:?}  host {want:?}  {}",
                if same { "bit-exact" } else { "MISMATCH" }
            );
        }
    }
    if mismatches > 0 {
        bail!(
            "{mismatches} of {} cases differ from the host; bit-exact required",
            host.len()
        );
    }
    Ok(Comparison {
        cases: host.len(),
        max_abs_diff: 0.0,
    })
}

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

fn list(values: &[f32], each: impl Fn(f32) -> String) -> String {
    values
        .iter()
        .map(|&v| each(v))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blobs::{generate, parse_shape, NAV_SIZES};

    /// The firmware's lines for `acts` on the blob's observations, at their sizes.
    fn log_lines(blob: &[u8], acts: &[Vec<f32>], flip: Option<usize>) -> String {
        let hex = |v: &[f32]| {
            v.iter()
                .map(|x| format!(" {:08x}", x.to_bits()))
                .collect::<String>()
        };
        let mut out = String::new();
        for (k, (o, a)) in blobs::observations(blob)
            .unwrap()
            .iter()
            .zip(acts)
            .enumerate()
        {
            let mut a = a.clone();
            if flip == Some(k) {
                a[0] = f32::from_bits(a[0].to_bits() ^ 1);
            }
            out += &format!("OBS {k}{}\nACT {k}{}\n", hex(o), hex(&a));
        }
        out + "DONE\n"
    }

    fn firmware_output(blob: &[u8], flip: Option<usize>) -> String {
        let acts = blobs::actions(blob, &blobs::observations(blob).unwrap()).unwrap();
        log_lines(blob, &acts, flip)
    }

    /// A blob for another plant (3 observations, 1 action) is checked at its own sizes: the
    /// widened observations and one action per case.
    #[test]
    fn a_blob_of_other_sizes_is_checked_at_its_sizes() {
        let shape = parse_shape("2x32", (3, 1)).unwrap();
        let blob = generate(
            shape,
            1,
            policy_core::Activation::Tanh,
            policy_core::Encoding::F32,
        )
        .unwrap();
        let out = firmware_output(&blob, None);
        assert!(
            out.starts_with("OBS 0 00000000 00000000 3fc00000\nACT 0 "),
            "{out}"
        );
        let log = FirmwareLog::parse(&out).unwrap();
        assert_eq!(log.actions[&0].len(), 1);
        assert_eq!(compare(&blob, &log, false).unwrap().cases, 10);
        let flipped = FirmwareLog::parse(&firmware_output(&blob, Some(2))).unwrap();
        assert!(compare(&blob, &flipped, false).is_err());
        // A 2-observation log does not pass for it.
        let nav = generate(
            parse_shape("2x32", NAV_SIZES).unwrap(),
            1,
            policy_core::Activation::Tanh,
            policy_core::Encoding::F32,
        )
        .unwrap();
        let nav_log = FirmwareLog::parse(&firmware_output(&nav, None)).unwrap();
        assert!(compare(&blob, &nav_log, false).is_err());
    }

    #[test]
    fn identical_bits_pass() {
        let blob = generate(
            parse_shape("2x32", NAV_SIZES).unwrap(),
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
                parse_shape("2x32", NAV_SIZES).unwrap(),
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
        let observations = blobs::observations(actor).unwrap();
        let refined = blobs::refined_actions(actor, critic, &observations, 16).unwrap();
        let plain = blobs::actions(actor, &observations).unwrap();
        assert_ne!(refined, plain, "16 proposals change some action");
        let log_of = |acts: &[Vec<f32>]| {
            let out = String::from("REFINE 16\n") + &log_lines(actor, acts, None);
            FirmwareLog::parse(&out).unwrap()
        };
        assert!(compare_with(actor, Some(critic), &log_of(&refined), false).is_ok());
        assert!(compare_with(actor, Some(critic), &log_of(&plain), false).is_err());
        assert!(compare_with(actor, None, &log_of(&refined), false).is_err());
    }

    /// firmware-m0's log (observation codes in, unit codes out) is checked against the host's
    /// integer entry; one changed code fails.
    #[test]
    fn an_integer_firmware_is_checked_by_its_codes() {
        let blob = generate(
            parse_shape("2x13", (3, 5)).unwrap(),
            1,
            policy_core::Activation::Relu,
            policy_core::Encoding::Integer,
        )
        .unwrap();
        let codes = blobs::observation_codes(&blob).unwrap();
        let units = blobs::action_codes(&blob, &codes).unwrap();
        let hex = |v: &[i8]| {
            v.iter()
                .map(|c| format!(" {:02x}", *c as u8))
                .collect::<String>()
        };
        let lines = |flip: bool| {
            let mut out = String::new();
            for (k, (c, u)) in codes.iter().zip(&units).enumerate() {
                let mut u = u.clone();
                if flip && k == 4 {
                    u[0] ^= 1;
                }
                out += &format!("OBS_CODES {k}{}\nACT_CODES {k}{}\n", hex(c), hex(&u));
            }
            FirmwareLog::parse(&(out + "DONE\n")).unwrap()
        };
        assert_eq!(codes[0], [0, 0, 127]);
        assert_eq!(compare(&blob, &lines(false), false).unwrap().cases, 10);
        assert!(compare(&blob, &lines(true), false).is_err());
    }

    #[test]
    fn one_flipped_bit_fails() {
        let blob = generate(
            parse_shape("2x32", NAV_SIZES).unwrap(),
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
