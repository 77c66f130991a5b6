//! The shipped badminton scenario, mutated line by line (proptest).
//!
//! Each `key = value` line of `scenarios/badminton.toml` may be kept, dropped, duplicated, or
//! given another value (another number, a non-finite one, a value of another type), and an
//! unknown key may be added; the text goes through [`tests::badminton_checks::check`], the same
//! properties the `badminton` fuzz target checks: refused in one line, or a few points played.

use firmware_sim::badminton::Config;
use proptest::prelude::*;
use tests::badminton_checks;

use crate::line_edits::{self, Edit};

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

fn edit() -> impl Strategy<Value = Edit> {
    line_edits::edit(12, VALUES.len(), -10.0..100.0)
}

/// The shipped text with `edits` applied to its `key = value` lines (other lines kept).
fn render(edits: &[Edit], extra: Option<&str>) -> String {
    line_edits::apply(Config::BUILTIN, edits, VALUES, extra.map(|e| ("name", e)))
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
