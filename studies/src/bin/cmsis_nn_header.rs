//! `cmsis-nn-header`: an integer actor as a C header for CMSIS-NN's fully connected kernel, with
//! the input codes and the unit codes policy-core computes on them, for the side-by-side count
//! on the Cortex-M4F in `docs/cortex-m.md` ("CMSIS-NN beside the `SMLAD` kernel";
//! `scripts/bench-cmsis-nn.sh` builds and runs it).
//!
//! `cargo run --release -p studies --bin cmsis-nn-header -- BLOB OUT.h`
//!
//! BLOB is an actor in the integer encoding (docs/blob-format.md, "The integer encoding"). Each
//! layer is written in the layout and the sign conventions `arm_fully_connected_per_channel_s8`
//! takes:
//!
//! - the int8 weights **row-major** (one output's weights together: `w[o * inputs + j]`), where
//!   the blob stores them column-major (`q[j * outputs + o]`);
//! - int32 biases, and the per-output multipliers and shifts as int32 (CMSIS-NN's shift is ours:
//!   negative to the right);
//! - `input_offset = −Z_in` (CMSIS-NN adds it to each input code) and `output_offset = Z_out`
//!   (added after the requantisation, as TensorFlow Lite Micro passes the zero point);
//! - the clamp `[act_min, 127]`: the fused ReLU's `Z_out` on a hidden layer of a ReLU actor, else
//!   −128; the weights are symmetric, so the filter offset is 0;
//! - the 256-entry tanh table of a layer that has one (`table[code + 128]`).
//!
//! Then the blob's bytes themselves (so the same program runs policy-core's C API on them), and
//! test cases: the input codes of the fixed observations the firmware acts on
//! (`firmware/src/observations.rs`, through [`Model::observation_codes`]) and of a spread of
//! codes over the int8 range, each with the unit codes [`Model::act_codes_in`] computes.

use std::fmt::Write as _;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use policy_core::blob::{self, Encoding, IntegerLayer};
use policy_core::model::Model;
use policy_core::{Activation, ModelKind};

#[path = "../../../firmware/src/observations.rs"]
mod observations;

/// Input cases beyond the firmware's observations: codes spread over the whole int8 range.
const SPREAD_CASES: usize = 22;

/// One layer in CMSIS-NN's terms.
#[derive(Debug, PartialEq)]
struct CmsisLayer {
    inputs: usize,
    outputs: usize,
    /// Row-major: `weights[o * inputs + j]`.
    weights: Vec<i8>,
    bias: Vec<i32>,
    multiplier: Vec<i32>,
    shift: Vec<i32>,
    /// Added to each input code: the negative of the input zero point.
    input_offset: i32,
    /// Added after the requantisation: the output zero point.
    output_offset: i32,
    act_min: i32,
    act_max: i32,
    table: Option<Vec<i8>>,
}

