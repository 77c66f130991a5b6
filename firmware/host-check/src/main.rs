//! host-check: the host half of scripts/cortex-m.sh (Cortex-M and RISC-V alike).
//!
//! ```text
//! host-check gen DEPTHxWIDTH OUT [--seed N] [--activation tanh|relu] [--encoding f32|f16|int8|integer]
//!                                [--observations N] [--actions N]
//!                                          write a deterministic actor blob of any shape and
//!                                          sizes (default 2 and 2, the navigation task's)
//! host-check encode IN OUT --encoding f32|f16|int8
//!                                          re-encode an f32 blob (e.g. a trained one)
//! host-check info BLOB                     print what the blob holds ("4x48 actor relu f32 v1")
//! host-check check BLOB FW_LOG [--critic CRITIC]
//!                                          recompute the firmware's actions (with the compare
//!                                          step if it ran one); bit-exact or exit 1
//! host-check measure --variant NAME --target T --machine M --cpu C --blob BLOB --image SLOT_BIN
//!                    --profile PROFILE --opt-level LEVEL --sizes SIZE_A_TXT --fw-log LOG
//!                    [--encodings f32,f16,int8,integer] [--plugin-log LOG] [--calls-log LOG] --out JSON
//!                                          one variant's figures; --calls-log: the log of the
//!                                          same C firmware built to measure the stack of each
//!                                          call (its STACK_PHASE dcp_* lines)
//! host-check image BLOB OUT.bin|OUT.hex --sequence N [--address ADDR]
//!                                          a slot record (header + blob) for a flash slot
//! host-check hex IN.bin OUT.hex --address ADDR
//!                                          a raw image as Intel HEX at ADDR (QEMU's loader
//!                                          takes a raw image no larger than the machine's RAM)
//! host-check damage IN OUT (--flip OFFSET | --cut LEN)
//!                                          a copy with one byte inverted, or cut short
//! host-check fill OUT --len N (--byte B | --random SEED)
//!                                          N erased/blank or random bytes
//! host-check slot-case --name NAME --expect A|B|safe [--blob BLOB] [--reason TEXT]
//!                      --fw-log LOG [--plugin-log LOG] --out JSON
//!                                          check one A/B boot case: the slot that runs, its
//!                                          actions bit-exact (or the safe state's zeros)
//! host-check slot-table OUT.md CASE_JSON...
//! host-check report --out JSON [--budgets FILE] [--meta KEY=VALUE]... VARIANT_JSON...
//!                                          the report; with --budgets, exit 1 naming every
//!                                          budget of FILE a variant passed
//! ```
//! Errors are one line on stderr and exit status 1.

mod blobs;
mod budgets;
mod check;
#[path = "../../../firmware-m0/src/codes.rs"]
mod codes;
mod log;
mod measure;
#[path = "../../src/observations.rs"]
mod observations;
#[path = "../../src/proposals.rs"]
mod proposals;
mod report;
#[path = "../../src/sizes.rs"]
mod sizes;
mod slots;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{anyhow, bail, Context, Result};

use blobs::BlobInfo;
use log::FirmwareLog;

