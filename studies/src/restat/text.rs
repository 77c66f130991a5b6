//! The phrases every rebuilt section uses: a cell's mean with its bootstrap interval, a count of
//! runs with its exact interval, a paired comparison with its sign-flip test, a verdict's
//! sensitivity and power, and a Markdown table.

use host_trainer::reproduce::verdict::{permutation_side, t_side, Side, Word};
use host_trainer::stats::binomial::clopper_pearson;
use host_trainer::stats::bootstrap::mean_text;
use host_trainer::stats::permutation::{sign_flip_permutation, PValue};
use host_trainer::stats::power::{
    pairs_for_mean_difference, power_paired, power_rate_difference, seeds_for_rate_difference,
};
use host_trainer::stats::sensitivity::{sensitivity, Sensitivity};
use host_trainer::stats::student_t::{clipped_text, Range};
use host_trainer::stats::{ALPHA, CONFIDENCE, POWER, REPS, SEED};

/// The largest number of runs a sensitivity search changes at once.
pub const SENSITIVITY_RUNS: usize = 3;

/// A cell's mean over its seeds with the 95 % percentile bootstrap interval, `(all n equal)`
/// without spread.
///
/// ```
/// use studies::restat::text::mean_cell;
/// assert_eq!(mean_cell(&[1.0; 5], 2), "1.00 (all 5 equal)");
/// ```
pub fn mean_cell(values: &[f64], decimals: usize) -> String {
    mean_text(values, decimals)
}

/// `k of n [lo, hi]`: a count of runs and the exact (Clopper–Pearson) 95 % interval of its rate.
///
/// ```
/// use studies::restat::text::count_cell;
/// assert_eq!(count_cell(0, 5), "0 of 5 [0.00, 0.52]");
/// assert_eq!(count_cell(2, 5), "2 of 5 [0.05, 0.85]");
/// ```
pub fn count_cell(k: usize, n: usize) -> String {
    let (lo, hi) = clopper_pearson(k as u64, n as u64, CONFIDENCE);
    format!("{k} of {n} [{lo:.2}, {hi:.2}]")
}

/// The two-sided sign-flip permutation p of paired differences (exact up to 20 pairs).
pub fn sign_flip(diffs: &[f64]) -> PValue {
    sign_flip_permutation(diffs, REPS as u64, SEED)
}

/// `mean [lo, hi], p P`: paired differences with the bootstrap interval of their mean and the
/// sign-flip p.
///
/// ```
/// use studies::restat::text::paired_cell;
/// assert_eq!(paired_cell(&[0.0; 5], 2), "0.00 (all 5 equal), p 1.000");
/// ```
pub fn paired_cell(diffs: &[f64], decimals: usize) -> String {
    if diffs.is_empty() {
        return "–".into();
    }
    format!(
        "{}, p {:.3}",
        mean_text(diffs, decimals),
        sign_flip(diffs).p
    )
}

/// The mean of `values` (0 for none).
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// The sample standard deviation of `values` (n − 1; 0 below two values).
pub fn sd(values: &[f64]) -> f64 {
    if values.len() < 2 {
        return 0.0;
    }
    let m = mean(values);
    (values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (values.len() - 1) as f64).sqrt()
}

/// `a[i] − b[i]`.
pub fn diff(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// Where the smallest p `n` pairs can give is not below α, a note saying so.
///
/// ```
/// use studies::restat::text::floor_note;
/// assert_eq!(floor_note(5).unwrap(), "5 pairs cannot give p < 0.05: the smallest p is 2/32 = 0.0625");
/// assert_eq!(floor_note(6), None);
/// ```
pub fn floor_note(n: usize) -> Option<String> {
    let patterns = 1u64 << n.min(62);
    let smallest = 2.0 / patterns as f64;
    (smallest >= ALPHA).then(|| {
        format!("{n} pairs cannot give p < {ALPHA}: the smallest p is 2/{patterns} = {smallest}")
    })
}

/// The observed mean and spread of `diffs`, or why there is no power figure: no mean (0, up to
/// the rounding of a sum of values printed to a few digits) or no spread.
fn effect(diffs: &[f64]) -> Result<(f64, f64), &'static str> {
    let (m, s) = (mean(diffs), sd(diffs));
    let scale = diffs.iter().fold(0.0f64, |a, d| a.max(d.abs()));
    if m.abs() <= 1e-9 * scale.max(1.0) {
        Err("observed mean 0")
    } else if s == 0.0 {
        Err("observed spread 0")
    } else {
        Ok((m, s))
    }
}

