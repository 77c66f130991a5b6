//! One `key = value` line of a TOML text, kept or mutated: the edit strategy the scenario,
//! badminton and train-config mutation tests share.

use proptest::prelude::*;

/// What happens to one line.
#[derive(Clone, Debug)]
pub enum Edit {
    Keep,
    Drop,
    Duplicate,
    /// A value from the caller's list of edge values, by index.
    Value(usize),
    /// A random number in place of the value.
    Number(f64),
    /// The valid value times a factor, keeping its type (integers stay integers).
    Scale(f64),
}

/// Edits with `keep` times the weight of each mutation; `values` edge values to pick from and
/// random numbers from `numbers` (or any f64).
pub fn edit(
    keep: u32,
    values: usize,
    numbers: std::ops::Range<f64>,
) -> impl Strategy<Value = Edit> {
    prop_oneof![
        keep => Just(Edit::Keep),
        1 => Just(Edit::Drop),
        1 => Just(Edit::Duplicate),
        1 => (0..values).prop_map(Edit::Value),
        1 => prop_oneof![numbers, any::<f64>()].prop_map(Edit::Number),
        1 => (0.0f64..3.0).prop_map(Edit::Scale),
    ]
}

/// A TOML float that parses back to `x` (TOML spells the non-finite ones `nan`, `inf`).
pub fn float(x: f64) -> String {
    match x {
        x if x.is_nan() => "nan".into(),
        x if x.is_infinite() => if x > 0.0 { "inf" } else { "-inf" }.into(),
        x => format!("{x:?}"),
    }
}

/// The line `key = value` after `e`, with its newline; `values` is the list `Edit::Value`
/// indexes.
pub fn line(key: &str, value: &str, e: &Edit, values: &[&str]) -> String {
    match e {
        Edit::Keep => format!("{key} = {value}\n"),
        Edit::Drop => String::new(),
        Edit::Duplicate => format!("{key} = {value}\n{key} = {value}\n"),
        Edit::Value(i) => format!("{key} = {}\n", values[*i]),
        Edit::Number(x) => format!("{key} = {}\n", float(*x)),
        Edit::Scale(f) => match (value.parse::<u32>(), value.parse::<f64>()) {
            (Ok(n), _) => format!("{key} = {}\n", (f64::from(n) * f).round() as u32),
            (_, Ok(x)) => format!("{key} = {}\n", float(x * f)),
            _ => format!("{key} = {value}\n"),
        },
    }
}

/// `text` with `edits` applied, in order, to its `key = value` lines (comments, section headers
/// and blank lines kept; a line beyond the edits is kept). After the line whose key is
/// `extra_after`, `extra = 1` is added when `extra` is given.
pub fn apply(text: &str, edits: &[Edit], values: &[&str], extra: Option<(&str, &str)>) -> String {
    let mut out = String::new();
    let mut edits = edits.iter();
    for source in text.lines() {
        let Some((key, value)) = source
            .split_once(" = ")
            .filter(|_| !source.starts_with('#'))
        else {
            out.push_str(source);
            out.push('\n');
            continue;
        };
        let value = value.split(" #").next().unwrap_or(value).trim();
        out.push_str(&line(
            key,
            value,
            edits.next().unwrap_or(&Edit::Keep),
            values,
        ));
        if let Some((_, extra)) = extra.filter(|(after, _)| *after == key) {
            out.push_str(&format!("{extra} = 1\n"));
        }
    }
    out
}
