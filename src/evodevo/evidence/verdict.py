"""The verdict of a two-learner comparison: different, equivalent within δ, or inconclusive.

SPEC §6 makes "no effect" a measured statement. From the paired differences ``d_i = A_i - B_i``
(one per training seed), a Holm-adjusted p and a margin δ fixed before the runs
(:mod:`evodevo.evidence.normalise`):

* **different** — ``p_adj < alpha`` and the 95 % interval of the mean difference excludes 0;
* **equivalent within δ** — otherwise, if the 95 % interval lies inside ``[-δ, +δ]`` (a TOST-
  style test; a 95 % rather than a 90 % interval, so it is the stricter of the two);
* **inconclusive** — neither; it then states how many runs a decision would need.

A difference can be significant and still smaller than δ; it reads "different", and its
interval shows the size. Runs needed (normal approximation, observed mean ``m`` and standard
deviation ``s`` of the differences, ``z_c = z_{(1+level)/2}``, ``z_a = z_{1-alpha/(2k)}`` for a
table of ``k`` comparisons, ``z_b = z_power``)::

    equivalence, if |m| < δ:   n > (z_c * s / (δ - |m|))**2          (half-width < δ - |m|)
    difference,  if m != 0:    n >= ((z_a + z_b) * s / |m|)**2       (MDE(n) <= |m|)
                               and 2 / 2**n < alpha / k               (the sign-flip test can)

The smaller of the two routes is reported, and never fewer than ``n + 1``. These are planning
numbers: they take the observed ``m`` and ``s`` as the truth.

>>> c = compare("A", [10.0, 11.0, 12.0, 10.5, 11.5, 10.0, 11.0, 12.0], "B", [0.0] * 8,
...             delta=1.0, reps=500)
>>> c.verdict, c.n
('different', 8)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from statistics import NormalDist
from typing import ClassVar, Literal

import numpy as np

from evodevo.evidence.aggregate import DEFAULT_REPS, LEVEL, Seed
from evodevo.evidence.paired import (
    holm,
    minimum_detectable_difference,
    paired_difference_interval,
    runs_for_alpha,
    sign_flip_test,
    wilcoxon_test,
)

__all__ = [
    "DIFFERENT",
    "EQUIVALENT",
    "INCONCLUSIVE",
    "ALPHA",
    "POWER",
    "decide",
    "runs_needed",
    "Comparison",
    "compare",
    "holm_table",
    "to_markdown",
]

DIFFERENT = "different"
EQUIVALENT = "equivalent within δ"
INCONCLUSIVE = "inconclusive"
#: Family-wise error rate of a table.
ALPHA = 0.05
#: Power behind the minimum detectable difference and the runs needed.
POWER = 0.8


def decide(low: float, high: float, p_adj: float, delta: float, alpha: float = ALPHA) -> str:
    """The verdict from the interval ``[low, high]`` of the mean difference and ``p_adj``.

    >>> decide(0.5, 1.5, 0.01, delta=0.2)
    'different'
    >>> decide(-0.1, 0.1, 0.9, delta=0.2)
    'equivalent within δ'
    >>> decide(-0.1, 0.5, 0.3, delta=0.2)
    'inconclusive'
    """
    if not delta > 0:
        raise ValueError(f"delta={delta} must be > 0; fix the margin before the runs (SPEC §6)")
    if low > high:
        raise ValueError(f"interval [{low}, {high}] has its bounds swapped")
    if p_adj < alpha and (low > 0 or high < 0):
        return DIFFERENT
    if -delta <= low and high <= delta:
        return EQUIVALENT
    return INCONCLUSIVE


def runs_needed(
    mean_diff: float,
    std_diff: float,
    delta: float,
    n: int,
    alpha: float = ALPHA,
    power: float = POWER,
    level: float = LEVEL,
    family_size: int = 1,
) -> int:
    """Paired runs an inconclusive comparison needs for a verdict (formula in the module doc).

    >>> runs_needed(mean_diff=0.0, std_diff=1.0, delta=0.5, n=5)  # (1.96 / 0.5)**2 = 15.4
    16
    >>> runs_needed(mean_diff=1.0, std_diff=1.0, delta=0.5, n=5)  # (2.80 / 1)**2 = 7.8
    8
    """
    if not delta > 0:
        raise ValueError(f"delta={delta} must be > 0")
    m, s = abs(float(mean_diff)), float(std_diff)
    z = NormalDist()  # the standard normal's quantiles
    z_c = z.inv_cdf((1 + level) / 2)
    z_ab = z.inv_cdf(1 - alpha / (2 * family_size)) + z.inv_cdf(power)
    routes: list[int] = []
    if m < delta:
        routes.append(math.floor((z_c * s / (delta - m)) ** 2) + 1)
    if m > 0:
        routes.append(max(math.ceil((z_ab * s / m) ** 2), runs_for_alpha(alpha / family_size)))
    return max(min(routes), n + 1)


@dataclass(frozen=True)
class Comparison:
    """Learner ``a`` against learner ``b`` on paired runs (``a - b``).

    Attributes:
        a: Name of the first arm.
        b: Name of the second arm.
        n: Paired runs (seeds).
        mean_diff: Mean of ``a - b`` over the runs.
        low: Lower bound of the bootstrap interval of ``mean_diff``.
        high: Upper bound of that interval.
        std_diff: Standard deviation (ddof=1) of the differences.
        p: Two-sided p of ``test``.
        p_adj: ``p`` after Holm's correction over the table (``p`` alone).
        delta: Margin δ, in the units of the scores.
        alpha: Family-wise error rate.
        mde: Smallest difference ``n`` runs detect at ``alpha`` and power 0.8 (normal approx.).
        verdict: :data:`DIFFERENT`, :data:`EQUIVALENT` or :data:`INCONCLUSIVE`.
        runs_needed: Paired runs a verdict would need; ``None`` once decided.
        test: The test behind ``p``.
        family_size: Comparisons in the Holm family.
        task: What the scores are of (a task, or "all"); a column of the table.
    """

    a: str
    b: str
    n: int
    mean_diff: float
    low: float
    high: float
    std_diff: float
    p: float
    p_adj: float
    delta: float
    alpha: float
    mde: float
    verdict: str
    runs_needed: int | None
    test: str
    family_size: int = 1
    task: str = ""

    #: Markdown header matching :meth:`fmt`.
    HEADER: ClassVar[str] = (
        "| task | A − B | runs | mean diff [95 % CI] | δ | test | p | p (Holm) | MDE | verdict |\n"
        "|---|---|---:|---:|---:|---|---:|---:|---:|---|"
    )

    def fmt(self, digits: int = 2) -> str:
        """One Markdown table row (columns as in :attr:`HEADER`)."""
        f = f".{digits}f"
        verdict = self.verdict
        if self.runs_needed is not None:
            verdict += f" (needs ≈ {self.runs_needed} runs)"
        return (
            f"| {self.task or '—'} | {self.a} − {self.b} | {self.n} | {self.mean_diff:{f}} [{self.low:{f}}, "
            f"{self.high:{f}}] | {self.delta:{f}} | {self.test} | {self.p:.3g} | "
            f"{self.p_adj:.3g} | {self.mde:{f}} | {verdict} |"
        )

    def redecided(self, p_adj: float, family_size: int) -> Comparison:
        """This comparison with a new adjusted p and family, verdict and runs re-derived."""
        verdict = decide(self.low, self.high, p_adj, self.delta, self.alpha)
        needed = (
            runs_needed(
                self.mean_diff,
                self.std_diff,
                self.delta,
                self.n,
                self.alpha,
                family_size=family_size,
            )
            if verdict == INCONCLUSIVE
            else None
        )
        return replace(
            self, p_adj=p_adj, verdict=verdict, runs_needed=needed, family_size=family_size
        )


def compare(
    a: str,
    a_runs: Sequence[float] | np.ndarray,
    b: str,
    b_runs: Sequence[float] | np.ndarray,
    delta: float,
    alpha: float = ALPHA,
    test: Literal["sign-flip", "wilcoxon"] = "sign-flip",
    reps: int = DEFAULT_REPS,
    seed: Seed = 0,
    level: float = LEVEL,
    task: str = "",
) -> Comparison:
    """Compare two learners whose run ``i`` shares training seed ``i``.

    Args:
        a: Name of the first arm.
        a_runs: One score per run of ``a`` (e.g. its final normalised return), seed order.
        b: Name of the second arm.
        b_runs: The scores of ``b`` on the same seeds, same order.
        delta: Margin δ in the units of the scores, fixed before the runs.
        alpha: Family-wise error rate.
        test: ``"sign-flip"`` (exact, any n) or ``"wilcoxon"`` (from 10 runs).
        reps: Bootstrap resamples of the interval.
        seed: Seed of the bootstrap (and of a Monte-Carlo sign-flip test).
        level: Coverage of the interval.
        task: What the scores are of, shown in the table.

    Returns:
        A :class:`Comparison` whose ``p_adj`` is ``p`` (a table of one); pass a table's
        comparisons to :func:`holm_table` to correct them together.
    """
    x = np.asarray(a_runs, dtype=float).ravel()
    y = np.asarray(b_runs, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError(
            f"{a} has {x.size} runs and {b} has {y.size}; a paired comparison needs the same "
            "training seeds for both arms"
        )
    d = x - y
    if test == "sign-flip":
        p = sign_flip_test(d, seed=seed)
    elif test == "wilcoxon":
        p = wilcoxon_test(d)
    else:
        raise ValueError(f"test={test!r} is not one of 'sign-flip', 'wilcoxon'")
    est = paired_difference_interval(d, reps=reps, seed=seed, level=level)
    std = float(d.std(ddof=1)) if d.size > 1 else 0.0
    base = Comparison(
        a=a,
        b=b,
        n=int(d.size),
        mean_diff=est.point,
        low=est.low,
        high=est.high,
        std_diff=std,
        p=p,
        p_adj=p,
        delta=float(delta),
        alpha=alpha,
        mde=minimum_detectable_difference(std, int(d.size), alpha),
        verdict=INCONCLUSIVE,
        runs_needed=None,
        test=test,
        task=task,
    )
    return base.redecided(p, 1)


def holm_table(comparisons: Sequence[Comparison]) -> list[Comparison]:
    """The comparisons of one table with Holm-adjusted p-values and their verdicts re-derived."""
    adjusted = holm([c.p for c in comparisons])
    k = len(comparisons)
    return [c.redecided(p, k) for c, p in zip(comparisons, adjusted, strict=True)]


def to_markdown(comparisons: Sequence[Comparison], digits: int = 2) -> str:
    """A Markdown table of comparisons (header and one row each)."""
    return "\n".join([Comparison.HEADER, *(c.fmt(digits) for c in comparisons)])
