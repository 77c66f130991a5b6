use crate::study;

const BIN: &str = env!("CARGO_BIN_EXE_margin-study");

fn stdout(args: &[&str]) -> String {
    let out = study(BIN, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {err}");
    String::from_utf8(out.stdout).expect("utf-8")
}

#[test]
fn the_screening_names_the_pages_winner() {
    let out = stdout(&["screen", "experiments/margin/record/screen.jsonl"]);
    assert!(
        out.contains(
            "Winner: uniform-share (16 failed seeds against A0's 17; mean settled error 0.925 against 0.966)."
        ),
        "{out}"
    );
    // The share of failed seeds with its exact interval: 17 of 26.
    assert!(
        out.contains("| A0 | 26 of 26 | 17 (0.65 [0.44, 0.83]) |"),
        "{out}"
    );
}

#[test]
fn the_confirmation_keeps_the_rules_verdict_and_adds_the_exact_tests() {
    let out = stdout(&[
        "confirm",
        "experiments/margin/record/confirm.jsonl",
        "--winner",
        "uniform-share",
    ]);
    // The pre-registered rule: a t interval of the paired differences, unchanged.
    assert!(
        out.contains(
            "Paired uniform-share − A0 over 26 pairs: failed seed -0.077 ± 0.110, settled error -0.048 ± 0.269."
        ),
        "{out}"
    );
    assert!(
        out.contains("Not adopted: neither paired interval lies below 0"),
        "{out}"
    );
    assert!(out.contains("failed seed, McNemar p = "), "{out}");
    assert!(
        out.contains("Goal, stuck at the margin: 0.390 against DDPG's 0.525: below."),
        "{out}"
    );
}

#[test]
fn a_record_without_the_reference_arm_is_refused() {
    let out = study(BIN, &["screen", "no/such/record.jsonl"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("margin-study: "), "{err}");
}
