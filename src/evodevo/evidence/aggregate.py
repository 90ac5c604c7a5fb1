"""Aggregates over runs and tasks with stratified-bootstrap intervals, on rliable (SPEC §6).

The unit is the training run: a learner's scores are a ``runs x tasks`` matrix of normalised
returns (:mod:`evodevo.evidence.normalise`). rliable gives the IQM and mean with 95 %
stratified-bootstrap intervals (runs resampled within each task), the probability that one
learner improves on another, and performance profiles.

Reproducibility: rliable 1.2.0 accepts a ``random_state`` but its ``StratifiedBootstrap``
draws the resampled run indices from NumPy's *global* RNG (``np.random.choice``), so the
argument changes nothing and ``create_performance_profile`` has no seed at all. The bootstraps
here are rliable's classes with only the index draw moved onto the bootstrap's own generator
(arch's ``seed`` argument), driven by the same ``conf_int`` rliable calls: the same ``seed``
gives the same interval, and nothing touches global state. Given a ``RandomState`` seeded
like the global RNG they reproduce rliable's own numbers exactly.

>>> scores = {"a": np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6], [0.7, 0.8]])}
>>> agg = aggregate_scores(scores, reps=200, seed=0)
>>> round(agg.estimate("a", "IQM").point, 6)
0.45
>>> agg.estimate("a", "IQM") == aggregate_scores(scores, reps=200, seed=0).estimate("a", "IQM")
True
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "DEFAULT_REPS",
    "LEVEL",
    "AGGREGATES",
    "Seed",
    "make_generator",
    "Estimate",
    "Aggregates",
    "Profiles",
    "interval_estimates",
    "aggregate_scores",
    "probability_of_improvement",
    "performance_profiles",
]

#: Bootstrap resamples by default (SPEC §7: at least 10,000).
DEFAULT_REPS = 10_000
#: Coverage of every interval.
LEVEL = 0.95


# rliable is imported where it is used, not at the top: it brings pandas, arch and scipy.stats
# (1.2 s), which every CLI call and every spawned worker that imports a comparison module
# would otherwise pay, whether or not it bootstraps anything.


def _iqm(scores: np.ndarray) -> Any:
    from rliable import metrics

    return metrics.aggregate_iqm(scores)


def _mean(scores: np.ndarray) -> Any:
    from rliable import metrics

    return metrics.aggregate_mean(scores)


def probability_of_improvement_statistic(x: np.ndarray, y: np.ndarray) -> Any:
    """rliable's probability-of-improvement statistic of two ``runs x tasks`` matrices."""
    from rliable import metrics

    return metrics.probability_of_improvement(x, y)


#: The aggregates :func:`aggregate_scores` reports, by name, as rliable computes them.
AGGREGATES: dict[str, Callable[[np.ndarray], Any]] = {"IQM": _iqm, "Mean": _mean}

#: What a bootstrap can be seeded with: an int, or a NumPy generator used as it stands.
Seed = int | np.random.Generator | np.random.RandomState


def make_generator(seed: Seed) -> np.random.Generator | np.random.RandomState:
    """A generator from an int seed; a generator given is used as it stands."""
    if isinstance(seed, np.random.Generator | np.random.RandomState):
        return seed
    return np.random.default_rng(int(seed))


@functools.cache
def _bootstraps() -> tuple[type, type]:
    """rliable's stratified bootstraps, subclassed to draw their run indices from their own
    generator (the plain and the independent one); built on first use (rliable is heavy)."""
    from rliable import library as rly

    class SeededStratifiedBootstrap(rly.StratifiedBootstrap):  # type: ignore[misc]
        def update_indices(self) -> tuple[np.ndarray, ...]:
            indices = self.generator.choice(self._num_items, self._args_shape, replace=True)
            if self._task_bootstrap:
                tasks = self.generator.choice(
                    self._num_tasks, self._strata_indices[0].shape, replace=True
                )
                return (indices, tasks, *self._strata_indices[1:])
            return (indices, *self._strata_indices)

    class SeededStratifiedIndependentBootstrap(rly.StratifiedIndependentBootstrap):  # type: ignore[misc]
        def _get_indices(
            self, num_runs: int, array_shape: tuple[int, ...], strata_indices: list[np.ndarray]
        ) -> tuple[np.ndarray, ...]:
            return (self.generator.choice(num_runs, array_shape, replace=True), *strata_indices)

    return SeededStratifiedBootstrap, SeededStratifiedIndependentBootstrap


