//! How fragile a verdict is: the fewest runs whose change flips it.
//!
//! **Definition.** Given the runs a verdict reads (their values, in a fixed order), a verdict
//! function of those values, and for each run a list of values it could have taken instead
//! (its *alternatives*), the sensitivity is the smallest `k` such that some `k` runs, each set
//! to one of its alternatives (the others unchanged), give a different verdict; with it, the
//! number of distinct sets of `k` runs that can do so. The alternatives name what "a change"
//! means and the page says which it used: for a pass/fail outcome, the other outcome; for a
//! value compared between two groups, the other group's lowest and highest value (a run that
//! came out like the other group's worst or best run).
//!
//! A verdict no change of up to `max_runs` runs can flip says so (`runs: None`): with five
//! pairs, for instance, no permutation test reaches p < 0.05, whatever the runs.

use super::permutation::next_combination as next_subset;

/// The fewest runs whose change flips a verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sensitivity {
    /// The fewest runs that flip it; `None` if no change of up to `searched` runs does.
    pub runs: Option<usize>,
    /// How many sets of that many runs flip it (0 with `runs: None`).
    pub sets: usize,
    /// Runs the verdict reads.
    pub of: usize,
    /// The largest set size tried.
    pub searched: usize,
}

impl std::fmt::Display for Sensitivity {
    /// `one run flips it (14 of the 20 can)`, `2 runs flip it (15 sets of 2 of the 20 can)`,
    /// `3 runs flip it (one set of 3 of the 20 can)`,
    /// or `no change of up to 3 of the 20 runs flips it`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (sets, of, searched) = (self.sets, self.of, self.searched);
        match self.runs {
            None => write!(f, "no change of up to {searched} of the {of} runs flips it"),
            Some(1) => write!(f, "one run flips it ({sets} of the {of} can)"),
            Some(k) if sets == 1 => write!(f, "{k} runs flip it (one set of {k} of the {of} can)"),
            Some(k) => write!(f, "{k} runs flip it ({sets} sets of {k} of the {of} can)"),
        }
    }
}

/// The fewest runs whose change flips `verdict(values)`; see the module docs. Tries every set
/// of 1, then 2, ... up to `max_runs` runs, and every combination of their alternatives.
///
/// ```
/// use host_trainer::stats::sensitivity::sensitivity;
/// // Verdict: "more than half passed" over 5 pass/fail runs, 4 passed.
/// let runs = [1.0, 1.0, 0.0, 1.0, 1.0];
/// let verdict = |v: &[f64]| v.iter().sum::<f64>() > 2.5;
/// let flip = |_: usize, v: f64| vec![1.0 - v];
/// let s = sensitivity(&runs, flip, verdict, 3);
/// assert_eq!((s.runs, s.sets), (Some(2), 6)); // any 2 of the 4 passes
/// assert_eq!(s.to_string(), "2 runs flip it (6 sets of 2 of the 5 can)");
/// ```
pub fn sensitivity<V: PartialEq>(
    values: &[f64],
    alternatives: impl Fn(usize, f64) -> Vec<f64>,
    verdict: impl Fn(&[f64]) -> V,
    max_runs: usize,
) -> Sensitivity {
    let base = verdict(values);
    let options: Vec<Vec<f64>> = values
        .iter()
        .enumerate()
        .map(|(i, &v)| alternatives(i, v))
        .collect();
    let n = values.len();
    let searched = max_runs.min(n);
    let mut changed = values.to_vec();
    for k in 1..=searched {
        let mut picked: Vec<usize> = (0..k).collect();
        let mut sets = 0;
        loop {
            if flips(&picked, &options, &mut changed, &|v| verdict(v) != base) {
                sets += 1;
            }
            if !next_subset(&mut picked, n) {
                break;
            }
        }
        if sets > 0 {
            return Sensitivity {
                runs: Some(k),
                sets,
                of: n,
                searched,
            };
        }
    }
    Sensitivity {
        runs: None,
        sets: 0,
        of: n,
        searched,
    }
}

/// Whether some choice of alternatives for the `picked` runs makes `differs` true; `changed`
/// holds the values and is restored before returning.
fn flips(
    picked: &[usize],
    options: &[Vec<f64>],
    changed: &mut [f64],
    differs: &dyn Fn(&[f64]) -> bool,
) -> bool {
    let Some((&run, rest)) = picked.split_first() else {
        return differs(changed);
    };
    let original = changed[run];
    let found = options[run].iter().any(|&alt| {
        changed[run] = alt;
        flips(rest, options, changed, differs)
    });
    changed[run] = original;
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_verdict_nothing_can_flip_says_so() {
        let s = sensitivity(&[0.5; 4], |_, v| vec![v], |_: &[f64]| true, 2);
        assert_eq!(s.runs, None);
        assert_eq!(s.to_string(), "no change of up to 2 of the 4 runs flips it");
    }
}