/// The pairs power 0.8 needs, as text: `18`, `over a million`, `–`.
fn needed_text(m: f64, s: f64) -> String {
    match pairs_for_mean_difference(m, s, ALPHA, POWER) {
        Some(k) if k > 1_000_000 => "over a million".into(),
        Some(k) => k.to_string(),
        None => "–".into(),
    }
}

/// The power a paired comparison of `diffs` had at its n for the observed mean and spread, and
/// the pairs power 0.8 needs: `power 0.32 at 5 pairs for the observed −0.20 (sd 0.29); 0.8
/// needs 18 pairs`. Where the normal approximation asks for fewer than 6 pairs, it adds that
/// the exact test needs 6.
pub fn power_text(diffs: &[f64], decimals: usize) -> String {
    let n = diffs.len();
    let (m, s) = match effect(diffs) {
        Ok(e) => e,
        Err(why) => return format!("no power figure ({why})"),
    };
    let power = power_paired(m, s, n as u64, ALPHA);
    let floor = match pairs_for_mean_difference(m, s, ALPHA, POWER) {
        Some(k) if k < 6 => " (the sign-flip test needs at least 6 to reach p < 0.05)",
        _ => "",
    };
    format!(
        "power {power:.2} at {n} pairs for the observed {m:+.decimals$} (sd {s:.decimals$}); \
         {POWER} needs {} pairs{floor}",
        needed_text(m, s)
    )
}

/// The power a comparison of two rates of runs (`k1` of `n`, `k2` of `n`) had, and the runs per
/// arm 0.8 needs (Fleiss's normal approximation).
pub fn rate_power_text(k1: usize, k2: usize, n: usize) -> String {
    let (p1, p2) = (k1 as f64 / n as f64, k2 as f64 / n as f64);
    if p1 == p2 {
        return "no power figure (observed rates equal)".into();
    }
    let power = power_rate_difference(p1, p2, n as u64, ALPHA);
    let needed =
        seeds_for_rate_difference(p1, p2, ALPHA, POWER).map_or("–".into(), |k| k.to_string());
    format!(
        "power {power:.2} at {n} runs per arm for the observed {p1:.2} against {p2:.2}; {POWER} \
         needs {needed} per arm"
    )
}

/// A verdict and its sensitivity.
#[derive(Debug)]
pub struct Judged<V> {
    /// The verdict on the runs as they came out.
    pub word: V,
    /// The fewest runs whose change flips it.
    pub sensitivity: Sensitivity,
}

/// `rule(runs)` and its sensitivity, each run's alternatives the values it could have taken
/// instead, up to [`SENSITIVITY_RUNS`] runs at once.
pub fn judge<V: PartialEq>(
    runs: &[f64],
    alternatives: &[Vec<f64>],
    rule: impl Fn(&[f64]) -> V,
) -> Judged<V> {
    judge_within(runs, alternatives, rule, SENSITIVITY_RUNS)
}

/// [`judge`] with the sensitivity searched up to `max_runs` runs at once.
pub fn judge_within<V: PartialEq>(
    runs: &[f64],
    alternatives: &[Vec<f64>],
    rule: impl Fn(&[f64]) -> V,
    max_runs: usize,
) -> Judged<V> {
    Judged {
        word: rule(runs),
        sensitivity: sensitivity(runs, |i, _| alternatives[i].clone(), &rule, max_runs),
    }
}

/// For runs in arms of `len` values, each run's alternatives: the lowest and highest value of
/// the arm `partner(arm)` (a run that came out like the other arm's worst or best run).
pub fn partner_extremes(
    runs: &[f64],
    len: usize,
    partner: impl Fn(usize) -> usize,
) -> Vec<Vec<f64>> {
    (0..runs.len())
        .map(|i| {
            let other = &runs[partner(i / len) * len..][..len];
            let lo = other.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = other.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            vec![lo, hi]
        })
        .collect()
}

/// The side of 0 a comparison lies on, as a page says it.
pub fn side_text(side: Side) -> &'static str {
    match side {
        Side::Above => "above 0",
        Side::Below => "below 0",
        Side::Spans => "not resolved",
    }
}