def _check(name: str, scores: np.ndarray) -> np.ndarray:
    a = np.asarray(scores, dtype=float)
    if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(
            f"scores of {name!r} have shape {a.shape}; give a runs x tasks matrix "
            "(one row per training run, one column per task)"
        )
    if not np.all(np.isfinite(a)):
        raise ValueError(f"scores of {name!r} hold NaN or inf; drop or fix those runs first")
    return a


def interval_estimates(
    score_dict: Mapping[str, np.ndarray | Sequence[np.ndarray]],
    func: Callable[..., Any],
    reps: int = DEFAULT_REPS,
    seed: Seed = 0,
    level: float = LEVEL,
    task_bootstrap: bool = False,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """rliable's ``get_interval_estimates`` (percentile method), seeded.

    Args:
        score_dict: Per key a ``runs x tasks`` matrix, or a list of such matrices that are
            resampled independently (e.g. ``[x, y]`` for a probability of improvement).
        func: Statistic of the matrix (or matrices); a scalar or 1-D array.
        reps: Bootstrap resamples.
        seed: Seed (or generator) of the bootstrap; an int starts a fresh stream for every
            key, so one learner's interval does not depend on which others are in the dict.
        level: Coverage of the intervals.
        task_bootstrap: Resample tasks as well as runs (rliable's option).

    Returns:
        ``(points, intervals)``: per key ``func`` of the data, and a ``2 x k`` array of lower
        and upper bounds, as rliable returns them.
    """
    if reps < 1:
        raise ValueError(f"reps={reps} must be at least 1 (SPEC §7 reports use 10,000)")
    points: dict[str, np.ndarray] = {}
    intervals: dict[str, np.ndarray] = {}
    plain, independent = _bootstraps()
    for key, scores in score_dict.items():
        gen = make_generator(seed)
        if isinstance(scores, np.ndarray):
            data = _check(key, scores)
            bs: Any = plain(data, task_bootstrap=task_bootstrap, seed=gen)
            points[key] = np.atleast_1d(np.asarray(func(data), dtype=float))
        else:
            arrays = [_check(key, s) for s in scores]
            bs = independent(*arrays, seed=gen)
            points[key] = np.atleast_1d(np.asarray(func(*arrays), dtype=float))
        intervals[key] = np.asarray(
            bs.conf_int(func, reps=reps, size=level, method="percentile"), dtype=float
        ).reshape(2, -1)
    return points, intervals


@dataclass(frozen=True)
class Estimate:
    """A point estimate and its interval.

    Attributes:
        point: The statistic on the data.
        low: Lower bound of the interval.
        high: Upper bound of the interval.
    """

    point: float
    low: float
    high: float

    def fmt(self, digits: int = 2) -> str:
        """``point [low, high]``.

        >>> Estimate(0.5, 0.25, 0.75).fmt()
        '0.50 [0.25, 0.75]'
        """
        return f"{self.point:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


@dataclass(frozen=True)
class Aggregates:
    """IQM and mean of each learner with their intervals, in rliable's array layout.

    Attributes:
        metric_names: Names of the aggregates, in column order.
        points: Per learner, one point estimate per metric.
        intervals: Per learner, a ``2 x metrics`` array of lower and upper bounds.
        n_runs: Per learner, the number of runs behind it.
        reps: Bootstrap resamples used.
    """

    metric_names: tuple[str, ...]
    points: dict[str, np.ndarray]
    intervals: dict[str, np.ndarray]
    n_runs: dict[str, int]
    reps: int

    def estimate(self, learner: str, metric: str) -> Estimate:
        """One learner's value of one aggregate."""
        j = self.metric_names.index(metric)
        lo, hi = self.intervals[learner][:, j]
        return Estimate(float(self.points[learner][j]), float(lo), float(hi))

    def to_markdown(self, digits: int = 2) -> str:
        """A Markdown table: learner, runs, then each aggregate with its 95 % interval."""
        head = "| learner | runs | " + " | ".join(f"{m} [95 % CI]" for m in self.metric_names)
        lines = [head + " |", "|---|---:|" + "---:|" * len(self.metric_names)]
        for name in self.points:
            cells = [self.estimate(name, m).fmt(digits) for m in self.metric_names]
            lines.append(f"| {name} | {self.n_runs[name]} | " + " | ".join(cells) + " |")
        return "\n".join(lines)


def aggregate_scores(
    score_dict: Mapping[str, np.ndarray],
    reps: int = DEFAULT_REPS,
    seed: Seed = 0,
    level: float = LEVEL,
) -> Aggregates:
    """IQM and mean of each learner's ``runs x tasks`` scores, with stratified-bootstrap intervals.

    The IQM (mean of the middle 50 % of all run-task scores) is rliable's recommended headline:
    less sensitive to outlier runs than the mean, far less noisy than the median.
    """
    names = tuple(AGGREGATES)

    def func(x: np.ndarray) -> np.ndarray:
        return np.array([AGGREGATES[m](x) for m in names])

    points, intervals = interval_estimates(score_dict, func, reps=reps, seed=seed, level=level)
    runs = {k: int(np.asarray(v).shape[0]) for k, v in score_dict.items()}
    return Aggregates(names, points, intervals, runs, reps)


def probability_of_improvement(
    score_dict: Mapping[str, np.ndarray],
    pairs: Sequence[tuple[str, str]],
    reps: int = DEFAULT_REPS,
    seed: Seed = 0,
    level: float = LEVEL,
) -> dict[tuple[str, str], Estimate]:
    """P(X > Y) for each pair ``(X, Y)``, with its interval (rliable's metric).

    Per task it is the Mann-Whitney probability that a random run of X beats a random run of
    Y (ties count one half), averaged over tasks; the runs of X and Y are resampled
    independently within each task. 0.5 is no improvement either way.

    >>> s = {"x": np.array([[1.0], [2.0], [3.0]]), "y": np.array([[0.0], [0.5], [0.7]])}
    >>> probability_of_improvement(s, [("x", "y")], reps=100)[("x", "y")].point
    1.0
    """
    for x, y in pairs:
        for k in (x, y):
            if k not in score_dict:
                raise KeyError(f"learner {k!r} is not among the scores {sorted(score_dict)}")
    pair_dict = {f"{x},{y}": [score_dict[x], score_dict[y]] for x, y in pairs}
    points, intervals = interval_estimates(
        pair_dict, probability_of_improvement_statistic, reps=reps, seed=seed, level=level
    )
    out: dict[tuple[str, str], Estimate] = {}
    for x, y in pairs:
        key = f"{x},{y}"
        out[(x, y)] = Estimate(
            float(points[key][0]), float(intervals[key][0, 0]), float(intervals[key][1, 0])
        )
    return out


@dataclass(frozen=True)
class Profiles:
    """Performance profiles: for each threshold τ, the fraction of run-task scores above τ.

    Attributes:
        taus: Thresholds on the normalised scale.
        profiles: Per learner, the profile at ``taus``.
        intervals: Per learner, a ``2 x len(taus)`` array of lower and upper bounds.
    """

    taus: np.ndarray
    profiles: dict[str, np.ndarray]
    intervals: dict[str, np.ndarray]


def performance_profiles(
    score_dict: Mapping[str, np.ndarray],
    taus: Sequence[float] | np.ndarray,
    reps: int = DEFAULT_REPS,
    seed: Seed = 0,
    level: float = LEVEL,
    per_run: bool = True,
) -> Profiles:
    """rliable's ``create_performance_profile``, seeded.

    Args:
        score_dict: Per learner a ``runs x tasks`` matrix.
        taus: Thresholds τ.
        reps: Bootstrap resamples.
        seed: Seed (or generator) of the bootstrap.
        level: Coverage of the bands.
        per_run: rliable's score distribution (fraction of all run-task scores above τ); if
            False, the fraction of tasks whose mean over runs is above τ.
    """
    from rliable import library as rly

    tau_arr = np.asarray(taus, dtype=float)
    dist = rly.score_distributions if per_run else rly.average_score_distributions

    def func(x: np.ndarray) -> np.ndarray:
        return np.asarray(dist(x, tau_arr), dtype=float)

    points, intervals = interval_estimates(score_dict, func, reps=reps, seed=seed, level=level)
    return Profiles(tau_arr, points, intervals)
