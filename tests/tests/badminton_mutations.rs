//! The shipped badminton scenario, mutated line by line (proptest).
//!
//! Each `key = value` line of `scenarios/badminton.toml` may be kept, dropped, duplicated, or
//! given another value (another number, a non-finite one, a value of another type), and an
//! unknown key may be added; the text goes through [`tests::badminton_checks::check`], the same
//! properties the `badminton` fuzz target checks: refused in one line, or a few points played.

use firmware_sim::badminton::Config;
use proptest::prelude::*;
use tests::badminton_checks;

/// Values of every TOML type, at the edges of the scenario's rules.
const VALUES: &[&str] = &[
    "0",
    "-1",
    "1",
    "0.0",
    "-0.0",
    "1e-7",
    "0.5",
    "1.0",
    "2.0",
    "50.0",
    "89.9",
    "90.0",
    "-90.0",
    "200.0",
    "1e38",
    "1e308",
    "nan",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "\"\"",
    "true",
    "[]",
    "[1.0, 2.0]",
    "[1.0]",
    "{}",
];

/// What happens to one line.
#[derive(Clone, Debug)]
enum Edit {
    Keep,
    Drop,
    Duplicate,
    /// A value from [`VALUES`].
    Value(usize),
    /// A random number in place of the value.
    Number(f64),
    /// The valid value times a factor, keeping its type (integers stay integers).
    Scale(f64),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        12 => Just(Edit::Keep),
        1 => Just(Edit::Drop),
        1 => Just(Edit::Duplicate),
        1 => (0..VALUES.len()).prop_map(Edit::Value),
        1 => prop_oneof![-10.0f64..100.0, any::<f64>()].prop_map(Edit::Number),
        1 => (0.0f64..3.0).prop_map(Edit::Scale),
    ]
}

/// A TOML float that parses back to `x`.
fn float(x: f64) -> String {
    match x {
        x if x.is_nan() => "nan".into(),
        x if x.is_infinite() => if x > 0.0 { "inf" } else { "-inf" }.into(),
        x => format!("{x:?}"),
    }
}

/// The shipped text with `edits` applied to its `key = value` lines (other lines kept).
fn render(edits: &[Edit], extra: Option<&str>) -> String {
    let mut text = String::new();
    let mut edits = edits.iter();
    for line in Config::BUILTIN.lines() {
        let Some((key, value)) = line.split_once(" = ").filter(|_| !line.starts_with('#')) else {
            text.push_str(line);
            text.push('\n');
            continue;
        };
        let value = value.split(" #").next().unwrap_or(value).trim();
        let e = edits.next().unwrap_or(&Edit::Keep);
        text.push_str(&match e {
            Edit::Keep => format!("{key} = {value}\n"),
            Edit::Drop => String::new(),
            Edit::Duplicate => format!("{key} = {value}\n{key} = {value}\n"),
            Edit::Value(i) => format!("{key} = {}\n", VALUES[*i]),
            Edit::Number(x) => format!("{key} = {}\n", float(*x)),
            Edit::Scale(f) => match (value.parse::<u32>(), value.parse::<f64>()) {
                (Ok(n), _) => format!("{key} = {}\n", (f64::from(n) * f).round() as u32),
                (_, Ok(x)) => format!("{key} = {}\n", float(x * f)),
                _ => format!("{key} = {value}\n"),
            },
        });
        if let (Some(extra), true) = (extra, key == "name") {
            text.push_str(&format!("{extra} = 1\n"));
        }
    }
    text
}

#[test]
fn the_shipped_badminton_scenario_plays() {
    let text = render(&[Edit::Keep], None);
    Config::from_toml_str(&text, "shipped").expect("the unedited text parses");
    badminton_checks::check(&text);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A few lines changed at a time, so that many cases parse and are played (a text with
    /// every line at risk would almost never pass validation).
    #[test]
    fn mutated_badminton_scenarios_play_or_are_refused_in_one_line(
        changes in prop::collection::vec((0usize..64, edit()), 0..3),
        extra in prop::option::weighted(0.1, "[a-z_]{1,8}"),
    ) {
        let mut edits = vec![Edit::Keep; 64];
        for (line, e) in changes {
            edits[line] = e;
        }
        badminton_checks::check(&render(&edits, extra.as_deref()));
    }
}
