//! Parsing of what the firmware prints over semihosting and of the QEMU plugin's counts.
//!
//! The firmware's lines are `TAG field...` with integers in decimal and `f32` values as 8 hex
//! digits of their bits, so nothing is lost in printing.

use std::collections::BTreeMap;

use anyhow::{anyhow, bail, Context, Result};

/// Everything the firmware reported in one run.
#[derive(Debug, Default)]
pub struct FirmwareLog {
    /// `SHAPE depth width observations actions`.
    pub shape: Option<[u32; 4]>,
    /// Bytes of the activation scratch (the only RAM the policy uses).
    pub scratch_bytes: Option<u64>,
    /// Bytes of the embedded blob.
    pub blob_bytes: Option<u64>,
    /// Observation `k` as bits, as many as the running blob reads (none in the safe state).
    pub observations: BTreeMap<usize, Vec<u32>>,
    /// Action `k` as bits, as many as the running blob acts (none in the safe state).
    pub actions: BTreeMap<usize, Vec<u32>>,
    /// Observation codes of case `k` (firmware-m0, which runs the integer entry: int8 codes in,
    /// unit codes out, no float); empty for the other firmware.
    pub observation_codes: BTreeMap<usize, Vec<i8>>,
    /// Action (unit) codes of case `k`, as many as the running blob acts (firmware-m0).
    pub action_codes: BTreeMap<usize, Vec<i8>>,
    /// Measured spans in mark order: name and how many repetitions the span holds.
    pub spans: Vec<(String, u64)>,
    /// `TICKS name reps ticks`.
    pub ticks: BTreeMap<String, (u64, u64)>,
    /// Calibration: (instructions, ticks).
    pub ticks_cal: Option<(u64, u64)>,
    /// Stack bytes used by `main`'s frame and everything above it.
    pub stack_main: Option<u64>,
    /// Stack bytes used below `main` in each phase.
    pub stack_phases: BTreeMap<String, u64>,
    /// Stack bytes each C API call used below its caller's frame, in the order printed: the C
    /// firmware's `STACK_PHASE` lines named for a call (`dcp_act`, `dcp_act+error`), measured
    /// one by one below the function that makes them, not below `main`.
    pub stack_calls: Vec<(String, u64)>,
    /// What became of each flash slot at boot: `SLOT A running 3` gives `"A" -> "running 3"`.
    pub slots: BTreeMap<String, String>,
    /// `RUNNING A`, `RUNNING B` or `RUNNING safe`: the slot the firmware runs.
    pub running: Option<String>,
    /// `REFINE t`: the firmware ran DCP's compare step with `t` proposals per tick (feature
    /// `refine`).
    pub refine: Option<usize>,
    /// The firmware reached its end.
    pub done: bool,
    /// `FAIL ...` lines.
    pub failures: Vec<String>,
}

/// A stack phase named for a C API call (every function of the header starts with `dcp_`).
fn is_call(phase: &str) -> bool {
    phase.starts_with("dcp_")
}

fn num(field: Option<&str>, line: &str) -> Result<u64> {
    field
        .ok_or_else(|| anyhow!("short line {line:?}"))?
        .parse()
        .with_context(|| format!("bad number in {line:?}"))
}

fn bits(field: Option<&str>, line: &str) -> Result<u32> {
    let f = field.ok_or_else(|| anyhow!("short line {line:?}"))?;
    u32::from_str_radix(f, 16).with_context(|| format!("bad hex in {line:?}"))
}

