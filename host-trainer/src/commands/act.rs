//! `host-trainer act`: a blob's outputs for given inputs, exactly as policy-core computes them
//! on the chip, each value with its bit pattern, so that a port of the forward pass (a C build,
//! another language, another compiler's libm) can be checked against a reference bit for bit.
//!
//! An actor or a discrete policy prints its action for an observation (`Model::act`: normalised,
//! clipped, the forward pass, `tanh`, scaled into the bounds; a discrete policy's action-table
//! row, then the row's index, `choice N`, and every row's Q value, `q ...`); a critic prints Q(s, a) for an observation followed by a unit-box action
//! (`Model::q`). Inputs are the ones a chip may see, NaN and infinities included.

use std::io::Read;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use firmware_sim::files;
use firmware_sim::out;
use policy_core::model::Model;
use policy_core::ModelKind;

/// The most input lines one call reads (a reference, not a benchmark).
const MAX_LINES: usize = 1_000_000;

#[derive(Debug, Args)]
pub(crate) struct ActArgs {
    /// The blob (policy.postcard, critic.postcard, a quantised blob, ...).
    #[arg(long)]
    blob: PathBuf,
    /// One input, its values separated by commas or spaces: the observation (a critic: the
    /// observation, then the unit-box action). `nan`, `inf` and `-inf` are inputs too. May be
    /// given several times.
    #[arg(long, value_name = "VALUES", allow_hyphen_values = true)]
    obs: Vec<String>,
    /// A file of inputs, one per line (`-`: standard input); blank lines and `#` comments are
    /// skipped.
    #[arg(long, value_name = "FILE")]
    obs_file: Option<PathBuf>,
}

pub(crate) fn act_command(args: &ActArgs) -> Result<()> {
    let path = args.blob.display();
    let bytes = files::read_blob(&args.blob).with_context(|| format!("cannot read blob {path}"))?;
    let model = Model::from_blob(&bytes).with_context(|| format!("{path} is not a valid blob"))?;
    let mut inputs: Vec<(String, Vec<f32>)> = Vec::new();
    for (i, text) in args.obs.iter().enumerate() {
        inputs.push((
            format!("--obs {}", i + 1),
            parse(text, &format!("--obs {}", i + 1))?,
        ));
    }
    if let Some(file) = &args.obs_file {
        let text = read_inputs(file)?;
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or_default().trim();
            if line.is_empty() {
                continue;
            }
            let at = format!("{}:{}", file.display(), n + 1);
            inputs.push((at.clone(), parse(line, &at)?));
            if inputs.len() > MAX_LINES {
                bail!("{}: more than {MAX_LINES} inputs", file.display());
            }
        }
    }
    if inputs.is_empty() {
        bail!("no input: give --obs VALUES or --obs-file FILE");
    }
    let h = model.header();
    let (obs_n, act_n) = (
        usize::from(h.shape.observations),
        usize::from(h.shape.actions),
    );
    let expected = match h.kind {
        ModelKind::Critic => obs_n + act_n,
        _ => obs_n,
    };
    // Every input is checked before the first output line: a bad line costs no half output.
    for (at, values) in &inputs {
        if values.len() != expected {
            bail!(
                "{at}: {} values, the blob takes {expected} ({})",
                values.len(),
                match h.kind {
                    ModelKind::Critic =>
                        format!("{obs_n} observations, then {act_n} unit-box actions"),
                    _ => format!("{obs_n} observations"),
                }
            );
        }
    }
    let mut scratch = vec![0.0f32; model.scratch_floats()];
    let mut text = String::new();
    for (_, values) in &inputs {
        let outputs = match h.kind {
            ModelKind::Critic => {
                let (obs, action) = values.split_at(obs_n);
                vec![model.q_in(obs, action, &mut scratch)?]
            }
            _ => {
                let mut action = vec![0.0f32; act_n];
                model.act_in(values, &mut scratch, &mut action)?;
                action
            }
        };
        text.push_str(&line(values, &outputs));
        if h.kind == ModelKind::Discrete {
            // The row's index: the choice a port's argmax must make (ties: the lowest), then
            // every row's Q value, the argmax's input, with its bits.
            let choice = model.choose_in(values, &mut scratch)?;
            let mut q = vec![0.0f32; usize::from(h.shape.choices)];
            model.choice_values_in(values, &mut scratch, &mut q)?;
            text.push_str(&format!(" choice {choice} q {}", values_and_bits(&q)));
        }
        text.push('\n');
    }
    out!("{text}");
    Ok(())
}

/// `inputs -> outputs [bits]`: every value in Rust's shortest round-trip form, then the
/// outputs' IEEE-754 bit patterns in hex, which a port compares.
fn line(inputs: &[f32], outputs: &[f32]) -> String {
    format!("{} -> {}", join(inputs), values_and_bits(outputs))
}

/// `v0 v1 [bits0 bits1]`.
fn values_and_bits(values: &[f32]) -> String {
    let bits: Vec<String> = values
        .iter()
        .map(|v| format!("{:08x}", v.to_bits()))
        .collect();
    format!("{} [{}]", join(values), bits.join(" "))
}

fn join(values: &[f32]) -> String {
    values
        .iter()
        .map(f32::to_string)
        .collect::<Vec<_>>()
        .join(" ")
}

/// One input's values, separated by commas and/or whitespace.
fn parse(text: &str, at: &str) -> Result<Vec<f32>> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f32>()
                .with_context(|| format!("{at}: {s:?} is not a number"))
        })
        .collect()
}

/// The inputs file's text (`-`: standard input), read whole but bounded.
fn read_inputs(file: &std::path::Path) -> Result<String> {
    const MAX_BYTES: u64 = 256 << 20;
    let mut text = String::new();
    if file.as_os_str() == "-" {
        std::io::stdin()
            .take(MAX_BYTES)
            .read_to_string(&mut text)
            .context("cannot read the inputs from standard input")?;
    } else {
        std::fs::File::open(file)
            .and_then(|f| f.take(MAX_BYTES).read_to_string(&mut text))
            .with_context(|| format!("cannot read {}", file.display()))?;
    }
    Ok(text)
}
