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

__all__ = ["plot_performance_profiles", "plot_interval_estimates"]

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
