//! The combined report: every variant, the Cortex-M aims, and a Markdown table.

use anyhow::Result;
use serde_json::{json, Value};

/// Instructions per multiply-accumulate allowed on the Cortex-M4F, per weight encoding (ReLU
/// networks, so that the figure is the multiply-accumulates' cost, not tanhf's).
const PER_MAC_AIMS: [(&str, f64); 3] = [("f32", 3.5), ("int8", 5.0), ("f16", 6.0)];

/// Flash (with the blob) and RAM in all (static + peak stack) allowed for an int8 4x48 firmware.
const FLASH_AIM: f64 = 32768.0;
/// See [`FLASH_AIM`].
const RAM_AIM: f64 = 4096.0;

const M4F_TARGET: &str = "thumbv7em-none-eabihf";

fn num(v: &Value, ptr: &str) -> f64 {
    v.pointer(ptr).and_then(Value::as_f64).unwrap_or(f64::NAN)
}

/// One aim on one variant: `value <= limit`, and by how much it is missed.
fn aim(v: &Value, what: &str, ptr: &str, limit: f64) -> Value {
    let value = num(v, ptr);
    let met = value <= limit;
    json!({ "variant": v["variant"], "profile": v["profile"], "opt_level": v["opt_level"],
            "encoding": v["encoding"], "shape": v["shape"], "aim": what, "value": value,
            "limit": limit, "met": met, "over_by": if met { 0.0 } else { value - limit } })
}

/// Evaluates the aims (reported, never asserted): instructions per MAC of every ReLU variant on
/// the M4F against its encoding's limit, and flash and RAM of every int8 4x48 M4F firmware.
pub fn aims(variants: &[Value]) -> Value {
    // A firmware running the compare step (`refine`) does T + 1 critic passes per act: its
    // instructions per actor MAC and its flash are not the plain policy's, so no aim applies.
    let m4f = || {
        variants
            .iter()
            .filter(|v| v["target"] == M4F_TARGET && v["refine"].is_null())
    };
    let per_mac: Vec<Value> = m4f()
        .filter(|v| v["blob"]["activation"] == "relu")
        .filter_map(|v| {
            let (enc, limit) = PER_MAC_AIMS.iter().find(|(e, _)| v["encoding"] == *e)?;
            Some(aim(
                v,
                &format!("{enc} ReLU: instructions per multiply-accumulate <= {limit}"),
                "/instructions/per_mac",
                *limit,
            ))
        })
        .collect();
    let memory: Vec<Value> = m4f()
        .filter(|v| v["encoding"] == "int8" && v["shape"] == "4x48")
        .flat_map(|v| {
            [
                aim(
                    v,
                    "whole firmware flash incl. blob <= 32 KiB",
                    "/flash/total",
                    FLASH_AIM,
                ),
                aim(
                    v,
                    "RAM in all (static + peak stack; the weights stay in flash) <= 4 KiB",
                    "/ram/total",
                    RAM_AIM,
                ),
            ]
        })
        .collect();
    let fits: Vec<&Value> = variants
        .iter()
        .filter(|v| num(v, "/flash/total") <= FLASH_AIM)
        .map(|v| &v["variant"])
        .collect();
    json!({ "per_mac_m4f": per_mac, "int8_4x48_memory_m4f": memory,
            "variants_within_32KiB_flash": fits })
}

/// A figure for the table, or `-` where the variant has none (the C firmware times no tanhf).
fn or_dash(v: Value) -> String {
    match v {
        Value::Null => "-".to_string(),
        v => v.to_string(),
    }
}

/// A Markdown table of the variants (one row each).
pub fn table(variants: &[Value]) -> String {
    let mut out = String::from(
        "| variant | encoding | profile | blob | flash B (blob) | .text | static RAM B (scratch) | peak stack B | RAM in all B \
         | instr/act mean (max) | instr/MAC | excl. tanhf | instr/tanhf | boot instr | host check |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for v in variants {
        let g = |p: &str| v.pointer(p).cloned().unwrap_or(Value::Null);
        out += &format!(
            "| {} | {} | {} (opt {}) | {} {} {} v{} | {} ({}) | {} | {} ({}) | {} | {} | {} ({}) | {} | {} | {} | {} | {} |\n",
            g("/variant").as_str().unwrap_or("?"),
            g("/encoding").as_str().unwrap_or("?"),
            g("/profile").as_str().unwrap_or("?"),
            g("/opt_level").as_str().unwrap_or("?"),
            g("/shape").as_str().unwrap_or("?"),
            g("/blob/kind").as_str().unwrap_or("?"),
            g("/blob/activation").as_str().unwrap_or("?"),
            g("/blob/version"),
            g("/flash/total"),
            g("/flash/blob"),
            g("/flash/text"),
            g("/ram/static_total"),
            g("/ram/scratch"),
            g("/ram/stack_peak"),
            g("/ram/total"),
            g("/instructions/act_mean"),
            g("/instructions/act_max"),
            g("/instructions/per_mac"),
            or_dash(g("/instructions/per_mac_excluding_tanhf")),
            or_dash(g("/instructions/tanhf_each")),
            g("/instructions/boot"),
            if g("/check/bit_exact") == Value::Bool(true) {
                "bit-exact"
            } else {
                "DIFFERS"
            },
        );
    }
    out
}