fn words(bytes: &[u8]) -> Vec<i32> {
    bytes
        .chunks_exact(4)
        .map(|w| i32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect()
}

fn signed(bytes: &[u8]) -> Vec<i8> {
    bytes.iter().map(|&b| b as i8).collect()
}

/// Every layer of the integer actor `bytes`, in CMSIS-NN's layout and conventions.
fn cmsis_layers(bytes: &[u8]) -> Result<Vec<CmsisLayer>> {
    let verified = blob::verify(bytes).context("not a valid blob")?;
    let h = verified.header;
    if h.encoding != Encoding::Integer || h.kind != ModelKind::Actor {
        bail!(
            "expected an actor in the integer encoding, found a {:?} in {:?}",
            h.kind,
            h.encoding
        );
    }
    let payload = verified.payload;
    let relu = h.activation == Activation::Relu;
    let mut found: Vec<IntegerLayer> = Vec::new();
    let (input, _) = blob::integer_layers(h.kind, h.shape, h.activation, |_, l| found.push(l))
        .context("the blob's integer layout overflows")?;
    let mut x_zero = words(&payload[input.zero..input.zero + 4])[0];
    let mut layers = Vec::new();
    for l in found {
        let d = l.dense(payload, relu);
        let mut weights = vec![0i8; l.inputs * l.outputs];
        for (k, &q) in d.weights.iter().enumerate() {
            let (j, o) = (k / l.outputs, k % l.outputs);
            weights[o * l.inputs + j] = q as i8;
        }
        layers.push(CmsisLayer {
            inputs: l.inputs,
            outputs: l.outputs,
            weights,
            bias: words(d.bias),
            multiplier: words(d.multipliers),
            shift: d.shifts.iter().map(|&s| i32::from(s as i8)).collect(),
            input_offset: -x_zero,
            output_offset: d.output_zero,
            act_min: d.lower,
            act_max: 127,
            table: d.table.map(signed),
        });
        x_zero = if d.table.is_some() { 0 } else { d.output_zero };
    }
    Ok(layers)
}

/// One row of int8 codes per case.
type Codes = Vec<Vec<i8>>;

/// The test cases: input codes and the unit codes policy-core's integer entry computes.
fn cases(bytes: &[u8]) -> Result<(Codes, Codes)> {
    let model = Model::from_blob(bytes).context("the blob does not load")?;
    let h = model.header();
    let (s, a) = (h.shape.observations as usize, h.shape.actions as usize);
    let mut inputs = Vec::new();
    for k in 0..observations::CASES {
        let mut obs = vec![0.0; s];
        observations::fill(k, &mut obs);
        let mut codes = vec![0i8; s];
        model.observation_codes(&obs, &mut codes)?;
        inputs.push(codes);
    }
    for k in 0..SPREAD_CASES {
        inputs.push(
            (0..s)
                .map(|j| ((k * 37 + j * 101) % 256) as u8 as i8)
                .collect(),
        );
    }
    let width = model.scratch_width();
    let mut outputs = Vec::new();
    for codes in &inputs {
        let mut unit = vec![0i8; a];
        model.act_codes_in(codes, &mut vec![0i32; 2 * width], &mut unit)?;
        outputs.push(unit);
    }
    Ok((inputs, outputs))
}

fn list<T: std::fmt::Display>(values: &[T]) -> String {
    let mut out = String::new();
    for (k, v) in values.iter().enumerate() {
        let sep = if k % 16 == 0 { "\n    " } else { " " };
        let _ = write!(out, "{sep}{v},");
    }
    out
}

/// The header's text for the blob `bytes`, named `name` in its first line.
fn header(bytes: &[u8], name: &str) -> Result<String> {
    let layers = cmsis_layers(bytes)?;
    let (inputs, outputs) = cases(bytes)?;
    let macs: usize = layers.iter().map(|l| l.inputs * l.outputs).sum();
    let width = layers
        .iter()
        .map(|l| l.inputs.max(l.outputs))
        .max()
        .unwrap_or(0);
    let mut h = String::new();
    let _ = writeln!(
        h,
        "/* {name} for CMSIS-NN's arm_fully_connected_per_channel_s8, written by\n   `cargo run -p studies --bin cmsis-nn-header`. Do not edit. */"
    );
    h.push_str("#ifndef CMSIS_NN_NET_H\n#define CMSIS_NN_NET_H\n\n#include <stdint.h>\n\n");
    let first = layers.first().map_or(0, |l| l.inputs);
    let last = layers.last().map_or(0, |l| l.outputs);
    for (what, v) in [
        ("NET_OBSERVATIONS", first),
        ("NET_ACTIONS", last),
        ("NET_LAYERS", layers.len()),
        ("NET_WIDTH", width),
        ("NET_MACS", macs),
        ("NET_OUTPUTS", layers.iter().map(|l| l.outputs).sum()),
        ("NET_CASES", inputs.len()),
        ("NET_BLOB_LEN", bytes.len()),
    ] {
        let _ = writeln!(h, "#define {what} {v}");
    }
    h.push('\n');
    for (n, l) in layers.iter().enumerate() {
        let _ = writeln!(
            h,
            "/* layer {n}: {} inputs, {} outputs */",
            l.inputs, l.outputs
        );
        let _ = writeln!(
            h,
            "static const int8_t layer{n}_weights[{}] __attribute__((aligned(4))) = {{{}\n}};",
            l.weights.len(),
            list(&l.weights)
        );
        for (part, v) in [
            ("bias", &l.bias),
            ("multiplier", &l.multiplier),
            ("shift", &l.shift),
        ] {
            let _ = writeln!(
                h,
                "static int32_t layer{n}_{part}[{}] = {{{}\n}};",
                v.len(),
                list(v)
            );
        }
        if let Some(t) = &l.table {
            let _ = writeln!(
                h,
                "static const int8_t layer{n}_table[256] = {{{}\n}};",
                list(t)
            );
        }
    }
    h.push_str("\nstruct net_layer {\n    int32_t inputs, outputs;\n    const int8_t *weights;\n    const int32_t *bias;\n    int32_t *multiplier, *shift;\n    int32_t input_offset, output_offset, act_min, act_max;\n    const int8_t *table; /* NULL: no table */\n};\n\n");
    h.push_str("static const struct net_layer NET[NET_LAYERS] = {\n");
    for (n, l) in layers.iter().enumerate() {
        let table = if l.table.is_some() {
            format!("layer{n}_table")
        } else {
            "0".into()
        };
        let _ = writeln!(
            h,
            "    {{{}, {}, layer{n}_weights, layer{n}_bias, layer{n}_multiplier, layer{n}_shift, {}, {}, {}, {}, {table}}},",
            l.inputs, l.outputs, l.input_offset, l.output_offset, l.act_min, l.act_max
        );
    }
    h.push_str("};\n\n");
    let rows = |rows: &[Vec<i8>]| {
        rows.iter()
            .map(|r| {
                format!(
                    "    {{{}}},\n",
                    r.iter()
                        .map(|c| c.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
            .collect::<String>()
    };
    let _ = writeln!(
        h,
        "/* Input codes, then the unit codes policy-core's Model::act_codes_in computes on them. */\nstatic const int8_t NET_INPUT_CODES[NET_CASES][NET_OBSERVATIONS] = {{\n{}}};\nstatic const int8_t NET_UNIT_CODES[NET_CASES][NET_ACTIONS] = {{\n{}}};\n",
        rows(&inputs),
        rows(&outputs)
    );
    let _ = writeln!(
        h,
        "/* The blob itself, for policy-core's C API. */\nstatic const uint8_t NET_BLOB[NET_BLOB_LEN] __attribute__((aligned(4))) = {{{}\n}};\n\n#endif",
        list(bytes)
    );
    Ok(h)
}

fn run(blob_path: &str, out: &str) -> Result<()> {
    let bytes = std::fs::read(blob_path).with_context(|| format!("cannot read {blob_path}"))?;
    let text = header(&bytes, blob_path).with_context(|| blob_path.to_string())?;
    std::fs::write(out, text).with_context(|| format!("cannot write {out}"))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [blob_path, out] = args.as_slice() else {
        eprintln!("usage: cmsis-nn-header BLOB OUT.h");
        return ExitCode::from(2);
    };
    match run(blob_path, out) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("cmsis-nn-header: {e:#}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    static GOLDEN: &[u8] =
        include_bytes!("../../../policy-core/tests/golden/actor_4x48_integer.postcard");

    /// Guards the transpose: each output's weights in a row, the blob's columns read across.
    #[test]
    fn weights_are_row_major() {
        let v = blob::verify(GOLDEN).unwrap();
        let layers = cmsis_layers(GOLDEN).unwrap();
        let mut at = Vec::new();
        let h = v.header;
        blob::integer_layers(h.kind, h.shape, h.activation, |_, l| at.push(l)).unwrap();
        for (l, c) in at.iter().zip(&layers) {
            for (j, o) in [(0, 0), (0, 1), (1, 0), (l.inputs - 1, l.outputs - 1)] {
                let q = v.payload[l.weights + j * l.outputs + o] as i8;
                assert_eq!(c.weights[o * l.inputs + j], q, "input {j}, output {o}");
            }
        }
    }

    /// The trained ReLU actor the bench runs (the golden one is tanh).
    static TRAINED: &[u8] =
        include_bytes!("../../../models/nav-walls__dcp-paper__0-integer.postcard");

    /// The offsets follow the zero points from layer to layer, with CMSIS-NN's signs, and the
    /// clamp is the fused ReLU's on a hidden layer without a table.
    #[test]
    fn offsets_and_clamps_follow_the_zero_points() {
        for (name, bytes, relu) in [("golden", GOLDEN, false), ("trained", TRAINED, true)] {
            let layers = cmsis_layers(bytes).unwrap();
            let last = layers.len() - 1;
            for (n, pair) in layers.windows(2).enumerate() {
                let after = if pair[0].table.is_some() {
                    0
                } else {
                    pair[0].output_offset
                };
                assert_eq!(pair[1].input_offset, -after, "{name}: layer {}", n + 1);
            }
            for (n, l) in layers[..last].iter().enumerate() {
                assert_eq!(l.table.is_none(), relu, "{name}: layer {n}");
                let lower = if relu { l.output_offset } else { -128 };
                assert_eq!((l.act_min, l.act_max), (lower, 127), "{name}: layer {n}");
            }
            let out = &layers[last];
            assert_eq!(
                (out.act_min, out.table.as_ref().map(Vec::len)),
                (-128, Some(256))
            );
        }
    }

    /// A forward pass over the header's arrays, as the C program runs it, gives policy-core's
    /// unit codes on every case.
    #[test]
    fn a_pass_over_the_exported_layers_gives_the_host_codes() {
        for bytes in [GOLDEN, TRAINED] {
            pass_gives_the_host_codes(bytes);
        }
    }

    fn pass_gives_the_host_codes(bytes: &[u8]) {
        let layers = cmsis_layers(bytes).unwrap();
        let (inputs, outputs) = cases(bytes).unwrap();
        assert_eq!(inputs.len(), observations::CASES + SPREAD_CASES);
        for (x, expected) in inputs.iter().zip(&outputs) {
            let mut x: Vec<i32> = x.iter().map(|&c| i32::from(c)).collect();
            for l in &layers {
                x = (0..l.outputs)
                    .map(|o| {
                        let row = &l.weights[o * l.inputs..(o + 1) * l.inputs];
                        let acc = l.bias[o]
                            + row
                                .iter()
                                .zip(&x)
                                .map(|(&w, &v)| i32::from(w) * (v + l.input_offset))
                                .sum::<i32>();
                        let v = policy_core::mlp::integer::multiply_by_quantized_multiplier(
                            acc,
                            l.multiplier[o],
                            l.shift[o],
                        );
                        let y = (v + l.output_offset).clamp(l.act_min, l.act_max);
                        l.table
                            .as_ref()
                            .map_or(y, |t| i32::from(t[(y + 128) as usize]))
                    })
                    .collect();
            }
            let got: Vec<i8> = x.iter().map(|&c| c as i8).collect();
            assert_eq!(&got, expected);
        }
    }

    /// The header names the sizes and holds the first layer's first row as written.
    #[test]
    fn the_header_holds_the_sizes_and_the_rows() {
        let text = header(GOLDEN, "golden").unwrap();
        let layers = cmsis_layers(GOLDEN).unwrap();
        assert!(text.contains("#define NET_LAYERS 5\n"), "{}", &text[..400]);
        assert!(text.contains("#define NET_WIDTH 48\n"));
        let first = &layers[0];
        let row: Vec<String> = first.weights[..first.inputs]
            .iter()
            .map(|w| format!("{w},"))
            .collect();
        assert!(text.contains(&format!(
            "layer0_weights[{}] __attribute__((aligned(4))) = {{\n    {}",
            first.weights.len(),
            row.join(" ")
        )));
    }
}
