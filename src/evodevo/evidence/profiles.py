"""Figures of the aggregates: performance profiles and interval estimates (SPEC §6).

Both are drawn only from the arrays they are given (those of :func:`~evodevo.evidence.aggregate.
performance_profiles` and :func:`~evodevo.evidence.aggregate.aggregate_scores`), on a matplotlib
``Figure`` of their own (no pyplot state), and saved to a path; the format follows its suffix.
The profile is drawn by rliable's ``plot_performance_profiles`` on that figure's axis. The
interval estimates are drawn here in the same layout as rliable's ``plot_interval_estimates``,
which places its x label at a fixed figure fraction (it lands on the tick labels of a table of
two or three learners) and draws through pyplot's current figure.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from evodevo.evidence.aggregate import Profiles

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_performance_profiles", "plot_interval_estimates", "plot_run_scores"]

_COLORS = tuple(f"C{i}" for i in range(10))


def _colors(names: Sequence[str]) -> dict[str, str]:
    return {n: _COLORS[i % len(_COLORS)] for i, n in enumerate(names)}


def _save(fig: Figure, path: str | Path) -> Path:
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, bbox_inches="tight", dpi=150)
    return out


def plot_performance_profiles(
    profiles: Profiles,
    path: str | Path,
    xlabel: str = r"normalised score $\tau$",
    ylabel: str = r"fraction of runs with score $> \tau$",
    title: str | None = None,
) -> Path:
    """Each learner's profile with its bootstrap band, saved to ``path`` (returned).

    Args:
        profiles: Thresholds, profiles and bands, as :func:`performance_profiles` returns them.
        path: File to write (``.png``, ``.pdf``, ``.svg``, ...).
        xlabel: Label of the x axis.
        ylabel: Label of the y axis.
        title: Optional title.
    """
    from matplotlib.figure import Figure
    from rliable import plot_utils  # heavy (pandas, arch); imported on use, as in aggregate.py

    fig = Figure(figsize=(7.0, 4.5))
    ax = fig.subplots()
    plot_utils.plot_performance_profiles(
        profiles.profiles,
        profiles.taus,
        performance_profile_cis=profiles.intervals,
        ax=ax,
        colors=_colors(list(profiles.profiles)),
        xlabel=xlabel,
        ylabel=ylabel,
        legend=True,
        labelsize="large",
        ticklabelsize="medium",
        legendsize="medium",
    )
    if title:
        ax.set_title(title)
    return _save(fig, path)


def plot_interval_estimates(
    points: Mapping[str, np.ndarray],
    intervals: Mapping[str, np.ndarray],
    metric_names: Sequence[str],
    path: str | Path,
    xlabel: str = "normalised score",
) -> Path:
    """One panel per metric, one bar per learner from its lower to its upper bound, a tick at
    the point estimate; saved to ``path`` (returned).

    Args:
        points: Per learner, one point estimate per metric.
        intervals: Per learner, a ``2 x metrics`` array of lower and upper bounds.
        metric_names: Metric names, in the column order of the arrays.
        path: File to write.
        xlabel: Label under every panel.
    """
    names = list(points)
    k = len(metric_names)
    for n in names:
        if np.shape(intervals[n]) != (2, k) or np.shape(points[n]) != (k,):
            raise ValueError(
                f"{n}: points of shape {np.shape(points[n])} and intervals of shape "
                f"{np.shape(intervals[n])} do not match {k} metrics {list(metric_names)}"
            )
    colors = _colors(names)
    from matplotlib.figure import Figure  # 0.35 s; imported on use, as rliable is

    fig = Figure(figsize=(3.4 * k, 0.9 + 0.45 * len(names)))
    axes = np.atleast_1d(fig.subplots(1, k, sharey=True))
    for j, (ax, metric) in enumerate(zip(axes, metric_names, strict=True)):
        for i, n in enumerate(names):
            lo, hi = np.asarray(intervals[n], dtype=float)[:, j]
            ax.barh(i, hi - lo, left=lo, height=0.6, color=colors[n], alpha=0.75)
            ax.vlines(float(points[n][j]), i - 0.3, i + 0.3, color="k", alpha=0.6)
        ax.set_title(metric)
        ax.set_xlabel(xlabel)
        ax.grid(True, axis="x", alpha=0.25)
        for side in ("top", "right", "left"):
            ax.spines[side].set_visible(False)
    axes[0].set_yticks(range(len(names)), names)
    fig.tight_layout()
    return _save(fig, path)


def plot_run_scores(
    scores: Mapping[str, Mapping[int, float]],
    means: Mapping[str, tuple[float, float, float]],
    path: str | Path,
    ylabel: str = "score",
    title: str | None = None,
    target: float | None = None,
) -> Path:
    """Each arm's runs as dots (one per run) beside the mean over runs and its interval;
    saved to ``path`` (returned). The training run is the unit (SPEC §6), so every run is shown.

    Args:
        scores: Per arm, the score of each run by its seed.
        means: Per arm, ``(mean, low, high)`` over its runs (arms without runs are skipped).
        path: File to write.
        ylabel: Label of the y axis.
        title: Optional title.
        target: A goal drawn as a dashed line (or none).
    """
    from matplotlib.figure import Figure  # imported on use, as above

    names = list(scores)
    colors = _colors(names)
    fig = Figure(figsize=(1.2 + 1.3 * max(len(names), 2), 4.2))
    ax = fig.subplots()
    for i, n in enumerate(names):
        runs = scores[n]
        xs = i - 0.12 + 0.24 * np.linspace(0, 1, max(len(runs), 1))[: len(runs)]
        ax.scatter(xs, list(runs.values()), s=18, color=colors[n], alpha=0.8, zorder=3)
        if n in means:
            m, lo, hi = means[n]
            ax.errorbar(i + 0.25, m, yerr=[[m - lo], [hi - m]], fmt="s", color="k", ms=5, capsize=4)
    if target is not None:
        ax.axhline(target, ls="--", color="0.4", lw=1)
    ax.set_xticks(range(len(names)), names)
    ax.set_xlim(-0.6, len(names) - 0.4)
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.25)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    if title:
        ax.set_title(title, fontsize="medium")
    fig.tight_layout()
    return _save(fig, path)
