//! The combined report: every variant, the aims of the Cortex-M issue, and a Markdown table.

use anyhow::Result;
use serde_json::{json, Value};

/// The aims, checked on a 4x48 actor on the Cortex-M4F: (name, JSON pointer, limit).
const AIMS: [(&str, &str, f64); 3] = [
    (
        "instructions per multiply-accumulate in act < 3.5",
        "/instructions/per_mac",
        3.5,
    ),
    (
        "whole firmware flash incl. blob < 32 KiB",
        "/flash/total",
        32768.0,
    ),
    (
        "RAM in all (static + peak stack; the weights stay in flash) < 4 KiB",
        "/ram/total",
        4096.0,
    ),
];

/// The variants the aims are evaluated on, in order of preference: the given (trained) blob if
/// it is a 4x48, else the generated 4x48.
const AIM_VARIANTS: [&str; 2] = ["m4f-trained", "m4f-4x48"];

/// Evaluates the aims on the first of [`AIM_VARIANTS`] that ran a 4x48 blob (reported, never
/// asserted).
pub fn aims(variants: &[Value]) -> Value {
    let found = AIM_VARIANTS.iter().find_map(|name| {
        variants
            .iter()
            .find(|v| v["variant"] == *name && v["shape"] == "4x48")
    });
    let Some(v) = found else {
        return json!({ "variant": Value::Null, "evaluated": false });
    };
    let list: Vec<Value> = AIMS
        .iter()
        .map(|(what, ptr, limit)| {
            let value = v.pointer(ptr).and_then(Value::as_f64).unwrap_or(f64::NAN);
            json!({ "aim": what, "value": value, "limit": limit, "met": value < *limit,
                    "over_by": if value < *limit { 0.0 } else { value - limit } })
        })
        .collect();
    let fits: Vec<&Value> = variants
        .iter()
        .filter(|v| {
            v.pointer("/flash/total")
                .and_then(Value::as_f64)
                .is_some_and(|f| f < 32768.0)
        })
        .map(|v| &v["variant"])
        .collect();
    json!({ "variant": v["variant"], "evaluated": true, "aims": list, "variants_under_32KiB_flash": fits })
}

/// A Markdown table of the variants (one row each).
pub fn table(variants: &[Value]) -> String {
    let mut out = String::from(
        "| variant | blob | flash B (blob) | .text | static RAM B (scratch) | peak stack B | RAM in all B \
         | instr/act mean (max) | instr/MAC | excl. tanhf | instr/tanhf | boot instr | host check |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for v in variants {
        let g = |p: &str| v.pointer(p).cloned().unwrap_or(Value::Null);
        out += &format!(
            "| {} | {} {} {} v{} | {} ({}) | {} | {} ({}) | {} | {} | {} ({}) | {} | {} | {} | {} | {} |\n",
            g("/variant").as_str().unwrap_or("?"),
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
            g("/instructions/per_mac_excluding_tanhf"),
            g("/instructions/tanhf_each"),
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

/// The whole report document.
pub fn document(meta: Vec<(String, String)>, variants: Vec<Value>) -> Result<Value> {
    let aims = aims(&variants);
    let meta: serde_json::Map<String, Value> = meta
        .into_iter()
        .map(|(k, v)| (k, Value::String(v)))
        .collect();
    Ok(json!({ "meta": meta, "variants": variants, "aims_m4f_4x48": aims }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aims_say_by_how_much_they_are_missed() {
        let v = vec![
            json!({ "variant": "m4f-4x48", "shape": "4x48", "instructions": { "per_mac": 5.5 },
                             "flash": { "total": 40000 }, "ram": { "total": 1000 } }),
        ];
        let a = aims(&v);
        assert_eq!(a["aims"][0]["met"], false);
        assert_eq!(a["aims"][0]["over_by"], 2.0);
        assert_eq!(a["aims"][2]["met"], true);
        assert_eq!(a["variants_under_32KiB_flash"].as_array().unwrap().len(), 0);
        assert!(table(&v).contains("| m4f-4x48 |"));
    }
}
