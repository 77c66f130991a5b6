//! The A/B flash slots under QEMU: slot images to load, damaged copies, and the check of one
//! boot case (which slot runs, and that it computes what the host computes for that slot's blob).
//!
//! The slot record itself is policy-core's (`policy_core::slot`): `image` writes what
//! host-trainer's `export --image` writes, with the same functions.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};
use serde_json::{json, Value};

use crate::check;
use crate::log::{plugin_spans, FirmwareLog};
use crate::{flag, read, read_text, write_atomic};

/// Parses a decimal or `0x` hexadecimal `u32` flag value.
fn number(flags: &BTreeMap<String, String>, key: &str) -> Result<u32> {
    let text = flag(flags, key)?;
    let parsed = match text.strip_prefix("0x") {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => text.parse(),
    };
    parsed.with_context(|| format!("--{key} {text:?}: expected a u32 (decimal or 0x hex)"))
}

/// `image BLOB OUT --sequence N [--address ADDR]`: the slot record, raw (`.bin`) or as Intel
/// HEX at ADDR (`.hex`, default: the example firmware's slot A).
pub fn image(blob: &[u8], out: &Path, flags: &BTreeMap<String, String>) -> Result<()> {
    use policy_core::slot;
    let sequence = number(flags, "sequence")?;
    let record = slot::record(blob, sequence, slot::EXAMPLE_SLOT_SIZE)?;
    let bytes = match out.extension().and_then(|e| e.to_str()) {
        Some("bin") => record,
        Some("hex") => {
            let address = match flags.get("address") {
                Some(_) => number(flags, "address")?,
                None => slot::EXAMPLE_SLOT_A,
            };
            slot::intel_hex(&record, address)?.into_bytes()
        }
        _ => bail!("{}: the image name must end in .bin or .hex", out.display()),
    };
    write_atomic(out, &bytes)?;
    println!("{} (slot record, sequence {sequence})", out.display());
    Ok(())
}

/// `hex IN OUT.hex --address ADDR`: a raw image (a slot record, whole or damaged) as Intel HEX at
/// ADDR. QEMU's loader reads a raw image only up to the machine's RAM size (16 KiB on sifive_e,
/// less than a 4x48 f32 slot record) but Intel HEX of any size, at the addresses inside it.
pub fn hex(raw: &[u8], out: &Path, flags: &BTreeMap<String, String>) -> Result<()> {
    let address = number(flags, "address")?;
    let text = policy_core::slot::intel_hex(raw, address)?;
    write_atomic(out, text.as_bytes())
}

/// `damage IN OUT --flip OFFSET` inverts one byte (a bad transfer); `--cut LEN` keeps the first
/// LEN bytes (a transfer cut short by a power loss).
pub fn damage(input: &[u8], out: &Path, flags: &BTreeMap<String, String>) -> Result<()> {
    let mut bytes = input.to_vec();
    match (flags.get("flip"), flags.get("cut")) {
        (Some(_), None) => {
            let at = number(flags, "flip")? as usize;
            let b = bytes
                .get_mut(at)
                .ok_or_else(|| anyhow!("--flip {at}: the input has {} bytes", input.len()))?;
            *b = !*b;
        }
        (None, Some(_)) => bytes.truncate(number(flags, "cut")? as usize),
        _ => bail!("give one of --flip OFFSET or --cut LEN"),
    }
    write_atomic(out, &bytes)
}

/// `fill OUT --len N --byte B` (0xFF: erased flash) or `--random SEED` (deterministic noise).
pub fn fill(out: &Path, flags: &BTreeMap<String, String>) -> Result<()> {
    let len = number(flags, "len")? as usize;
    let bytes = match (flags.get("byte"), flags.get("random")) {
        (Some(_), None) => {
            let b = u8::try_from(number(flags, "byte")?).context("--byte must fit a byte")?;
            vec![b; len]
        }
        (None, Some(_)) => {
            let mut rng = ChaCha8Rng::seed_from_u64(number(flags, "random")?.into());
            (0..len).map(|_| rng.next_u32() as u8).collect()
        }
        _ => bail!("give one of --byte B or --random SEED"),
    };
    write_atomic(out, &bytes)
}