impl FirmwareLog {
    /// Parses the firmware's output; lines it does not know (QEMU's own) are skipped.
    pub fn parse(text: &str) -> Result<Self> {
        let mut log = Self::default();
        for line in text.lines().map(str::trim) {
            let mut f = line.split_whitespace();
            match f.next() {
                Some("SHAPE") => {
                    let mut s = [0u32; 4];
                    for v in &mut s {
                        *v = num(f.next(), line)? as u32;
                    }
                    log.shape = Some(s);
                }
                Some("SCRATCH_BYTES") => log.scratch_bytes = Some(num(f.next(), line)?),
                Some("BLOB_BYTES") => log.blob_bytes = Some(num(f.next(), line)?),
                Some(tag @ ("OBS" | "ACT")) => {
                    let k = num(f.next(), line)? as usize;
                    let v = f.map(|x| bits(Some(x), line)).collect::<Result<Vec<_>>>()?;
                    let map = if tag == "OBS" {
                        &mut log.observations
                    } else {
                        &mut log.actions
                    };
                    map.insert(k, v);
                }
                Some(tag @ ("OBS_CODES" | "ACT_CODES")) => {
                    let k = num(f.next(), line)? as usize;
                    let v = f
                        .map(|x| u8::from_str_radix(x, 16).map(|b| b as i8))
                        .collect::<Result<Vec<_>, _>>()
                        .with_context(|| format!("bad code in {line:?}"))?;
                    let map = if tag == "OBS_CODES" {
                        &mut log.observation_codes
                    } else {
                        &mut log.action_codes
                    };
                    map.insert(k, v);
                }
                Some("SPAN") => {
                    let name = f.next().ok_or_else(|| anyhow!("short line {line:?}"))?;
                    let arg = num(f.next(), line)?;
                    // `SPAN act k` is one pass on observation k; other spans give a
                    // repetition count.
                    if name == "act" {
                        log.spans.push((format!("{name}{arg}"), 1));
                    } else {
                        log.spans.push((name.to_string(), arg));
                    }
                }
                Some("TICKS_CAL") => {
                    log.ticks_cal = Some((num(f.next(), line)?, num(f.next(), line)?))
                }
                Some("TICKS") => {
                    let name = f
                        .next()
                        .ok_or_else(|| anyhow!("short line {line:?}"))?
                        .to_string();
                    log.ticks
                        .insert(name, (num(f.next(), line)?, num(f.next(), line)?));
                }
                Some("STACK_MAIN") => log.stack_main = Some(num(f.next(), line)?),
                Some("STACK_PHASE") => {
                    let name = f
                        .next()
                        .ok_or_else(|| anyhow!("short line {line:?}"))?
                        .to_string();
                    let bytes = num(f.next(), line)?;
                    if is_call(&name) {
                        log.stack_calls.push((name, bytes));
                    } else {
                        log.stack_phases.insert(name, bytes);
                    }
                }
                Some("SLOT") => {
                    let id = f.next().ok_or_else(|| anyhow!("short line {line:?}"))?;
                    let rest = f.collect::<Vec<_>>().join(" ");
                    log.slots.insert(id.to_string(), rest);
                }
                Some("REFINE") => log.refine = Some(num(f.next(), line)? as usize),
                Some("RUNNING") => log.running = f.next().map(str::to_string),
                Some("DONE") => log.done = true,
                Some("FAIL") => log.failures.push(line.to_string()),
                _ => {}
            }
        }
        Ok(log)
    }

    /// How many cases the firmware acted on: actions, or action codes (firmware-m0).
    pub fn cases(&self) -> usize {
        self.actions.len().max(self.action_codes.len())
    }

    /// Fails unless the firmware ran to its end without reporting a failure.
    pub fn require_success(&self) -> Result<()> {
        if let Some(first) = self.failures.first() {
            bail!("the firmware reported: {first}");
        }
        if !self.done {
            bail!("the firmware did not reach its end (no DONE line)");
        }
        Ok(())
    }
}