/// The default seed of `gen` (the firmware check needs any fixed one).
const DEFAULT_SEED: u64 = 4;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-check: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &[String]) -> Result<()> {
    let (cmd, rest) = args
        .split_first()
        .ok_or_else(|| anyhow!("no command (gen, info, check, measure, report)"))?;
    let (flags, positional) = split_flags(rest)?;
    match (cmd.as_str(), positional.as_slice()) {
        ("gen", [shape, out]) => gen(shape, Path::new(out), &flags),
        ("encode", [input, out]) => {
            let encoding = blobs::parse_encoding(flag(&flags, "encoding")?)?;
            let bytes = blobs::encode(&read(input)?, encoding)?;
            write_if_changed(Path::new(out), &bytes)?;
            println!("{out} ({} bytes, {input} as {encoding})", bytes.len());
            Ok(())
        }
        ("info", [blob]) => {
            let info = BlobInfo::of(&read(blob)?)?;
            println!(
                "{} {} {} {} v{}",
                info.name(),
                info.kind,
                info.activation,
                info.encoding,
                info.version
            );
            Ok(())
        }
        ("check", [blob, fw_log]) => {
            let log = FirmwareLog::parse(&read_text(fw_log)?)?;
            let critic = flags.get("critic").map(|c| read(c)).transpose()?;
            let cmp = check::compare_with(&read(blob)?, critic.as_deref(), &log, true)?;
            println!("MATCH: {} cases bit-exact with policy-core on the host", cmp.cases);
            Ok(())
        }
        ("measure", []) => measure(&flags),
        ("image", [blob, out]) => slots::image(&read(blob)?, Path::new(out), &flags),
        ("hex", [input, out]) => slots::hex(&read(input)?, Path::new(out), &flags),
        ("damage", [input, out]) => slots::damage(&read(input)?, Path::new(out), &flags),
        ("fill", [out]) => slots::fill(Path::new(out), &flags),
        ("slot-case", []) => slots::case(&flags),
        ("slot-table", [out, cases @ ..]) => slots::table(Path::new(out), cases),
        ("report", variants) => report(&flags, &args[1..], variants),
        _ => bail!("unknown command or wrong arguments: {} (see the usage in firmware/host-check/src/main.rs)", args.join(" ")),
    }
}

/// Splits `--key value` pairs from positional arguments; `--meta` may repeat (collected apart).
fn split_flags(args: &[String]) -> Result<(BTreeMap<String, String>, Vec<String>)> {
    let (mut flags, mut positional) = (BTreeMap::new(), Vec::new());
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if let Some(key) = a.strip_prefix("--") {
            let value = it.next().ok_or_else(|| anyhow!("--{key} needs a value"))?;
            if key != "meta" {
                flags.insert(key.to_string(), value.clone());
            }
        } else {
            positional.push(a.clone());
        }
    }
    Ok((flags, positional))
}

pub(crate) fn flag<'a>(flags: &'a BTreeMap<String, String>, key: &str) -> Result<&'a str> {
    flags
        .get(key)
        .map(String::as_str)
        .ok_or_else(|| anyhow!("missing --{key}"))
}

pub(crate) fn read(path: &str) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read {path}"))
}

pub(crate) fn read_text(path: &str) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("cannot read {path}"))
}

/// Writes through a temporary file and a rename, so a reader never sees half a file.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
}

/// Writes a blob only if its bytes changed, so cargo's rerun-if-changed does not rebuild the
/// firmware on every run of the script.
fn write_if_changed(out: &Path, bytes: &[u8]) -> Result<()> {
    if std::fs::read(out).ok().as_deref() != Some(bytes) {
        write_atomic(out, bytes)?;
    }
    Ok(())
}

fn gen(shape: &str, out: &Path, flags: &BTreeMap<String, String>) -> Result<()> {
    let activation = match flags.get("activation").map(String::as_str) {
        None | Some("tanh") => policy_core::Activation::Tanh,
        Some("relu") => policy_core::Activation::Relu,
        Some(other) => bail!("--activation {other:?}: expected tanh or relu"),
    };
    let seed = match flags.get("seed") {
        Some(s) => s
            .parse()
            .with_context(|| format!("--seed {s:?} is not an integer"))?,
        None => DEFAULT_SEED,
    };
    let encoding = match flags.get("encoding") {
        Some(e) => blobs::parse_encoding(e)?,
        None => policy_core::Encoding::F32,
    };
    let size = |key: &str, default: u16| match flags.get(key) {
        Some(n) => n
            .parse()
            .with_context(|| format!("--{key} {n:?} is not a count")),
        None => Ok(default),
    };
    let sizes = (
        size("observations", blobs::NAV_SIZES.0)?,
        size("actions", blobs::NAV_SIZES.1)?,
    );
    let bytes = blobs::generate(
        blobs::parse_shape(shape, sizes)?,
        seed,
        activation,
        encoding,
    )?;
    write_if_changed(out, &bytes)?;
    println!(
        "{} ({} bytes, {shape} {activation} {encoding}, seed {seed})",
        out.display(),
        bytes.len()
    );
    Ok(())
}

