"""Statistics of one run (SPEC §7): Wilson intervals for success rates, bootstrap intervals for
means of a run's episodes, exact tests (McNemar, Fisher) between policies on episodes.

They describe one run; they never compare learners. Comparisons between learners, with the
training run as the unit (rliable aggregates, paired sign-flip and Wilcoxon tests on seeds,
verdicts against a margin δ), live in :mod:`evodevo.evidence` (SPEC §6), which reuses
:func:`holm` from here for the p-values of a table.

>>> lo, hi = wilson_interval(23, 40)
>>> round(lo, 3), round(hi, 3)
(0.422, 0.715)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "holm",
    "wilson_interval",
    "bootstrap_ci",
    "MeanSummary",
    "summarise",
    "fisher_exact",
    "permutation_test",
    "mcnemar_exact",
    "mcnemar_exact_counts",
    "RateSummary",
    "rate",
]

Z95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (95 % by default)."""
    if n <= 0:
        return (0.0, 1.0)
    if not 0 <= successes <= n:
        raise ValueError(f"successes={successes} must lie in [0, n={n}]")
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


def bootstrap_ci(
    values: Sequence[float] | np.ndarray,
    n_resamples: int = 10_000,
    level: float = 0.95,
    seed: int = 0,
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean (SPEC §6: ≥ 10,000 resamples)."""
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        return (float("nan"), float("nan"))
    if x.size == 1:
        return (float(x[0]), float(x[0]))
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, x.size, size=(n_resamples, x.size))
    means = x[idx].mean(axis=1)
    a = (1 - level) / 2
    return (float(np.quantile(means, a)), float(np.quantile(means, 1 - a)))


@dataclass(frozen=True)
class MeanSummary:
    """Mean, standard deviation (ddof=1), bootstrap 95 % interval and count."""

    mean: float
    std: float
    ci_low: float
    ci_high: float
    n: int

    def fmt(self, digits: int = 1) -> str:
        return f"{self.mean:.{digits}f} ± {self.std:.{digits}f} [{self.ci_low:.{digits}f}, {self.ci_high:.{digits}f}]"


def summarise(values: Sequence[float] | np.ndarray, seed: int = 0) -> MeanSummary:
    """:class:`MeanSummary` of ``values``."""
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        nan = float("nan")
        return MeanSummary(nan, nan, nan, nan, 0)
    lo, hi = bootstrap_ci(x, seed=seed)
    std = float(x.std(ddof=1)) if x.size > 1 else 0.0
    return MeanSummary(float(x.mean()), std, lo, hi, int(x.size))


@dataclass(frozen=True)
class RateSummary:
    """A success rate with its Wilson 95 % interval."""

    successes: int
    n: int
    rate: float
    ci_low: float
    ci_high: float

    def fmt(self) -> str:
        return f"{100 * self.rate:.1f} % [{100 * self.ci_low:.1f}, {100 * self.ci_high:.1f}] (n={self.n})"


def rate(successes: int, n: int) -> RateSummary:
    """:class:`RateSummary` for ``successes`` out of ``n``."""
    lo, hi = wilson_interval(successes, n)
    return RateSummary(int(successes), int(n), successes / n if n else float("nan"), lo, hi)


def fisher_exact(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided Fisher exact test p-value for two success counts."""
    # scipy.stats costs ~0.4 s to import, paid by every worker process that imports evodevo.grn;
    # only the tests of a table need it, so it is imported here
    from scipy.stats import fisher_exact as _fe

    res = _fe([[k1, n1 - k1], [k2, n2 - k2]], alternative="two-sided")
    return float(res[1])


def mcnemar_exact(
    a: Sequence[bool] | Sequence[int] | np.ndarray, b: Sequence[bool] | Sequence[int] | np.ndarray
) -> float:
    """Two-sided exact McNemar p-value for two policies' successes on the *same* episodes.

    Only the discordant episodes count: ``n_ab`` won by ``a`` alone and ``n_ba`` by ``b`` alone;
    under the null each is Binomial(n_ab + n_ba, 1/2). Paired on the episode seeds, it is more
    powerful than Fisher's test on the two rates (SPEC §6: the test used is named).

    >>> mcnemar_exact([1, 1, 1, 1, 1, 1, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0])  # 6 vs 0 discordant
    0.03125
    >>> mcnemar_exact([1, 0], [1, 0])  # no discordant episode: no evidence either way
    1.0
    """
    x = np.asarray(a, dtype=bool)
    y = np.asarray(b, dtype=bool)
    if x.shape != y.shape:
        raise ValueError(f"paired test needs the same episodes: {x.shape} vs {y.shape}")
    return mcnemar_exact_counts(int(np.sum(x & ~y)), int(np.sum(~x & y)))


def mcnemar_exact_counts(n_ab: int, n_ba: int) -> float:
    """:func:`mcnemar_exact` from the two discordant counts (e.g. summed over the seeds of
    several paired tables: the pairs stay pairs).

    >>> mcnemar_exact_counts(6, 0)
    0.03125
    """
    if n_ab < 0 or n_ba < 0:
        raise ValueError(f"discordant counts must be >= 0, got {n_ab} and {n_ba}")
    n = n_ab + n_ba
    if n == 0:
        return 1.0
    from scipy.stats import binomtest  # lazy: see fisher_exact

    return float(binomtest(min(n_ab, n_ba), n, 0.5).pvalue)


def holm(pvalues: Sequence[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (family-wise error over the given tests), input order.

    >>> holm([0.01, 0.04, 0.03])
    [0.03, 0.06, 0.06]
    """
    m = len(pvalues)
    order = sorted(range(m), key=lambda i: pvalues[i])
    out = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * float(pvalues[i])))
        out[i] = running
    return out


def permutation_test(
    a: Sequence[float] | np.ndarray,
    b: Sequence[float] | np.ndarray,
    n_resamples: int = 10_000,
    seed: int = 0,
    paired: bool = False,
) -> float:
    """Two-sided permutation test p-value for a difference of means.

    With ``paired=True`` (same episode seeds on both sides) the signs of the per-pair
    differences are flipped: over all ``2**n`` sign patterns (the exact test) when that is at
    most ``n_resamples``, else at random. With n pairs the exact test cannot go below
    ``2 / 2**n`` (0.25 for 3 seeds). Otherwise (unpaired) the labels are shuffled at random.
    """
    x = np.asarray(a, dtype=float)
    y = np.asarray(b, dtype=float)
    rng = np.random.default_rng(seed)
    if paired:
        if x.shape != y.shape:
            raise ValueError("paired test needs equal-length samples")
        d = x - y
        obs = abs(d.mean())
        if 2**d.size <= n_resamples:
            patterns = np.arange(2**d.size)[:, None] >> np.arange(d.size) & 1
            stats = np.abs(((1.0 - 2.0 * patterns) * d).mean(axis=1))
            return float(np.mean(stats >= obs - 1e-12))
        signs = rng.choice([-1.0, 1.0], size=(n_resamples, d.size))
        stats = np.abs((signs * d).mean(axis=1))
    else:
        pooled = np.concatenate([x, y])
        obs = abs(x.mean() - y.mean())
        stats = np.empty(n_resamples)
        for i in range(n_resamples):
            p = rng.permutation(pooled)
            stats[i] = abs(p[: x.size].mean() - p[x.size :].mean())
    return float((1 + np.sum(stats >= obs - 1e-12)) / (n_resamples + 1))