/// Instructions counted by the plugin between the marks of each span, minus the cost of the
/// marks themselves (the first span, two marks back to back), per repetition.
pub fn plugin_spans(plugin_log: &str, spans: &[(String, u64)]) -> Result<BTreeMap<String, f64>> {
    let marks: Vec<u64> = plugin_log
        .lines()
        .filter_map(|l| l.trim().strip_prefix("PLUGIN_MARK "))
        .map(|v| v.trim().parse().context("bad PLUGIN_MARK count"))
        .collect::<Result<_>>()?;
    if marks.len() != 2 * spans.len() {
        bail!(
            "expected {} plugin marks for {} spans, found {}",
            2 * spans.len(),
            spans.len(),
            marks.len()
        );
    }
    let raw: Vec<u64> = marks
        .chunks_exact(2)
        .map(|m| m[1].saturating_sub(m[0]))
        .collect();
    let overhead = match spans.first() {
        Some((name, _)) if name == "overhead" => raw[0],
        _ => bail!("the first span must be the mark overhead"),
    };
    let mut out = BTreeMap::new();
    for ((name, reps), count) in spans.iter().zip(&raw) {
        let net = if name == "overhead" {
            *count
        } else {
            count.saturating_sub(overhead)
        };
        out.insert(name.clone(), net as f64 / (*reps).max(1) as f64);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOG: &str = "SHAPE 4 48 2 2\nSCRATCH_BYTES 512\nOBS 0 00000000 3f800000\n\
                       ACT 0 3e800000 be800000\nSPAN overhead 1\nSPAN act 0\nSPAN tanhf 64\n\
                       STACK_MAIN 96\nSTACK_PHASE act 120\nSTACK_PHASE dcp_verify 988\n\
                       STACK_PHASE dcp_act+error 1128\nSLOT A running 3\n\
                       SLOT B failed: checksum mismatch: stored CRC-32 0x1\nRUNNING A\nDONE\n";

    #[test]
    fn parses_every_field_as_printed() {
        let log = FirmwareLog::parse(LOG).unwrap();
        assert_eq!(log.shape, Some([4, 48, 2, 2]));
        assert_eq!(log.observations[&0], [0, 0x3f80_0000]);
        assert_eq!(
            FirmwareLog::parse("ACT 3 3e800000\nACT 4\n")
                .unwrap()
                .actions,
            BTreeMap::from([(3, vec![0x3e80_0000]), (4, vec![])])
        );
        assert_eq!(f32::from_bits(log.actions[&0][0]), 0.25);
        assert_eq!(log.spans[1], ("act0".to_string(), 1));
        assert_eq!(log.stack_phases["act"], 120);
        assert_eq!(
            log.stack_calls,
            [("dcp_verify".into(), 988), ("dcp_act+error".into(), 1128)],
            "calls kept apart from main's phases, in the order printed"
        );
        assert_eq!(log.stack_phases.len(), 1);
        assert_eq!(log.slots["A"], "running 3");
        assert_eq!(
            log.slots["B"],
            "failed: checksum mismatch: stored CRC-32 0x1"
        );
        assert_eq!(log.running.as_deref(), Some("A"));
        log.require_success().unwrap();
    }

    #[test]
    fn codes_are_read_as_int8_bits() {
        let log = FirmwareLog::parse("OBS_CODES 1 7f 80\nACT_CODES 1 ff 00\nDONE\n").unwrap();
        assert_eq!(log.observation_codes[&1], [127, -128]);
        assert_eq!(log.action_codes[&1], [-1, 0]);
        assert_eq!(log.cases(), 1);
        assert!(FirmwareLog::parse("ACT_CODES 0 1ff\n").is_err());
    }

    #[test]
    fn a_fail_line_or_a_missing_end_is_a_failure() {
        assert!(FirmwareLog::parse("FAIL panic\nDONE\n")
            .unwrap()
            .require_success()
            .is_err());
        assert!(FirmwareLog::parse("SHAPE 4 48 2 2\n")
            .unwrap()
            .require_success()
            .is_err());
    }

    #[test]
    fn plugin_spans_subtract_the_mark_overhead_and_divide_by_repetitions() {
        let log = FirmwareLog::parse(LOG).unwrap();
        let plugin = "PLUGIN_MARK 100\nPLUGIN_MARK 106\nPLUGIN_MARK 200\nPLUGIN_MARK 7206\n\
                      PLUGIN_MARK 8000\nPLUGIN_MARK 11206\nPLUGIN_TOTAL 20000\n";
        let spans = plugin_spans(plugin, &log.spans).unwrap();
        assert_eq!(spans["overhead"], 6.0);
        assert_eq!(spans["act0"], 7000.0);
        assert_eq!(spans["tanhf"], 50.0);
        assert!(plugin_spans("PLUGIN_MARK 1\n", &log.spans).is_err());
    }
}