fn measure(flags: &BTreeMap<String, String>) -> Result<()> {
    let blob_path = flag(flags, "blob")?;
    let blob = read(blob_path)?;
    let info = BlobInfo::of(&blob)?;
    let mut log = FirmwareLog::parse(&read_text(flag(flags, "fw-log")?)?)?;
    if let Some(path) = flags.get("calls-log") {
        let calls = FirmwareLog::parse(&read_text(path)?)?;
        calls.require_success().with_context(|| path.clone())?;
        if calls.stack_calls.is_empty() {
            bail!("{path}: expected STACK_PHASE lines of C API calls, found none");
        }
        log.stack_calls = calls.stack_calls;
    }
    let critic = flags.get("critic").map(|c| read(c)).transpose()?;
    let cmp = check::compare_with(&blob, critic.as_deref(), &log, false)?;
    let plugin = flags.get("plugin-log").map(|p| read_text(p)).transpose()?;
    let sizes = measure::parse_sizes(&read_text(flag(flags, "sizes")?)?);
    let variant = measure::Variant {
        name: flag(flags, "variant")?.into(),
        target: flag(flags, "target")?.into(),
        machine: flag(flags, "machine")?.into(),
        cpu: flag(flags, "cpu")?.into(),
        profile: flag(flags, "profile")?.into(),
        opt_level: flag(flags, "opt-level")?.into(),
        blob_path: blob_path.into(),
        encodings: flags
            .get("encodings")
            .map_or("f32,f16,int8", String::as_str)
            .into(),
    };
    let record_len = read(flag(flags, "image")?)?.len() as u64;
    let value = measure::measure(
        &variant,
        &info,
        blob.len() as u64,
        record_len,
        &sizes,
        &log,
        plugin.as_deref(),
        &cmp,
    )?;
    write_atomic(
        Path::new(flag(flags, "out")?),
        serde_json::to_string_pretty(&value)?.as_bytes(),
    )
}

fn report(
    flags: &BTreeMap<String, String>,
    raw: &[String],
    variant_files: &[String],
) -> Result<()> {
    let meta = raw
        .windows(2)
        .filter(|w| w[0] == "--meta")
        .map(|w| {
            w[1].split_once('=')
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .ok_or_else(|| anyhow!("--meta {} is not KEY=VALUE", w[1]))
        })
        .collect::<Result<Vec<_>>>()?;
    let variants = variant_files
        .iter()
        .map(|f| serde_json::from_str(&read_text(f)?).with_context(|| format!("{f} is not JSON")))
        .collect::<Result<Vec<serde_json::Value>>>()?;
    let mut table = report::table(&variants);
    let calls = report::call_table(&variants);
    if !calls.is_empty() {
        table += &format!("\nStack per call of the C API (the c-* variants):\n\n{calls}");
    }
    let doc = report::document(meta, variants)?;
    let out = Path::new(flag(flags, "out")?);
    write_atomic(out, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    write_atomic(&out.with_extension("md"), table.as_bytes())?;
    print!("{table}");
    let aims = &doc["aims"];
    for list in ["per_mac_m4f", "int8_4x48_memory_m4f"] {
        for aim in aims[list].as_array().into_iter().flatten() {
            let met = if aim["met"] == true { "met" } else { "MISSED" };
            let num = |k: &str| aim[k].as_f64().unwrap_or(f64::NAN);
            println!(
                "aim ({}, {} opt {}): {} -> {} ({met}{})",
                aim["variant"].as_str().unwrap_or("?"),
                aim["profile"].as_str().unwrap_or("?"),
                aim["opt_level"].as_str().unwrap_or("?"),
                aim["aim"].as_str().unwrap_or("?"),
                num("value"),
                if aim["met"] == true {
                    String::new()
                } else {
                    format!(", over by {:.3}", num("over_by"))
                }
            );
        }
    }
    println!(
        "variants within 32 KiB of flash: {}",
        aims["variants_within_32KiB_flash"]
    );
    let Some(file) = flags.get("budgets") else {
        return Ok(());
    };
    let budgets = budgets::parse(&read_text(file)?).with_context(|| file.to_string())?;
    let variants = doc["variants"]
        .as_array()
        .map(Vec::as_slice)
        .unwrap_or_default();
    let results = budgets::check(&budgets, variants)?;
    for (budget, outcome) in &results {
        println!("{}", budgets::describe(budget, outcome));
    }
    budgets::verdict(file, &results)
}
