"""Figures 3.3-3.5 drawn from saved run files only (SPEC §1.8, §6; STYLE.md point 2).

* ``fig_3_3_learning_curves.png``: per task, training return per episode (moving average),
  mean ± std over seeds, one line per variant, one colour per variant in every panel, the
  legend below the panels.
* ``fig_3_4_ablation.png``: final return per task and variant, mean ± std over seeds.
* ``fig_3_5_{env}.png``: for one modulated run, per task: the four module states, the
  effective learning rate, the context gate, and the 4x4 correlation of the states.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from evodevo.neuromod.config import MODULE_NAMES
from evodevo.plotting import pyplot
from evodevo.runs import RunDir

__all__ = ["draw_all", "learning_curves", "ablation_bars", "neuromod_dynamics"]

_ORDER = ("biarm", "pnn", "no-da", "no-5ht", "no-ne", "no-ach")


def _folder(root: Path, variant: str, seed: int) -> Path:
    return root / "runs" / f"{variant}__s{seed}"


def _smooth(x: np.ndarray, w: int) -> np.ndarray:
    if x.size < w or w <= 1:
        return x
    c = np.cumsum(np.insert(x, 0, 0.0))
    head = c[1:w] / np.arange(1, w)
    return np.concatenate([head, (c[w:] - c[:-w]) / w])


def learning_curves(
    root: Path, runs: dict[str, dict[int, dict[str, Any]]], window: int = 20
) -> str:
    """Fig. 3.3 from every run's ``metrics.csv``."""
    plt = pyplot()
    envs = [t["env_id"] for t in next(iter(next(iter(runs.values())).values()))["tasks"]]
    variants = [v for v in _ORDER if v in runs] + [v for v in runs if v not in _ORDER]
    width = 4.2 * len(envs)
    rows_of_legend = -(-len(variants) // max(1, int(width // 1.5)))  # about 1.5 in per entry
    ncol = max(1, -(-len(variants) // rows_of_legend))  # the rows balanced
    legend_h = 0.3 + 0.22 * rows_of_legend  # inches below the panels
    fig, axes = plt.subplots(1, len(envs), figsize=(width, 3.4 + legend_h), squeeze=False)
    colours = plt.get_cmap("tab10")
    handles, labels = [], []
    for k, v in enumerate(variants):
        colour = colours(k % 10)
        per_task: dict[int, list[np.ndarray]] = {}
        line = None
        for seed in runs[v]:
            rows = RunDir(_folder(root, v, seed), create=False).read_csv("metrics.csv")
            for i in range(len(envs)):
                r = np.array([float(x["return"]) for x in rows if int(x["task"]) == i])
                per_task.setdefault(i, []).append(_smooth(r, window))
        for i, curves in per_task.items():
            n = min(len(c) for c in curves)
            if n == 0:
                continue
            m = np.stack([c[:n] for c in curves])
            mean, std = m.mean(0), m.std(0)
            ax = axes[0][i]
            xs = np.arange(n)
            (line,) = ax.plot(xs, mean, color=colour, lw=1.2)
            ax.fill_between(xs, mean - std, mean + std, color=colour, alpha=0.15, lw=0)
        if line is not None:
            handles.append(line)
            labels.append(f"{v} (n={len(runs[v])})")
    for i, env in enumerate(envs):
        axes[0][i].set_title(env)
        axes[0][i].set_xlabel("episode")
    axes[0][0].set_ylabel(f"return ({window}-episode moving average)")
    # The legend sits below the panels, outside every axes, so it covers no curve.
    fig.legend(
        handles,
        labels,
        loc="lower center",
        ncol=ncol,
        fontsize=9,
        frameon=False,
        title="mean ± std over n seeds",
        title_fontsize=9,
    )
    fig.tight_layout(rect=(0, legend_h / (3.4 + legend_h), 1, 1))
    name = "fig_3_3_learning_curves.png"
    fig.savefig(root / name, dpi=110)
    plt.close(fig)
    return name


def ablation_bars(root: Path, runs: dict[str, dict[int, dict[str, Any]]]) -> str:
    """Fig. 3.4: final return per task and variant (mean ± std over seeds)."""
    plt = pyplot()
    variants = [v for v in _ORDER if v in runs]
    envs = [t["env_id"] for t in next(iter(next(iter(runs.values())).values()))["tasks"]]
    fig, axes = plt.subplots(1, len(envs), figsize=(3.6 * len(envs), 3.4), squeeze=False)
    for i, env in enumerate(envs):
        ax = axes[0][i]
        means, stds = [], []
        for v in variants:
            vals = [
                t["final_return"]
                for s in runs[v].values()
                for t in s["tasks"]
                if t["env_id"] == env
            ]
            means.append(float(np.mean(vals)))
            stds.append(float(np.std(vals, ddof=1)) if len(vals) > 1 else 0.0)
        ax.bar(range(len(variants)), means, yerr=stds, capsize=3, color="C0")
        ax.set_xticks(range(len(variants)), variants, rotation=45, fontsize=8)
        ax.set_title(env)
    axes[0][0].set_ylabel("final return (greedy evaluation)")
    fig.tight_layout()
    name = "fig_3_4_ablation.png"
    fig.savefig(root / name, dpi=110)
    plt.close(fig)
    return name


def neuromod_dynamics(run_dir: Path, out: Path, label: str = "") -> list[str]:
    """Fig. 3.5 for one run: per task states, learning rate, context gate, correlations."""
    plt = pyplot()
    run = RunDir(run_dir, create=False)
    rows = run.read_csv("neuromod.csv")
    envs = [t["env_id"] for t in run.read_summary()["tasks"]]
    names = []
    for i, env in enumerate(envs):
        sel = [r for r in rows if int(r["task"]) == i and r["s_DA"] != ""]
        if len(sel) < 2:
            continue
        step = np.array([int(r["step"]) for r in sel])
        states = np.array([[float(r[f"s_{m}"]) for m in MODULE_NAMES] for r in sel])
        lr = np.array([float(r["lr"]) for r in sel])
        gate = np.array([float(r["gate"]) if r["gate"] else np.nan for r in sel])
        fig = plt.figure(figsize=(9, 8))
        gs = fig.add_gridspec(3, 2)
        ax = fig.add_subplot(gs[0, :])
        for j, m in enumerate(MODULE_NAMES):
            ax.plot(step, states[:, j], label=m, lw=0.8)
        ax.set_ylim(0, 1)
        ax.set_title(f"{env}: neuromodulator states {label}")
        ax.legend(fontsize=8, ncol=4)
        ax = fig.add_subplot(gs[1, 0])
        ax.plot(step, lr, lw=0.8)
        ax.set_title("effective learning rate (Eq. 3.7)")
        ax = fig.add_subplot(gs[1, 1])
        ax.plot(step, gate, lw=0.8)
        ax.set_title("context gate sigmoid(sum w_m s_m) (Eq. 3.8)")
        ax = fig.add_subplot(gs[2, :])
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = np.corrcoef(states.T)
        im = ax.imshow(corr, vmin=-1, vmax=1, cmap="coolwarm")
        ax.set_xticks(range(4), MODULE_NAMES)
        ax.set_yticks(range(4), MODULE_NAMES)
        for a in range(4):
            for b in range(4):
                if np.isfinite(corr[a, b]):
                    ax.text(b, a, f"{corr[a, b]:.2f}", ha="center", va="center", fontsize=8)
        fig.colorbar(im, ax=ax, fraction=0.03)
        ax.set_title("correlation of the states")
        fig.tight_layout()
        name = f"fig_3_5_{env}.png"
        fig.savefig(out / name, dpi=100)
        plt.close(fig)
        names.append(name)
    return names


def draw_all(root: str | Path, runs: dict[str, dict[int, dict[str, Any]]]) -> list[str]:
    """Every figure of the grid in ``root``; returns the file names."""
    root = Path(root)
    names = [learning_curves(root, runs), ablation_bars(root, runs)]
    # Fig. 3.5 from the first modulated run (in this order) whose module log was kept: the runs
    # that the grid took over from a sweep's lanes may lack neuromod.csv.
    for v in ("biarm", "no-da", "no-5ht", "no-ne", "no-ach"):
        logged = [
            s for s in sorted(runs.get(v, {})) if (_folder(root, v, s) / "neuromod.csv").is_file()
        ]
        if logged:
            seed = logged[0]
            names += neuromod_dynamics(_folder(root, v, seed), root, f"({v}, seed {seed})")
            break
    return names
