"""Figures of SPEC §2.5, drawn only from a run's saved files (never inside the training loop).

* ``fitness_success.png`` — best/mean fitness and best training success per generation
  (``history.csv``);
* ``connections.png`` — regulatory connections per generation (``history.csv``);
* ``regulatory_heatmap.png`` — W_r of the best genome, blue activation / red repression
  (``best_genome.npz``);
* ``rolling_success_<eval>.png`` — rolling success over the test episodes, genome beside the
  trivial policies (``eval_*_episodes.csv``);
* ``ablations.png`` — change in success per ablation with its interval (``ablations.csv``);
* ``expression_trace.png`` — gene expression of one test episode (``trace.npz``);
* ``modulator_trace.png`` — neuromodulated GRN (SPEC §5): the four modulator states, the gene
  expression and the actions of one test episode (``modulator_trace.npz``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from evodevo.errors import EvodevoError
from evodevo.grn.genome import load_arrays
from evodevo.grn.neuromodulated import MODULATOR_TRACE_FILE
from evodevo.grn.recording import TRACE_FILE
from evodevo.plotting import pyplot
from evodevo.runs import RunDir

__all__ = ["plot_run", "plot_modulator_trace", "ROLLING_WINDOW"]

ROLLING_WINDOW = 10
"""Episodes in the rolling success window."""


def _col(rows: list[dict[str, str]], key: str) -> np.ndarray:
    return np.array([float(r[key]) for r in rows])


def plot_history(run: RunDir, out: Path) -> list[Path]:
    """Fitness/success and connections per generation."""
    plt = pyplot()
    rows = run.read_csv("history.csv")
    if not rows:
        raise EvodevoError(f"{str(run / 'history.csv')!r} holds no generation yet")
    gen = _col(rows, "generation") + 1
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(gen, _col(rows, "best_fitness"), "o-", label="best fitness")
    ax.plot(gen, _col(rows, "mean_fitness"), "s--", label="mean fitness")
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness (Eq. 4.6)")
    ax2 = ax.twinx()
    ax2.plot(gen, _col(rows, "best_success"), "^-", color="tab:green", label="best success")
    ax2.set_ylabel("training success")
    ax2.set_ylim(-0.02, 1.02)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, loc="lower right", fontsize=8)
    fig.tight_layout()
    p1 = out / "fitness_success.png"
    fig.savefig(p1, dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 3))
    ax.plot(gen, _col(rows, "best_connections"), "o-", label="best genome")
    ax.plot(gen, _col(rows, "mean_connections"), "s--", label="population mean")
    ax.set_xlabel("generation")
    ax.set_ylabel("regulatory connections")
    ax.legend(fontsize=8)
    fig.tight_layout()
    p2 = out / "connections.png"
    fig.savefig(p2, dpi=120)
    plt.close(fig)
    return [p1, p2]


def plot_heatmap(run: RunDir, out: Path) -> list[Path]:
    """W_r heatmap: blue = activation (w > 0), red = repression (w < 0)."""
    arrays, header = load_arrays(run / "best_genome.npz")
    if "W_r" not in arrays:
        return []
    plt = pyplot()
    w = arrays["W_r"]
    lim = float(np.abs(w).max()) or 1.0
    fig, ax = plt.subplots(figsize=(5, 4.3))
    im = ax.imshow(w, cmap="RdBu", vmin=-lim, vmax=lim)
    ax.set_xlabel("target gene i")
    ax.set_ylabel("source gene k")
    density = np.count_nonzero(w) / w.size
    ax.set_title(f"W_r of the best genome ({100 * density:.0f} % present)", fontsize=9)
    fig.colorbar(im, ax=ax, label="weight (blue activation, red repression)")
    fig.tight_layout()
    p = out / "regulatory_heatmap.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return [p]


def plot_rolling(run: RunDir, out: Path) -> list[Path]:
    """Rolling success over the test episodes, one figure per evaluation file."""
    plt = pyplot()
    paths = []
    for csv_path in sorted(run.path.glob("eval_*_episodes.csv")):
        rows = run.read_csv(csv_path.name)
        fig, ax = plt.subplots(figsize=(6, 3.2))
        for policy in dict.fromkeys(r["policy"] for r in rows):
            s = np.array([float(r["success"]) for r in rows if r["policy"] == policy])
            w = min(ROLLING_WINDOW, len(s))
            roll = np.convolve(s, np.ones(w) / w, mode="valid")
            ax.plot(np.arange(w, len(s) + 1), roll, label=f"{policy} ({100 * s.mean():.0f} %)")
        ax.set_xlabel("test episode")
        ax.set_ylabel(f"success, rolling mean of {ROLLING_WINDOW}")
        ax.set_ylim(-0.02, 1.02)
        ax.legend(fontsize=8)
        ax.set_title(csv_path.stem.replace("_episodes", ""), fontsize=9)
        fig.tight_layout()
        p = out / f"rolling_success_{csv_path.stem.replace('_episodes', '')}.png"
        fig.savefig(p, dpi=120)
        plt.close(fig)
        paths.append(p)
    return paths


def plot_ablations(run: RunDir, out: Path, stem: str = "ablations") -> list[Path]:
    """Change in success per ablation with its 95 % interval (``{stem}.csv`` →
    ``{stem}.png``; the stem of a ``--set`` test: :func:`evodevo.grn.ablations.ablations_stem`)."""
    if not (run / f"{stem}.csv").is_file():
        return []
    plt = pyplot()
    rows = [r for r in run.read_csv(f"{stem}.csv") if r["ablation"] != "intact"]
    names = [r["ablation"] for r in rows]
    change = 100 * _col(rows, "change")
    lo = 100 * _col(rows, "change_ci_low")
    hi = 100 * _col(rows, "change_ci_high")
    fig, ax = plt.subplots(figsize=(6, 3.5))
    y = np.arange(len(names))
    ax.barh(y, change, color=["tab:red" if c < 0 else "tab:blue" for c in change])
    ax.errorbar(change, y, xerr=[change - lo, hi - change], fmt="none", ecolor="k", capsize=3)
    ax.set_yticks(y, names, fontsize=8)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlabel("change in test success vs intact genome (points, 95 % CI)")
    fig.tight_layout()
    p = out / f"{stem}.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return [p]


def plot_trace(run: RunDir, out: Path) -> list[Path]:
    """Expression of every gene over one test episode, and the actions."""
    if not (run / TRACE_FILE).is_file():
        return []
    arrays, meta = load_arrays(run / TRACE_FILE, "grn_trace")
    x, actions = arrays["x"], arrays["actions"]
    if x.size == 0:
        return []
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    steps = np.arange(1, x.shape[0] + 1)
    a1.plot(steps, x, lw=0.8, alpha=0.7)
    a1.set_ylabel("expression x_i")
    a1.set_ylim(-0.02, 1.02)
    outcome = "success" if meta.get("success") else "failure"
    a1.set_title(f"gene expression, test episode {meta.get('index')} ({outcome})", fontsize=9)
    for j, name in enumerate(["dx", "dy", "d-angle", "a4"][: actions.shape[1]]):
        a2.plot(steps, actions[:, j], "o-", label=name)
    a2.set_xlabel("env step")
    a2.set_ylabel("action")
    a2.legend(fontsize=8)
    fig.tight_layout()
    p = out / "expression_trace.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return [p]


def plot_modulator_trace(run: RunDir, out: Path) -> list[Path]:
    """Modulator states m_DA, m_5HT, m_NE, m_ACh, gene expression and actions of one episode."""
    if not (run / MODULATOR_TRACE_FILE).is_file():
        return []
    arrays, meta = load_arrays(run / MODULATOR_TRACE_FILE, "grn_modulator_trace")
    m, x, actions = arrays["m"], arrays["x"], arrays["actions"]
    plt = pyplot()
    fig, (a0, a1, a2) = plt.subplots(3, 1, figsize=(6, 7), sharex=True)
    steps = np.arange(1, m.shape[0] + 1)
    gamma = meta.get("gamma", [float("nan")] * 4)
    for j, name in enumerate(meta.get("modulators", ["DA", "5HT", "NE", "ACh"])):
        a0.plot(steps, m[:, j], lw=1.5, label=f"{name} (gamma {gamma[j]:+.2f})")
    a0.axhline(0.5, color="k", lw=0.6, ls=":")
    a0.set_ylabel("modulator state")
    a0.legend(fontsize=7, ncol=2)
    outcome = "success" if meta.get("success") else "failure"
    a0.set_title(
        f"neuromodulated GRN, {meta.get('objects')} episode {meta.get('index')} "
        f"({outcome}, return {meta.get('reward', float('nan')):.3g})",
        fontsize=9,
    )
    a1.plot(steps, x, lw=0.7, alpha=0.7)
    a1.set_ylabel("expression x_i")
    a1.set_ylim(-0.02, 1.02)
    for j in range(actions.shape[1]):
        a2.plot(steps, actions[:, j], lw=1.0, label=f"a{j}")
    a2.set_xlabel("env step")
    a2.set_ylabel("action")
    a2.legend(fontsize=7)
    fig.tight_layout()
    p = out / "modulator_trace.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return [p]


def plot_run(path: str | Path) -> list[Path]:
    """Draw every figure whose data exists into ``DIR/figures``; returns the files written."""
    run = RunDir(path, create=False)
    out = run.path / "figures"
    out.mkdir(exist_ok=True)
    paths: list[Path] = []
    for fn in (
        plot_history,
        plot_heatmap,
        plot_rolling,
        plot_ablations,
        plot_trace,
        plot_modulator_trace,
    ):
        paths += fn(run, out)
    return paths