/// A Markdown table: the header, right-aligned columns after the first `left` ones, the rows.
///
/// ```
/// use studies::restat::text::table;
/// let t = table(&["a", "b"], 1, &[vec!["x".into(), "1".into()]]);
/// assert_eq!(t, "| a | b |\n|---|---:|\n| x | 1 |\n");
/// ```
pub fn table(headers: &[&str], left: usize, rows: &[Vec<String>]) -> String {
    let mut out = format!("| {} |\n|", headers.join(" | "));
    for i in 0..headers.len() {
        out.push_str(if i < left { "---|" } else { "---:|" });
    }
    out.push('\n');
    for row in rows {
        out.push_str(&format!("| {} |\n", row.join(" | ")));
    }
    out
}

/// A claim's word from the side of 0 its differences lie on: reproduced on the `expected` side,
/// contradicted on the other, not reproduced where neither.
pub fn claim(expected: Side) -> impl Fn(Side) -> Word + Copy {
    move |side| {
        let opposite = match expected {
            Side::Above => Side::Below,
            Side::Below => Side::Above,
            Side::Spans => Side::Spans,
        };
        Word::of(side == expected, side != Side::Spans && side == opposite)
    }
}

/// Two arms paired by seed, judged by the 95 % t interval of their differences (the rule the
/// older pages read) and by the sign-flip test, each with its sensitivity.
#[derive(Debug)]
pub struct Paired<W> {
    /// `first − second`, by seed.
    pub diffs: Vec<f64>,
    /// The verdict by the t interval of the differences.
    pub t: Judged<W>,
    /// The verdict by the sign-flip test at α.
    pub exact: Judged<W>,
}

/// `first` against `second`, paired by position (seed), each verdict `word` of the side of 0;
/// a run's alternatives are the lowest and highest value of the other arm.
pub fn paired<W: PartialEq>(
    first: &[f64],
    second: &[f64],
    word: impl Fn(Side) -> W + Copy,
) -> Paired<W> {
    paired_within(first, second, word, SENSITIVITY_RUNS)
}

/// [`paired`] with the sensitivity searched up to `max_runs` runs at once: past 20 pairs the
/// sign-flip test draws its patterns, and a search over every set of three of 52 runs would
/// redraw them about 180,000 times.
pub fn paired_within<W: PartialEq>(
    first: &[f64],
    second: &[f64],
    word: impl Fn(Side) -> W + Copy,
    max_runs: usize,
) -> Paired<W> {
    let n = first.len();
    let runs: Vec<f64> = first.iter().chain(second).copied().collect();
    let alts = partner_extremes(&runs, n, |arm| 1 - arm);
    let split = move |r: &[f64]| diff(&r[..n], &r[n..]);
    Paired {
        diffs: diff(first, second),
        t: judge_within(&runs, &alts, |r| word(t_side(&split(r))), max_runs),
        exact: judge_within(
            &runs,
            &alts,
            |r| word(permutation_side(&split(r), ALPHA)),
            max_runs,
        ),
    }
}

/// The t interval of paired differences as a rule reads it, clipped to their `range`, or
/// `(all n equal)`.
pub fn t_cell(diffs: &[f64], decimals: usize, range: Range) -> String {
    clipped_text(diffs, decimals, range)
}

/// The t half of a paired verdict: `t interval of the paired differences −0.02 [−0.27, 0.23]:
/// **not reproduced**; 3 runs flip it (...)`.
pub fn t_sentence<W>(
    p: &Paired<W>,
    decimals: usize,
    range: Range,
    word: impl Fn(&W) -> String,
) -> String {
    format!(
        "the 95 % t interval of the paired differences, {}: **{}**; {}",
        t_cell(&p.diffs, decimals, range),
        word(&p.t.word),
        p.t.sensitivity
    )
}

/// The exact half of a paired verdict: the sign-flip test, its verdict and sensitivity, the
/// floor of few pairs where it binds, and the power.
pub fn exact_sentence<W>(p: &Paired<W>, decimals: usize, word: impl Fn(&W) -> String) -> String {
    let floor = floor_note(p.diffs.len()).map_or(String::new(), |n| format!("; {n}"));
    format!(
        "Exact: the sign-flip test of the {} paired differences, mean {:+.decimals$}, {}: **{}**; \
         {}{floor}. Power: {}.",
        p.diffs.len(),
        mean(&p.diffs),
        sign_flip(&p.diffs),
        word(&p.exact.word),
        p.exact.sensitivity,
        power_text(&p.diffs, decimals).trim_start_matches("power "),
    )
}

/// A claim's word as the page prints it.
pub fn word_text(w: &Word) -> String {
    w.text().to_string()
}

