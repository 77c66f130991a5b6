//! Fault strings assembled from the `--faults` grammar, then mutated (proptest).
//!
//! `item = dropout-nan:P | dropout-stale:P | stuck:D@T | wall:T@X0/Y0/X1/Y1[@I]`, items joined by
//! commas. Numbers come from a pool of edge cases and random values; separators are sometimes
//! replaced, doubled or dropped. The text goes through [`tests::fault_checks::check`], the same
//! properties the `faults` fuzz target checks.

use firmware_sim::nav::faults::Faults;
use proptest::prelude::*;
use tests::fault_checks;

/// A number as text: well formed, at the edge of its type, or malformed.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (0u32..300).prop_map(|n| n.to_string()),
        4 => (-7.0f64..7.0).prop_map(|x| x.to_string()),
        1 => (0.0f64..=1.0).prop_map(|x| x.to_string()),
        1 => prop::sample::select(vec![
            "NaN", "inf", "-inf", "-0", "1e309", "4294967295", "4294967296",
            "18446744073709551616", "-1", "+2", "", " 3 ", "0x10", "1.5.2", "1e-320", "١",
        ])
        .prop_map(String::from),
    ]
}

/// A separator: the right one mostly, a wrong or doubled one sometimes.
fn separator(right: &'static str) -> impl Strategy<Value = String> {
    prop_oneof![
        8 => Just(right.to_string()),
        1 => prop::sample::select(vec![":", "@", "/", ",", ";", " ", "", "::", "@@"]).prop_map(String::from),
    ]
}

fn item() -> impl Strategy<Value = String> {
    prop_oneof![
        (
            prop::sample::select(vec!["dropout-nan", "dropout-stale", "dropout", "Stuck"]),
            separator(":"),
            number()
        )
            .prop_map(|(k, s, p)| format!("{k}{s}{p}")),
        (separator(":"), number(), separator("@"), number())
            .prop_map(|(s1, d, s2, t)| format!("stuck{s1}{d}{s2}{t}")),
        (
            separator(":"),
            number(),
            separator("@"),
            prop::collection::vec((number(), separator("/")), 4),
            prop::option::of((separator("@"), number())),
        )
            .prop_map(|(s1, t, s2, coords, replaces)| {
                let mut w = format!("wall{s1}{t}{s2}");
                for (i, (c, sep)) in coords.iter().enumerate() {
                    w.push_str(if i == 0 { "" } else { sep });
                    w.push_str(c);
                }
                if let Some((sep, i)) = replaces {
                    w.push_str(&format!("{sep}{i}"));
                }
                w
            }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn assembled_fault_strings_keep_the_parser_properties(
        items in prop::collection::vec((item(), separator(",")), 0..4),
    ) {
        let text: String = items.iter().map(|(i, s)| format!("{i}{s}")).collect();
        fault_checks::check(&text);
    }

    /// Well-formed items with in-range numbers always parse, and their canonical form names
    /// the same faults.
    #[test]
    fn well_formed_fault_strings_parse(
        p in 0.0f64..=1.0,
        dim in 0usize..2,
        tick in any::<u32>(),
        wall in [-3.0f64..3.0, -3.0f64..3.0, -3.0f64..3.0, -3.0f64..3.0],
        replaces in prop::option::of(0usize..13),
    ) {
        let [x0, y0, x1, y1] = wall;
        let mut text = format!("dropout-stale:{p} , stuck:{dim}@{tick},wall:{tick}@{x0}/{y0}/{x1}/{y1}");
        if let Some(i) = replaces {
            text.push_str(&format!("@{i}"));
        }
        let faults: Faults = text.parse().expect("well formed");
        prop_assert_eq!(faults.stuck.map(|s| (s.dim, s.from_tick)), Some((dim, tick)));
        prop_assert_eq!(faults.wall.map(|w| w.wall.to), Some([x1, y1]));
        fault_checks::check(&text);
    }
}

/// The examples of the `--faults` documentation hold all properties.
#[test]
fn documented_fault_strings_hold() {
    for text in [
        "",
        "dropout-nan:0.1,stuck:0@50,wall:20@-2/0/2/0",
        "dropout-stale:1",
        "wall:10@-1/-3/1/-3@8",
        "wall:10@0/0/0/9",
    ] {
        fault_checks::check(text);
    }
    assert_eq!(
        fault_checks::spec(&"stuck:1@2, dropout-nan:0.5".parse().expect("parses")),
        "dropout-nan:0.5,stuck:1@2"
    );
}
