#!/usr/bin/env python3
"""Writes stats_scipy.json: host_trainer::stats's quantities as scipy computes them.

An outside computation for the statistics module's unit tests (src/stats/golden.rs), which
assert the Rust values against this file; CI reads the committed JSON and needs no scipy.
Rerun it after changing what the tests check:

    pip install scipy==1.14.1 numpy==2.2.6
    python3 host-trainer/tests/golden/stats_scipy.py > host-trainer/tests/golden/stats_scipy.json
"""

import itertools
import json
import math
import sys

import numpy as np
import scipy
from scipy import special, stats


def clopper_pearson(k, n, conf):
    a = 1 - conf
    lo = 0.0 if k == 0 else stats.beta.ppf(a / 2, k, n - k + 1)
    hi = 1.0 if k == n else stats.beta.ppf(1 - a / 2, k + 1, n - k)
    return float(lo), float(hi)


def sign_flip_p(d):
    # Every sign pattern (n_resamples=inf): p = share of |mean| at least the observed.
    res = stats.permutation_test(
        (np.array(d),),
        lambda x, axis: np.abs(np.mean(x, axis=axis)),
        permutation_type="samples",
        alternative="greater",
        n_resamples=np.inf,
        vectorized=True,
    )
    return float(res.pvalue)


def two_sample_p(a, b):
    res = stats.permutation_test(
        (np.array(a), np.array(b)),
        lambda x, y, axis: np.abs(np.mean(x, axis=axis) - np.mean(y, axis=axis)),
        permutation_type="independent",
        alternative="greater",
        n_resamples=np.inf,
        vectorized=True,
    )
    return float(res.pvalue)


def exact_bootstrap_quantiles(xs, conf):
    """The percentile interval of the mean over every one of the n^n resamples."""
    means = sorted(np.mean(r) for r in itertools.product(xs, repeat=len(xs)))
    a = 1 - conf
    return float(np.quantile(means, a / 2)), float(np.quantile(means, 1 - a / 2))


def power_rows():
    za = stats.norm.ppf(0.975)
    zb = stats.norm.ppf(0.8)
    rows = []
    for effect, sd in [(1.0, 1.0), (0.2, 0.36), (0.53, 0.44), (0.05, 0.3)]:
        n_unpaired = 2 * ((za + zb) * sd / effect) ** 2
        n_paired = ((za + zb) * sd / effect) ** 2
        rows.append({"effect": effect, "sd": sd, "unpaired": n_unpaired, "paired": n_paired,
                     "power_paired_5": float(stats.norm.cdf(effect * math.sqrt(5) / sd - za))})
    rates = []
    for p1, p2 in [(0.5, 0.1), (0.8, 0.2), (0.3, 0.1)]:
        pbar = (p1 + p2) / 2
        s0 = math.sqrt(2 * pbar * (1 - pbar))
        s1 = math.sqrt(p1 * (1 - p1) + p2 * (1 - p2))
        n = (za * s0 + zb * s1) ** 2 / (p1 - p2) ** 2
        power10 = stats.norm.cdf((abs(p1 - p2) * math.sqrt(10) - za * s0) / s1)
        rates.append({"p1": p1, "p2": p2, "n": n, "power_10": float(power10)})
    return rows, rates


def main():
    cp = [
        {"k": k, "n": n, "confidence": c, "interval": clopper_pearson(k, n, c)}
        for n in [1, 2, 5, 10, 20, 37, 100, 500]
        for k in sorted({0, 1, n // 3, n // 2, n - 1, n})
        for c in [0.9, 0.95, 0.99]
    ]
    betainc = [
        {"x": x, "a": a, "b": b, "value": float(special.betainc(a, b, x))}
        for x in [0.001, 0.05, 0.3, 0.5, 0.77, 0.999]
        for a, b in [(0.5, 0.5), (1, 5), (2.5, 4), (10, 3), (40, 60), (200, 1)]
    ]
    mcnemar = [
        {"b": b, "c": c, "p": float(stats.binomtest(b, b + c, 0.5).pvalue)}
        for b, c in [(4, 0), (0, 4), (1, 6), (7, 3), (10, 2), (5, 5), (0, 12), (25, 11)]
    ]
    diffs = [
        [0.1, 0.2, 0.3, 0.4, 0.5],
        # Experiment 1: the paper's DCP minus DDPG, success paired by seed (4x48, pinwheel).
        [0.17, -0.30, -0.26, -0.59, 0.0],
        [-0.98, -0.02, -0.37, -0.31, -0.99],
        [0.4, -0.1, 0.25, 0.3, 0.05, 0.6, -0.2, 0.15, 0.35, 0.1, 0.0, 0.45],
        [1, 0, 1, 1, 0, 1, 1, 0, -1, 0],
    ]
    sign_flip = [{"diffs": d, "p": sign_flip_p(d)} for d in diffs]
    groups = [
        ([10.0, 11.0], [1.0, 2.0, 3.0]),
        ([0.83, 0.42, 1.0, 1.0, 1.0], [1.0, 0.12, 0.74, 0.41, 1.0]),
        ([0.2, 0.5, 0.9, 0.4, 0.7, 0.3], [0.1, 0.15, 0.6, 0.2, 0.05, 0.25, 0.3]),
    ]
    two_sample = [{"a": a, "b": b, "p": two_sample_p(a, b)} for a, b in groups]
    samples = [
        [1.0, 2.0, 3.0, 4.0],
        [0.0, 0.0, 1.0, 1.0, 1.0],
        [100.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0],
        [0.98, 0.88, 1.0, 1.0, 0.91, 0.21, 0.9, 0.04, 0.91, 0.83, 0.5],
        list(np.round(np.linspace(-3, 7, 23) ** 2 % 5, 3)),
    ]
    iqm = [{"x": x, "iqm": float(stats.trim_mean(x, 0.25))} for x in samples]
    poi = []
    for x, y in [(samples[3], samples[1]), (samples[0], samples[2]), (samples[4], samples[3])]:
        u = stats.mannwhitneyu(x, y).statistic
        poi.append({"x": x, "y": y, "poi": float(u / (len(x) * len(y)))})
    boot_x = [0.2, 0.4, 0.5, 0.7, 0.9, 1.0, 0.3]
    lo, hi = exact_bootstrap_quantiles(boot_x, 0.95)
    normal = [{"p": p, "z": float(stats.norm.ppf(p))} for p in [0.5, 0.8, 0.9, 0.975, 0.995, 1e-6]]
    means, rates = power_rows()
    out = {
        "produced_by": f"tests/golden/stats_scipy.py, scipy {scipy.__version__}, numpy {np.__version__}",
        "clopper_pearson": cp,
        "incomplete_beta": betainc,
        "mcnemar": mcnemar,
        "sign_flip": sign_flip,
        "two_sample": two_sample,
        "iqm": iqm,
        "probability_of_improvement": poi,
        "exact_bootstrap_mean": {"x": boot_x, "confidence": 0.95, "lo": lo, "hi": hi},
        "normal_quantile": normal,
        "power_means": means,
        "power_rates": rates,
    }
    json.dump(out, sys.stdout, indent=1)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
