//! One variant's resource figures (a firmware build run once under QEMU), as a JSON object.

use std::collections::BTreeMap;

use anyhow::{anyhow, bail, Context, Result};
use serde_json::{json, Value};

use crate::blobs::BlobInfo;
use crate::check::Comparison;
use crate::log::{plugin_spans, FirmwareLog};

/// What the script knows about a variant besides the logs.
#[derive(Debug)]
pub struct Variant {
    /// Name, e.g. `m4f-trained` or `m4f-4x48`.
    pub name: String,
    /// Rust target triple.
    pub target: String,
    /// QEMU machine.
    pub machine: String,
    /// QEMU CPU.
    pub cpu: String,
    /// Cargo profile the firmware was built with (`release` or `release-s`).
    pub profile: String,
    /// That profile's `opt-level` (`3` or `s`).
    pub opt_level: String,
    /// Path of the blob the variant ran (from slot A).
    pub blob_path: String,
    /// The weight encodings the firmware was built to run (its features: `f32,f16,int8` by
    /// default, `int8` for an int8-only firmware).
    pub encodings: String,
}

/// Section sizes from `size -A` output (`name size addr` lines).
pub fn parse_sizes(text: &str) -> BTreeMap<String, u64> {
    text.lines()
        .filter_map(|l| {
            let mut f = l.split_whitespace();
            let (name, size) = (f.next()?, f.next()?.parse().ok()?);
            name.starts_with('.').then(|| (name.to_string(), size))
        })
        .collect()
}

/// Bytes of the startup code's own sections: riscv-rt puts the Rust half of its reset code in
/// `.init.rust`, outside `.text` (its assembly half, `.init`, is inside). None on the Cortex-M.
fn init_sections(sizes: &BTreeMap<String, u64>) -> u64 {
    sizes
        .iter()
        .filter(|(name, _)| name.starts_with(".init"))
        .map(|(_, size)| size)
        .sum()
}

/// The firmware's flash (without a blob): the sections a flasher writes. `.data` is in RAM at
/// run time but its initial values are stored in flash.
fn firmware_flash(sizes: &BTreeMap<String, u64>) -> u64 {
    let sec = |n: &str| sizes.get(n).copied().unwrap_or(0);
    sec(".vector_table") + sec(".text") + init_sections(sizes) + sec(".rodata") + sec(".data")
}

/// Instructions per span: from the plugin when its log is there, else from SysTick ticks under
/// `-icount` (resolution of one tick, tens of instructions). Returns the spans and the source.
fn instruction_spans(
    log: &FirmwareLog,
    plugin_log: Option<&str>,
) -> Result<(BTreeMap<String, f64>, &'static str)> {
    if let Some(text) = plugin_log {
        return Ok((plugin_spans(text, &log.spans)?, "tcg-plugin"));
    }
    let (cal_insns, cal_ticks) = log.ticks_cal.ok_or_else(|| anyhow!("no TICKS_CAL line"))?;
    let per_tick = cal_insns as f64 / cal_ticks.max(1) as f64;
    let mut spans = BTreeMap::new();
    for (name, (reps, ticks)) in &log.ticks {
        spans.insert(
            name.clone(),
            *ticks as f64 * per_tick / (*reps).max(1) as f64,
        );
    }
    // SysTick times all acts together: every observation gets the mean.
    let act = *spans
        .get("act")
        .ok_or_else(|| anyhow!("no TICKS act line"))?;
    for k in 0..log.cases() {
        spans.insert(format!("act{k}"), act);
    }
    Ok((spans, "systick-icount"))
}

