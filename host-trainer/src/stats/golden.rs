//! The module against scipy: `tests/golden/stats_scipy.json`, written by
//! `tests/golden/stats_scipy.py` (scipy 1.14.1), asserted value by value.

use serde_json::Value;

use super::aggregate::{iqm, probability_of_improvement};
use super::binomial::{clopper_pearson, mcnemar_exact};
use super::bootstrap::bootstrap_percentile_ci;
use super::permutation::{permutation_two_sample, sign_flip_permutation};
use super::power::{
    pairs_for_mean_difference, power_paired, power_rate_difference, seeds_for_mean_difference,
    seeds_for_rate_difference,
};
use super::special::{incomplete_beta, normal_quantile};

const GOLDEN: &str = include_str!("../../tests/golden/stats_scipy.json");

fn golden(section: &str) -> Vec<Value> {
    let doc: Value = serde_json::from_str(GOLDEN).expect("the golden file is JSON");
    doc[section].as_array().expect("a golden section").clone()
}

fn num(v: &Value) -> f64 {
    v.as_f64().expect("a number")
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array().expect("an array").iter().map(num).collect()
}

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!((got - want).abs() <= tol, "{what}: got {got}, scipy {want}");
}

#[test]
fn clopper_pearson_matches_scipy() {
    for row in golden("clopper_pearson") {
        let (k, n) = (row["k"].as_u64().expect("k"), row["n"].as_u64().expect("n"));
        let (lo, hi) = clopper_pearson(k, n, num(&row["confidence"]));
        let want = nums(&row["interval"]);
        close(lo, want[0], 1e-10, &format!("lower {row}"));
        close(hi, want[1], 1e-10, &format!("upper {row}"));
    }
}

#[test]
fn the_incomplete_beta_matches_scipy() {
    for row in golden("incomplete_beta") {
        let got = incomplete_beta(num(&row["x"]), num(&row["a"]), num(&row["b"]));
        close(got, num(&row["value"]), 1e-11, &row.to_string());
    }
}

#[test]
fn mcnemar_matches_scipy_binomtest() {
    for row in golden("mcnemar") {
        let got = mcnemar_exact(row["b"].as_u64().expect("b"), row["c"].as_u64().expect("c"));
        close(got, num(&row["p"]), 1e-12, &row.to_string());
    }
}

#[test]
fn permutation_tests_match_scipy() {
    for row in golden("sign_flip") {
        let got = sign_flip_permutation(&nums(&row["diffs"]), 0, 0).p;
        close(got, num(&row["p"]), 1e-12, &row.to_string());
    }
    for row in golden("two_sample") {
        let got = permutation_two_sample(&nums(&row["a"]), &nums(&row["b"]), 0, 0).p;
        close(got, num(&row["p"]), 1e-12, &row.to_string());
    }
}

#[test]
fn iqm_and_probability_of_improvement_match_scipy() {
    for row in golden("iqm") {
        close(
            iqm(&nums(&row["x"])),
            num(&row["iqm"]),
            1e-12,
            &row.to_string(),
        );
    }
    for row in golden("probability_of_improvement") {
        let got = probability_of_improvement(&nums(&row["x"]), &nums(&row["y"]));
        close(got, num(&row["poi"]), 1e-12, &row.to_string());
    }
}

#[test]
fn the_bootstrap_lands_near_the_exact_bootstrap() {
    // Python listed all 7^7 resamples; 20,000 seeded ones land within 0.01 of its quantiles.
    let row = &golden_object("exact_bootstrap_mean");
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let ci = bootstrap_percentile_ci(&nums(&row["x"]), mean, 0.95, 20_000, 0);
    close(ci.lo, num(&row["lo"]), 0.01, "lower");
    close(ci.hi, num(&row["hi"]), 0.01, "upper");
}

fn golden_object(section: &str) -> Value {
    let doc: Value = serde_json::from_str(GOLDEN).expect("the golden file is JSON");
    doc[section].clone()
}

#[test]
fn normal_quantiles_and_power_match_scipy() {
    for row in golden("normal_quantile") {
        close(
            normal_quantile(num(&row["p"])),
            num(&row["z"]),
            1e-9,
            &row.to_string(),
        );
    }
    for row in golden("power_means") {
        let (effect, sd) = (num(&row["effect"]), num(&row["sd"]));
        let unpaired = seeds_for_mean_difference(effect, sd, 0.05, 0.8);
        assert_eq!(
            unpaired,
            Some((num(&row["unpaired"]).ceil() as u64).max(2)),
            "{row}"
        );
        let paired = pairs_for_mean_difference(effect, sd, 0.05, 0.8);
        assert_eq!(
            paired,
            Some((num(&row["paired"]).ceil() as u64).max(2)),
            "{row}"
        );
        let p5 = power_paired(effect, sd, 5, 0.05);
        close(p5, num(&row["power_paired_5"]), 1e-9, &row.to_string());
    }
    for row in golden("power_rates") {
        let (p1, p2) = (num(&row["p1"]), num(&row["p2"]));
        let n = seeds_for_rate_difference(p1, p2, 0.05, 0.8);
        assert_eq!(n, Some(num(&row["n"]).ceil() as u64), "{row}");
        close(
            power_rate_difference(p1, p2, 10, 0.05),
            num(&row["power_10"]),
            1e-9,
            "power",
        );
    }
}
