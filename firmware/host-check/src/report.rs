//! The combined report: every variant, the aims of the Cortex-M issue, and a Markdown table.

use anyhow::Result;
use serde_json::{json, Value};

/// The aims, checked on the 4x48 actor on the Cortex-M4F: (name, JSON pointer, limit).
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
        "static RAM + peak stack beyond the weights < 4 KiB",
        "/ram/beyond_weights",
        4096.0,
    ),
];

/// Evaluates the aims on variant `on` (reported, never asserted).
pub fn aims(variants: &[Value], on: &str) -> Value {
    let Some(v) = variants.iter().find(|v| v["variant"] == on) else {
        return json!({ "variant": on, "evaluated": false });
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
    json!({ "variant": on, "evaluated": true, "aims": list, "variants_under_32KiB_flash": fits })
}

/// A Markdown table of the variants (one row each).
pub fn table(variants: &[Value]) -> String {
    let mut out = String::from(
        "| variant | flash B (blob) | .text | static RAM B (slot) | peak stack B | RAM beyond weights B \
         | instr/act mean (max) | instr/MAC | excl. tanhf | instr/tanhf | load_into instr | host check |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for v in variants {
        let g = |p: &str| v.pointer(p).cloned().unwrap_or(Value::Null);
        out += &format!(
            "| {} | {} ({}) | {} | {} ({}) | {} | {} | {} ({}) | {} | {} | {} | {} | {} |\n",
            g("/variant").as_str().unwrap_or("?"),
            g("/flash/total"),
            g("/flash/blob"),
            g("/flash/text"),
            g("/ram/static_total"),
            g("/ram/policy_slot"),
            g("/ram/stack_peak"),
            g("/ram/beyond_weights"),
            g("/instructions/act_mean"),
            g("/instructions/act_max"),
            g("/instructions/per_mac"),
            g("/instructions/per_mac_excluding_tanhf"),
            g("/instructions/tanhf_each"),
            g("/instructions/load_into"),
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
    let aims = aims(&variants, "m4f-4x48");
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
            json!({ "variant": "m4f-4x48", "instructions": { "per_mac": 5.5 },
                             "flash": { "total": 40000 }, "ram": { "beyond_weights": 1000 } }),
        ];
        let a = aims(&v, "m4f-4x48");
        assert_eq!(a["aims"][0]["met"], false);
        assert_eq!(a["aims"][0]["over_by"], 2.0);
        assert_eq!(a["aims"][2]["met"], true);
        assert_eq!(a["variants_under_32KiB_flash"].as_array().unwrap().len(), 0);
        assert!(table(&v).contains("| m4f-4x48 |"));
    }
}
