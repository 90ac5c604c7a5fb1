"""Paired run-level tests between two learners trained on the same seeds (SPEC §6).

Run ``i`` of learner A and run ``i`` of learner B share a training seed, so the evidence is the
vector of differences ``d_i = A_i - B_i``, one per seed. The exact sign-flip test asks how often
flipping the signs of the ``d_i`` gives a mean at least as far from 0 as the observed one; the
Wilcoxon signed-rank test (scipy) ranks them and is used from 10 runs on. P-values of one table
are Holm-corrected together (:func:`holm`). With ``n`` runs no two-sided sign-flip p can be
below ``2 / 2**n`` (0.0625 for 5 runs), and :func:`minimum_detectable_difference` says which
difference ``n`` runs can find.

>>> sign_flip_test([1.0, 2.0, 3.0, 4.0, 5.0])  # every run of A above B, 5 seeds
0.0625
>>> smallest_sign_flip_p(10)
0.001953125
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from statistics import NormalDist

import numpy as np

from evodevo.evidence.aggregate import (
    AGGREGATES,
    DEFAULT_REPS,
    LEVEL,
    Estimate,
    Seed,
    interval_estimates,
    make_generator,
)
from evodevo.stats import holm

#: The standard normal (its quantiles; the standard library's, exact to ~1e-15).
_Z = NormalDist()

__all__ = [
    "MAX_EXACT_RUNS",
    "MONTE_CARLO_RESAMPLES",
    "MIN_WILCOXON_RUNS",
    "sign_flip_test",
    "wilcoxon_test",
    "holm",
    "paired_difference_interval",
    "smallest_sign_flip_p",
    "runs_for_alpha",
    "minimum_detectable_difference",
]

#: Up to this many runs the sign-flip test enumerates all 2**n sign patterns.
MAX_EXACT_RUNS = 20
#: Random sign patterns of the Monte-Carlo sign-flip test above ``MAX_EXACT_RUNS`` runs.
MONTE_CARLO_RESAMPLES = 100_000
#: SPEC §6: the Wilcoxon signed-rank test is used from this many runs on.
MIN_WILCOXON_RUNS = 10


def _diffs(d: Sequence[float] | np.ndarray) -> np.ndarray:
    x = np.asarray(d, dtype=float).ravel()
    if x.size == 0:
        raise ValueError("no paired differences given; pass one difference per training seed")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"paired differences hold NaN or inf: {x.tolist()}")
    return x


def sign_flip_test(
    diffs: Sequence[float] | np.ndarray,
    seed: Seed = 0,
    n_resamples: int = MONTE_CARLO_RESAMPLES,
) -> float:
    """Two-sided sign-flip (paired permutation) test of mean difference 0.

    Under the null each ``d_i`` is as likely to be ``-d_i``. The statistic is ``|sum d|``; up
    to :data:`MAX_EXACT_RUNS` runs all ``2**n`` sign patterns are counted (exact p, the
    observed pattern included), above that ``n_resamples`` random patterns from ``seed`` give
    ``(1 + hits) / (1 + n_resamples)``.

    Args:
        diffs: One paired difference per seed.
        seed: Seed (or generator) of the Monte-Carlo patterns; unused when exact.
        n_resamples: Random patterns above :data:`MAX_EXACT_RUNS` runs.

    >>> sign_flip_test([1.0, -1.0])
    1.0
    """
    d = _diffs(diffs)
    obs = abs(d.sum())
    tol = 1e-9 * max(1.0, float(np.abs(d).sum()))
    if d.size <= MAX_EXACT_RUNS:
        sums = np.zeros(1)
        for v in d:  # all 2**n signed sums, doubling per run
            sums = np.concatenate([sums + v, sums - v])
        return float(np.mean(np.abs(sums) >= obs - tol))
    gen = make_generator(seed)
    hits = 0
    for start in range(0, n_resamples, 10_000):
        k = min(10_000, n_resamples - start)
        signs = gen.choice([-1.0, 1.0], size=(k, d.size))
        hits += int(np.sum(np.abs(signs @ d) >= obs - tol))
    return float((1 + hits) / (1 + n_resamples))


def wilcoxon_test(diffs: Sequence[float] | np.ndarray) -> float:
    """Two-sided Wilcoxon signed-rank p-value (scipy's exact or normal method, as it picks).

    SPEC §6 uses it from :data:`MIN_WILCOXON_RUNS` runs; with fewer, use
    :func:`sign_flip_test`. Zero differences are dropped (scipy's default, Wilcoxon's rule);
    all-zero differences give p = 1.
    """
    d = _diffs(diffs)
    if d.size < MIN_WILCOXON_RUNS:
        raise ValueError(
            f"the Wilcoxon test is used from {MIN_WILCOXON_RUNS} runs (SPEC §6), got {d.size}; "
            "use sign_flip_test for fewer runs"
        )
    if not np.any(d):
        return 1.0
    from scipy import stats as sps  # 0.4 s at import; only this test needs it

    return float(sps.wilcoxon(d, alternative="two-sided").pvalue)


def paired_difference_interval(
    diffs: Sequence[float] | np.ndarray,
    reps: int = DEFAULT_REPS,
    seed: Seed = 0,
    level: float = LEVEL,
) -> Estimate:
    """Mean paired difference with its percentile-bootstrap interval (runs resampled, rliable).

    >>> paired_difference_interval([2.0, 2.0, 2.0], reps=100)
    Estimate(point=2.0, low=2.0, high=2.0)
    """
    d = _diffs(diffs)
    points, intervals = interval_estimates(
        {"d": d[:, None]}, AGGREGATES["Mean"], reps=reps, seed=seed, level=level
    )
    return Estimate(float(points["d"][0]), float(intervals["d"][0, 0]), float(intervals["d"][1, 0]))


def smallest_sign_flip_p(n: int) -> float:
    """The smallest two-sided p the exact sign-flip test can give with ``n`` runs: ``2 / 2**n``.

    >>> smallest_sign_flip_p(5)
    0.0625
    """
    if n < 1:
        raise ValueError(f"n={n} runs must be at least 1")
    return min(1.0, 2.0 / 2.0**n)


def runs_for_alpha(alpha: float = 0.05) -> int:
    """The fewest runs whose smallest sign-flip p is below ``alpha`` (6 at 0.05).

    >>> runs_for_alpha(0.05), runs_for_alpha(0.01)
    (6, 8)
    """
    if not 0 < alpha < 1:
        raise ValueError(f"alpha={alpha} must lie in (0, 1)")
    n = 1
    while smallest_sign_flip_p(n) >= alpha:
        n += 1
    return n


def minimum_detectable_difference(
    std_diff: float, n: int, alpha: float = 0.05, power: float = 0.8
) -> float:
    """Smallest true mean difference ``n`` paired runs detect with the given power.

    Normal approximation of a two-sided test: ``(z_{1-alpha/2} + z_power) * std_diff / sqrt(n)``
    (2.80 standard errors at alpha 0.05 and power 0.8). It ignores that ``std_diff`` is itself
    estimated and that the exact tests are discrete, so with few runs it is optimistic; below
    :func:`runs_for_alpha` runs no difference is detectable by the sign-flip test at all.

    >>> round(minimum_detectable_difference(1.0, 10), 3)
    0.886
    """
    if n < 1:
        raise ValueError(f"n={n} runs must be at least 1")
    if std_diff < 0:
        raise ValueError(f"std_diff={std_diff} must be >= 0")
    z = _Z.inv_cdf(1 - alpha / 2) + _Z.inv_cdf(power)
    return z * std_diff / math.sqrt(n)
