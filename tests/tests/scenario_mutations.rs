//! Scenario TOML assembled from valid fragments, then mutated (proptest).
//!
//! A case is a list of `key = value` lines in four sections (top level, `[start]`, `[metrics]`,
//! `[pass]`) plus `[[walls]]` entries. Each line may be kept, dropped, duplicated, or given
//! another value (another number, a non-finite one, a value of another type), and unknown keys
//! may be added; the text goes through [`tests::scenario_checks::check`], the same properties the
//! `scenario` fuzz target checks.

use firmware_sim::nav::scenario::Scenario;
use proptest::prelude::*;
use tests::scenario_checks;

use crate::line_edits::{self, float, line, Edit};

/// A valid scenario as (section, key, value) lines; section "" is the top level.
const FRAGMENTS: &[(&str, &str, &str)] = &[
    ("", "name", "\"fuzz\""),
    ("", "description", "\"generated\""),
    ("", "arena_half_size", "6.0"),
    ("", "max_step", "0.25"),
    ("", "reward", "\"lr\""),
    ("", "gamma", "0.99"),
    ("", "time_limit", "200"),
    ("", "goal_radius", "0.1"),
    ("", "goal_hold", "10"),
    ("start", "rule", "\"boundary\""),
    ("start", "inset", "0.25"),
    ("metrics", "settle_window", "20"),
    ("metrics", "success_radius", "2.0"),
    ("metrics", "near_radius", "0.25"),
    ("metrics", "stuck_window", "20"),
    ("metrics", "stuck_min_command", "0.5"),
    ("metrics", "stuck_max_progress", "0.05"),
    ("pass", "min_success_rate", "0.8"),
    ("pass", "max_stuck_rate", "0.2"),
];

/// Values of every TOML type, at the edges of the scenario's rules and of f32/u32.
const VALUES: &[&str] = &[
    "0",
    "-1",
    "1",
    "0.0",
    "-0.0",
    "1e-7",
    "0.9999999",
    "1.0",
    "5.9",
    "6.0",
    "1e38",
    "1e39",
    "1e308",
    "nan",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "-5",
    "\"lr-gr\"",
    "\"gr\"",
    "\"points\"",
    "\"\"",
    "\"two\\nlines\"",
    "true",
    "[]",
    "[[1.0, 2.0]]",
    "[1.0, 2.0]",
    "{}",
    "1979-05-27",
    "'x'",
];

fn edit() -> impl Strategy<Value = Edit> {
    line_edits::edit(8, VALUES.len(), -10.0..10.0)
}

/// A coordinate: mostly inside the arena, sometimes out of it or not finite.
fn coordinate() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -6.0f64..6.0,
        1 => Just(f64::NAN),
        1 => prop_oneof![Just(6.0f64), Just(-6.0), Just(7.0), Just(1e300)],
    ]
}

/// `[[walls]]` entries, or `points` of a start rule.
fn points(max: usize) -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec([coordinate(), coordinate()], 0..max)
}

/// Renders the edited fragments, the start points, the walls and the extra keys.
fn render(
    edits: &[Edit],
    start_points: &Option<Vec<[f64; 2]>>,
    walls: &[[f64; 2]],
    extra: &[String],
) -> String {
    let mut text = String::new();
    for section in ["", "start", "metrics", "pass"] {
        if !section.is_empty() {
            text.push_str(&format!("[{section}]\n"));
        }
        for ((_, key, value), e) in FRAGMENTS
            .iter()
            .zip(edits)
            .filter(|((s, ..), _)| *s == section)
        {
            if section == "start" && start_points.is_some() {
                continue;
            }
            text.push_str(&line(key, value, e, VALUES));
        }
        if let (true, Some(p)) = (section == "start", start_points) {
            let p: Vec<String> = p
                .iter()
                .map(|[x, y]| format!("[{}, {}]", float(*x), float(*y)))
                .collect();
            text.push_str(&format!("rule = \"points\"\npoints = [{}]\n", p.join(", ")));
        }
        if let Some(key) = extra.get(
            ["", "start", "metrics", "pass"]
                .iter()
                .position(|s| *s == section)
                .unwrap_or(0),
        ) {
            text.push_str(&format!("{key} = 1\n"));
        }
    }
    for pair in walls.chunks_exact(2) {
        let ([x0, y0], [x1, y1]) = (pair[0], pair[1]);
        text.push_str(&format!(
            "[[walls]]\nfrom = [{}, {}]\nto = [{}, {}]\n",
            float(x0),
            float(y0),
            float(x1),
            float(y1)
        ));
    }
    text
}

/// Extra keys per section: none mostly, a misspelt one sometimes.
fn extra_keys() -> impl Strategy<Value = Vec<String>> {
    prop::collection::vec(
        prop_oneof!["time_limt", "walls_", "gama", "[a-z_]{1,8}"],
        0..2,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn mutated_scenarios_keep_the_parser_properties(
        edits in prop::collection::vec(edit(), FRAGMENTS.len()),
        start_points in prop::option::weighted(0.3, points(4)),
        walls in points(8),
        extra in extra_keys(),
    ) {
        scenario_checks::check(&render(&edits, &start_points, &walls, &extra));
    }

    /// Only numbers change, by a factor, keeping their types: many cases parse, so the
    /// accepted-scenario properties (validate, TOML round trip, a finite plant) are exercised,
    /// not just the errors.
    #[test]
    fn rescaled_scenarios_keep_the_parser_properties(
        factors in prop::collection::vec(prop::option::weighted(0.3, 0.0f64..3.0), FRAGMENTS.len()),
        start_points in prop::option::weighted(0.3, prop::collection::vec([-6.0f64..6.0, -6.0f64..6.0], 1..4)),
        walls in prop::collection::vec([-6.0f64..6.0, -6.0f64..6.0], 0..8),
    ) {
        let edits: Vec<Edit> = factors.iter().map(|f| f.map_or(Edit::Keep, Edit::Scale)).collect();
        scenario_checks::check(&render(&edits, &start_points, &walls, &[]));
    }
}

/// The fragments alone are the valid scenario the mutations start from.
#[test]
fn unedited_fragments_are_a_valid_scenario() {
    let text = render(
        &vec![Edit::Keep; FRAGMENTS.len()],
        &None,
        &[[-2.0, 1.0], [2.0, 1.0]],
        &[],
    );
    let s = Scenario::from_toml_str(&text).expect("the fragments parse");
    assert_eq!((s.name.as_str(), s.walls.len()), ("fuzz", 1));
    scenario_checks::check_accepted(&s);
    for builtin in ["nav-walls", "nav-open"] {
        scenario_checks::check_accepted(&Scenario::builtin(builtin).expect("built in"));
    }
}

/// Every fragment given every value of [`VALUES`], one at a time, the rest kept valid: the
/// edge values reach validation alone, which random edits of several lines rarely do.
#[test]
fn each_value_in_each_field_keeps_the_parser_properties() {
    for field in 0..FRAGMENTS.len() {
        for v in 0..VALUES.len() {
            let mut edits = vec![Edit::Keep; FRAGMENTS.len()];
            edits[field] = Edit::Value(v);
            scenario_checks::check(&render(&edits, &None, &[], &[]));
        }
    }
}