/// A Markdown table of the stack each C API call used below its caller's frame (one row per
/// call, in the order the firmware measured them; one column per variant that measured them),
/// or nothing when no variant did.
pub fn call_table(variants: &[Value]) -> String {
    let measured: Vec<(&str, &Vec<Value>)> = variants
        .iter()
        .filter_map(|v| {
            let calls = v.pointer("/ram/stack_per_call")?.as_array()?;
            (!calls.is_empty()).then(|| (v["variant"].as_str().unwrap_or("?"), calls))
        })
        .collect();
    let mut calls: Vec<&str> = Vec::new();
    for call in measured.iter().flat_map(|(_, c)| c.iter()) {
        let name = call["call"].as_str().unwrap_or("?");
        if !calls.contains(&name) {
            calls.push(name);
        }
    }
    if calls.is_empty() {
        return String::new();
    }
    let mut out = String::from("| stack B below the caller |");
    let mut rule = String::from("|---|");
    for (variant, _) in &measured {
        out += &format!(" {variant} |");
        rule += "---:|";
    }
    out += &format!("\n{rule}\n");
    for call in calls {
        out += &format!("| `{call}` |");
        for (_, measured_calls) in &measured {
            let bytes = measured_calls.iter().find(|c| c["call"] == call);
            out += &format!(
                " {} |",
                or_dash(bytes.map_or(Value::Null, |c| c["bytes"].clone()))
            );
        }
        out.push('\n');
    }
    out
}

/// The whole report document.
pub fn document(meta: Vec<(String, String)>, variants: Vec<Value>) -> Result<Value> {
    let aims = aims(&variants);
    let meta: serde_json::Map<String, Value> = meta
        .into_iter()
        .map(|(k, v)| (k, Value::String(v)))
        .collect();
    Ok(json!({ "meta": meta, "variants": variants, "aims": aims }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aims_say_by_how_much_they_are_missed() {
        let v = vec![
            json!({ "variant": "m4f-4x48-relu-int8", "target": M4F_TARGET, "shape": "4x48",
                    "encoding": "int8", "profile": "release", "opt_level": "3",
                    "blob": { "activation": "relu" }, "instructions": { "per_mac": 5.5 },
                    "flash": { "total": 40000 }, "ram": { "total": 1000 } }),
            json!({ "variant": "m4f-2x32-relu-f16", "target": M4F_TARGET, "shape": "2x32",
                    "encoding": "f16", "blob": { "activation": "relu" },
                    "instructions": { "per_mac": 6.0 }, "flash": { "total": 30000 } }),
            json!({ "variant": "m3-4x48-relu-int8", "target": "thumbv7m-none-eabi",
                    "shape": "4x48", "encoding": "int8", "blob": { "activation": "relu" },
                    "instructions": { "per_mac": 100.0 } }),
        ];
        let a = aims(&v);
        let per_mac = a["per_mac_m4f"].as_array().unwrap();
        assert_eq!(per_mac.len(), 2, "M4F only");
        assert_eq!(per_mac[0]["met"], false);
        assert_eq!(per_mac[0]["over_by"], 0.5);
        assert_eq!(per_mac[1]["met"], true, "the limit itself is met");
        let memory = a["int8_4x48_memory_m4f"].as_array().unwrap();
        assert_eq!(memory.len(), 2);
        assert_eq!(memory[0]["over_by"], 40000.0 - 32768.0);
        assert_eq!(memory[1]["met"], true);
        assert_eq!(
            a["variants_within_32KiB_flash"],
            json!(["m4f-2x32-relu-f16"])
        );
        assert!(table(&v).contains("| m4f-4x48-relu-int8 | int8 | release (opt 3) |"));
        assert_eq!(call_table(&v), "", "no variant measured its calls");
    }

    #[test]
    fn the_call_table_has_a_row_per_call_and_a_column_per_variant() {
        let calls = |list: &[(&str, u64)]| {
            list.iter()
                .map(|(c, b)| json!({ "call": c, "bytes": b }))
                .collect::<Vec<_>>()
        };
        let v = vec![
            json!({ "variant": "c-m4f-trained", "ram": { "stack_per_call":
                    calls(&[("dcp_verify", 900), ("dcp_q", 700)]) } }),
            json!({ "variant": "m4f-trained", "ram": { "stack_phases": { "act": 100 } } }),
            json!({ "variant": "c-m0-trained", "ram": { "stack_per_call":
                    calls(&[("dcp_verify", 988)]) } }),
        ];
        assert_eq!(
            call_table(&v),
            "| stack B below the caller | c-m4f-trained | c-m0-trained |\n|---|---:|---:|\n\
             | `dcp_verify` | 900 | 988 |\n| `dcp_q` | 700 | - |\n"
        );
    }
}