/// Builds the variant's JSON object. The firmware holds no blob: its flash is its own sections,
/// and the whole figure adds the slot record the variant ran from (header + blob), which is what
/// a product flashes besides the firmware for one policy.
#[allow(clippy::too_many_arguments)] // each is one source the report draws on
pub fn measure(
    v: &Variant,
    info: &BlobInfo,
    blob_len: u64,
    record_len: u64,
    sizes: &BTreeMap<String, u64>,
    log: &FirmwareLog,
    plugin_log: Option<&str>,
    cmp: &Comparison,
) -> Result<Value> {
    let sec = |n: &str| sizes.get(n).copied().unwrap_or(0);
    let firmware = firmware_flash(sizes);
    let flash = firmware + record_len;
    let static_ram = sec(".data") + sec(".bss") + sec(".uninit");
    let scratch = log
        .scratch_bytes
        .ok_or_else(|| anyhow!("no SCRATCH_BYTES line"))?;
    let main_frame = log
        .stack_main
        .ok_or_else(|| anyhow!("no STACK_MAIN line"))?;
    // The firmware's own phases (boot, act). The C firmware's calls measured one by one
    // (`stack_per_call`) run below a measuring function after them, which a product does not
    // run: they are reported per call, not in the peak.
    let below = log.stack_phases.values().copied().max().unwrap_or(0);
    let peak_stack = main_frame + below;
    if firmware == 0 || record_len < blob_len || static_ram < scratch {
        bail!("section sizes do not describe this firmware (flash {firmware}, static RAM {static_ram}, record {record_len}, blob {blob_len}, scratch {scratch})");
    }

    let (spans, source) = instruction_spans(log, plugin_log)?;
    let acts: Vec<f64> = (0..log.cases())
        .map(|k| {
            spans
                .get(&format!("act{k}"))
                .copied()
                .context("missing act span")
        })
        .collect::<Result<_>>()?;
    let act_mean = acts.iter().sum::<f64>() / acts.len().max(1) as f64;
    let act_max = acts.iter().copied().fold(0.0, f64::max);
    let act_min = acts.iter().copied().fold(f64::INFINITY, f64::min);
    let boot = spans.get("boot").copied().context("missing boot span")?;
    let tanhf = spans.get("tanhf").copied();
    let macs = info.macs() as f64;
    let excl_tanh = tanhf.map(|t| (act_mean - info.tanh_calls() as f64 * t) / macs);

    Ok(json!({
        "variant": v.name, "target": v.target, "qemu_machine": v.machine, "qemu_cpu": v.cpu,
        "profile": v.profile, "opt_level": v.opt_level,
        "firmware_encodings": v.encodings.split(',').collect::<Vec<_>>(),
        "shape": info.name(), "encoding": info.encoding.to_string(),
        "macs_per_act": info.macs(), "tanhf_per_act": info.tanh_calls(),
        "blob": { "path": v.blob_path, "bytes": blob_len, "kind": info.kind.to_string(),
                  "activation": info.activation.to_string(), "encoding": info.encoding.to_string(),
                  "version": info.version },
        "flash": {
            "total": flash, "vector_table": sec(".vector_table"), "text": sec(".text"),
            "init": init_sections(sizes),
            "rodata": sec(".rodata"), "data": sec(".data"), "blob": blob_len,
            "slot_record": record_len, "blob_share": round(blob_len as f64 / flash as f64, 3),
            "without_blob": firmware,
        },
        "ram": {
            "data": sec(".data"), "bss": sec(".bss"), "uninit": sec(".uninit"), "static_total": static_ram,
            "scratch": scratch, "static_beyond_scratch": static_ram - scratch,
            "stack_main_frame": main_frame, "stack_phases": log.stack_phases, "stack_peak": peak_stack,
            "stack_per_call": log.stack_calls.iter()
                .map(|(call, bytes)| json!({ "call": call, "bytes": bytes })).collect::<Vec<_>>(),
            "total": static_ram + peak_stack,
        },
        "instructions": {
            "source": source,
            "act_mean": round(act_mean, 1), "act_min": round(act_min, 1), "act_max": round(act_max, 1),
            "act_per_observation": acts.iter().map(|a| round(*a, 1)).collect::<Vec<_>>(),
            "per_mac": round(act_mean / macs, 3), "per_mac_worst": round(act_max / macs, 3),
            "tanhf_each": tanhf.map(|t| round(t, 1)),
            "per_mac_excluding_tanhf": excl_tanh.map(|e| round(e, 3)),
            "boot": round(boot, 0), "boot_per_blob_byte": round(boot / blob_len as f64, 2),
            "mark_overhead": spans.get("overhead").map(|o| round(*o, 0)),
        },
        "refine": log.refine,
        "check": { "cases": cmp.cases, "bit_exact": cmp.max_abs_diff == 0.0, "max_abs_diff": cmp.max_abs_diff },
    }))
}

/// Rounds for the report (the counts are exact; means need no more digits).
fn round(x: f64, digits: i32) -> f64 {
    let p = 10f64.powi(digits);
    (x * p).round() / p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_a_output_is_read_by_section_name() {
        let text = "fw  :\nsection  size  addr\n.vector_table  1024  0\n.text  5000  1024\n.bss 28900 536870912\nTotal 34924\n";
        let s = parse_sizes(text);
        assert_eq!(s[".text"], 5000);
        assert_eq!(s[".bss"], 28900);
        assert!(!s.contains_key("Total"));
    }

    /// The RISC-V firmware's reset code in `.init.rust` was left out of its flash figure.
    #[test]
    fn flash_counts_the_startup_sections_beside_text() {
        let riscv = "fw  :
section  size  addr
.text.dummy 0 541065216
.text  44380  541065216
                     .init.rust  22  541109596
.rodata  4268  541109620
.data 0 2147483648
                     .bss 512 2147483648
.stack 15872 2147484160
";
        assert_eq!(firmware_flash(&parse_sizes(riscv)), 44380 + 22 + 4268);
        let arm = "fw  :
.vector_table 1024 0
.text 5000 1024
.rodata 300 6024
.data 8 536870912
";
        assert_eq!(firmware_flash(&parse_sizes(arm)), 1024 + 5000 + 300 + 8);
    }
}