/// `slot-case`: checks one boot case and writes its JSON (`name`, `expect`, `running`, each
/// slot's status, the boot's instruction count).
pub fn case(flags: &BTreeMap<String, String>) -> Result<()> {
    let name = flag(flags, "name")?;
    let expect = flag(flags, "expect")?;
    let log = FirmwareLog::parse(&read_text(flag(flags, "fw-log")?)?)?;
    let running = log
        .running
        .clone()
        .ok_or_else(|| anyhow!("{name}: the firmware printed no RUNNING line"))?;
    if running != expect {
        bail!(
            "{name}: slot {running} runs, expected {expect} (A: {}; B: {})",
            status(&log, "A"),
            status(&log, "B")
        );
    }
    match expect {
        "A" | "B" => {
            let blob = read(flag(flags, "blob")?)?;
            check::compare(&blob, &log, false).with_context(|| format!("{name}: slot {expect}"))?;
        }
        "safe" => check_safe_state(name, &log)?,
        other => bail!("--expect {other:?}: expected A, B or safe"),
    }
    if let Some(reason) = flags.get("reason") {
        let failed = log.slots.values().filter(|s| s.starts_with("failed"));
        if !failed.clone().any(|s| s.contains(reason.as_str())) {
            bail!(
                "{name}: no slot failed with {reason:?} (A: {}; B: {})",
                status(&log, "A"),
                status(&log, "B")
            );
        }
    }
    let boot = match flags.get("plugin-log") {
        Some(path) => Some(plugin_spans(&read_text(path)?, &log.spans)?["boot"]),
        None => None,
    };
    let value = json!({
        "case": name, "expect": expect, "running": running,
        "slot_a": status(&log, "A"), "slot_b": status(&log, "B"),
        "blob_bytes": log.blob_bytes, "boot_instructions": boot,
    });
    println!(
        "{name}: RUNNING {running} as expected (A: {}; B: {}){}",
        status(&log, "A"),
        status(&log, "B"),
        boot.map(|b| format!("; boot {b} instructions"))
            .unwrap_or_default()
    );
    write_atomic(
        Path::new(flag(flags, "out")?),
        serde_json::to_string_pretty(&value)?.as_bytes(),
    )
}

fn status(log: &FirmwareLog, id: &str) -> String {
    log.slots
        .get(id)
        .cloned()
        .unwrap_or_else(|| "no SLOT line".into())
}

/// The safe state: the boot failure reported, and every action the zero action (with no blob
/// the firmware has no action size, so it prints none).
fn check_safe_state(name: &str, log: &FirmwareLog) -> Result<()> {
    if !log.failures.iter().any(|f| f.starts_with("FAIL boot")) {
        bail!("{name}: the safe state must end with a FAIL boot line");
    }
    // firmware-m0 prints unit codes (`ACT_CODES`), the other firmware f32 bits (`ACT`).
    let nonzero = log.actions.values().flatten().any(|&a| a != 0)
        || log.action_codes.values().flatten().any(|&c| c != 0);
    if log.cases() == 0 || nonzero {
        bail!(
            "{name}: the safe state must print zero actions, found {:08x?} {:?}",
            log.actions,
            log.action_codes
        );
    }
    if log.slots.len() != 2 || log.slots.values().any(|s| !s.starts_with("failed")) {
        bail!(
            "{name}: both slots must report why they failed, found {:?}",
            log.slots
        );
    }
    Ok(())
}

/// `slot-table OUT.md CASE_JSON...`: the cases as a Markdown table.
pub fn table(out: &Path, cases: &[String]) -> Result<()> {
    let mut md = String::from(
        "| case | runs | slot A | slot B | boot instructions |\n|---|---|---|---|---|\n",
    );
    for path in cases {
        let c: Value = serde_json::from_str(&read_text(path)?)
            .with_context(|| format!("{path} is not JSON"))?;
        let text = |k: &str| c[k].as_str().unwrap_or("?").to_string();
        let boot = c["boot_instructions"]
            .as_f64()
            .map_or("?".into(), |b| format!("{b:.0}"));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {boot} |",
            text("case"),
            text("running"),
            text("slot_a"),
            text("slot_b")
        );
    }
    write_atomic(out, md.as_bytes())?;
    print!("{md}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flags(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn numbers_are_decimal_or_hex() {
        assert_eq!(number(&flags(&[("a", "0x40000")]), "a").unwrap(), 0x40000);
        assert_eq!(number(&flags(&[("a", "12")]), "a").unwrap(), 12);
        assert!(number(&flags(&[("a", "x")]), "a").is_err());
    }

    #[test]
    fn a_safe_state_log_needs_zero_actions_and_both_reasons() {
        let good = "ACT 0\nACT 1 00000000\nSLOT A failed: empty slot\n\
                    SLOT B failed: checksum mismatch\nRUNNING safe\nFAIL boot: no slot\n";
        check_safe_state("t", &FirmwareLog::parse(good).unwrap()).unwrap();
        let moved = good.replace("ACT 1 00000000", "ACT 1 3e800000");
        assert!(check_safe_state("t", &FirmwareLog::parse(&moved).unwrap()).is_err());
        let no_reason = good.replace("SLOT B failed: checksum mismatch\n", "");
        assert!(check_safe_state("t", &FirmwareLog::parse(&no_reason).unwrap()).is_err());
    }
}