/// A side of 0 as the page prints it, `first` and `second` naming the arms.
pub fn differ_text(first: &'static str, second: &'static str) -> impl Fn(&Side) -> String {
    move |side| match side {
        Side::Above => format!("{first} higher"),
        Side::Below => format!("{first} lower"),
        Side::Spans => format!("no difference shown between {first} and {second}"),
    }
}

/// `n` with a comma every three digits, as the pages write counts.
///
/// ```
/// use studies::restat::text::thousands;
/// assert_eq!(thousands(10_000), "10,000");
/// assert_eq!(thousands(999), "999");
/// ```
pub fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// A sensitivity as a table cell: `1 run (3 of 10)`, `2 runs (9 sets)`, `none up to 3 of 10`.
///
/// ```
/// use host_trainer::stats::sensitivity::Sensitivity;
/// use studies::restat::text::sensitivity_cell;
/// let s = Sensitivity { runs: Some(2), sets: 9, of: 10, searched: 3 };
/// assert_eq!(sensitivity_cell(&s), "2 runs (9 sets)");
/// let s = Sensitivity { runs: None, sets: 0, of: 10, searched: 3 };
/// assert_eq!(sensitivity_cell(&s), "none up to 3 of 10");
/// ```
pub fn sensitivity_cell(s: &Sensitivity) -> String {
    match s.runs {
        None => format!("none up to {} of {}", s.searched, s.of),
        Some(1) => format!("1 run ({} of {})", s.sets, s.of),
        Some(k) if s.sets == 1 => format!("{k} runs (one set)"),
        Some(k) => format!("{k} runs ({} sets)", s.sets),
    }
}

/// One row of a table of paired comparisons: its label, the comparison, and how to print its
/// differences.
pub struct PairedRow {
    /// What is compared, `first − second`.
    pub label: String,
    /// The comparison, judged by side of 0.
    pub paired: Paired<Side>,
    /// Digits of the differences.
    pub decimals: usize,
    /// The range of a difference, for the t interval's clipping.
    pub range: Range,
}

impl PairedRow {
    /// `first` against `second`, paired by seed.
    pub fn new(
        label: String,
        first: &[f64],
        second: &[f64],
        decimals: usize,
        range: Range,
    ) -> Self {
        PairedRow::within(label, first, second, decimals, range, SENSITIVITY_RUNS)
    }

    /// [`PairedRow::new`] with the sensitivity searched up to `max_runs` runs at once.
    pub fn within(
        label: String,
        first: &[f64],
        second: &[f64],
        decimals: usize,
        range: Range,
        max_runs: usize,
    ) -> Self {
        PairedRow {
            label,
            paired: paired_within(first, second, |s| s, max_runs),
            decimals,
            range,
        }
    }
}

/// A table of paired comparisons, each read by the t interval of its differences (`t_label`
/// names whose reading that is) and by the sign-flip test, each with its sensitivity, and
/// its power.
pub fn paired_table(t_label: &str, rows: &[PairedRow]) -> String {
    let cells: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            let p = &r.paired;
            vec![
                r.label.clone(),
                mean_cell(&p.diffs, r.decimals),
                t_cell(&p.diffs, r.decimals, r.range),
                side_text(p.t.word).into(),
                sensitivity_cell(&p.t.sensitivity),
                format!("{:.4}", sign_flip(&p.diffs).p),
                side_text(p.exact.word).into(),
                sensitivity_cell(&p.exact.sensitivity),
                power_cell(&p.diffs),
            ]
        })
        .collect();
    let t_verdict = format!("{t_label}: t interval off 0?");
    table(
        &[
            "comparison",
            "mean difference (bootstrap)",
            "95 % t interval",
            &t_verdict,
            "sensitivity",
            "sign-flip p",
            "exact: p < 0.05?",
            "sensitivity",
            "power; pairs for 0.8",
        ],
        1,
        &cells,
    ) + "\nPower: at the comparison's own pairs, for the observed mean difference and spread; \
         the pairs power 0.8 needs by the normal approximation, a floor (the sign-flip test \
         cannot reach p < 0.05 below 6 pairs, whatever the effect).\n"
}

/// The power of a paired comparison and the pairs 0.8 needs, as a table cell: `0.32; 18`.
pub fn power_cell(diffs: &[f64]) -> String {
    match effect(diffs) {
        Ok((m, s)) => format!(
            "{:.2}; {}",
            power_paired(m, s, diffs.len() as u64, ALPHA),
            needed_text(m, s)
        ),
        Err(_) => "–".into(),
    }
}
