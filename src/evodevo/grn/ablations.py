"""The nine ablations of SPEC §2.5 (thesis Section 4.7), applied to a run's best genome.

Each ablation changes the genome (or, for "no noise", the dynamics config) and is tested on the
same fixed test episodes as the intact genome. The table reports each success rate with its
Wilson interval, the change against the intact genome with a Newcombe (Wilson-score hybrid)
95 % interval, and the two-sided Fisher exact p-value.

>>> sorted(ABLATIONS)[:3]
['fewer_genes', 'no_decay', 'no_noise']
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.config import replace
from evodevo.errors import EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.evaluation import load_run, set_suffix, test_episodes
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.genome import GrnGenome
from evodevo.runs import atomic_write_text, write_json
from evodevo.seeding import np_rng
from evodevo.stats import fisher_exact, holm, mcnemar_exact, rate

__all__ = [
    "ABLATIONS",
    "ablate",
    "difference_interval",
    "run_ablations",
    "ablations_stem",
    "ABLATION_KEY",
]

ABLATION_KEY = 5
"""Seed stream of the random draws of the ablations (under the run seed)."""
UNIFORM_THETA = 0.5
"""Threshold of every gene in the "uniform thresholds" ablation (SPEC §2.5)."""
FEWER_GENES = 25
"""Genes kept (the first ones) in the "fewer genes" ablation (SPEC §2.5)."""

Ablation = Callable[[GrnGenome, Any, np.random.Generator], tuple[GrnGenome, Any]]


def _no_noise(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    return g.copy(), replace(cfg, dynamics=replace(cfg.dynamics, noise_std=0.0))


def _uniform_thresholds(
    g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator
) -> tuple[GrnGenome, Any]:
    h = g.copy()
    h.theta[:] = UNIFORM_THETA
    return h, cfg


def _no_regulation(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    h = g.copy()
    h.W_r[:] = 0.0
    return h, cfg


def _fewer_genes(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    k = min(FEWER_GENES, g.n_genes)
    h = GrnGenome(
        g.W_s[:, :k].copy(),
        g.W_r[:k, :k].copy(),
        g.W_m[:k].copy(),
        g.theta[:k].copy(),
        g.delta[:k].copy(),
        g.alpha[:k].copy(),
        g.P.copy(),
    )
    return h, cfg


def _random_sensors(
    g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator
) -> tuple[GrnGenome, Any]:
    h = g.copy()
    h.W_s = rng.normal(0.0, cfg.genome.ws_std, g.W_s.shape)
    return h, cfg


def _no_decay(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    h = g.copy()
    h.delta[:] = 0.0
    return h, cfg


def _random_motors(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    h = g.copy()
    h.W_m = rng.normal(0.0, cfg.genome.wm_std, g.W_m.shape)
    return h, cfg


def _random_matrix(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    h = g.copy()
    present = g.W_r != 0.0
    h.W_r = np.where(present, rng.normal(0.0, cfg.genome.wr_std, g.W_r.shape), 0.0)
    return h, cfg


def _no_sparsity(g: GrnGenome, cfg: GrnConfig, rng: np.random.Generator) -> tuple[GrnGenome, Any]:
    h = g.copy()
    h.W_r = rng.normal(0.0, cfg.genome.wr_std, g.W_r.shape)
    return h, cfg


ABLATIONS: dict[str, Ablation] = {
    "no_noise": _no_noise,
    "uniform_thresholds": _uniform_thresholds,
    "no_regulation": _no_regulation,
    "fewer_genes": _fewer_genes,
    "random_sensors": _random_sensors,
    "no_decay": _no_decay,
    "random_motors": _random_motors,
    "random_matrix": _random_matrix,
    "no_sparsity": _no_sparsity,
}
"""Name → function(genome, config, rng) returning the ablated (genome, config)."""


def ablate(
    genome: GrnGenome, name: str, config: GrnConfig, rng: np.random.Generator
) -> tuple[GrnGenome, Any]:
    """Apply ablation ``name``; the input genome is not changed."""
    if name not in ABLATIONS:
        raise EvodevoError(f"unknown ablation {name!r}; choose one of {sorted(ABLATIONS)}")
    return ABLATIONS[name](genome, config, rng)


def difference_interval(k1: int, n1: int, k2: int, n2: int) -> tuple[float, float]:
    """Newcombe's hybrid-score 95 % interval of p1 − p2 (from the two Wilson intervals)."""
    p1, p2 = k1 / n1, k2 / n2
    r1, r2 = rate(k1, n1), rate(k2, n2)
    d = p1 - p2
    lo = d - math.sqrt((p1 - r1.ci_low) ** 2 + (r2.ci_high - p2) ** 2)
    hi = d + math.sqrt((r1.ci_high - p1) ** 2 + (p2 - r2.ci_low) ** 2)
    return lo, hi


def run_ablations(
    path: str | Path,
    episodes: int | None = None,
    objects: str = "test",
    seed: int | None = None,
    workers: int = 1,
    overrides: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Evaluate the intact best genome and its nine ablations on the same test episodes.

    Writes ``ablations.csv``, ``ablations.md`` and ``ablations.json`` into the run directory;
    ``overrides`` (``--set``, ``evaluation.*`` and ``env.*`` only:
    :func:`~evodevo.grn.evaluation.test_overrides`) change the test, and the files get the
    suffix of :func:`~evodevo.grn.evaluation.set_suffix` (:func:`ablations_stem`).
    """
    loaded = load_run(path, overrides)
    if not isinstance(loaded.genome, GrnGenome):
        raise EvodevoError(
            f"ablations apply to GRN genomes; this run's controller is {loaded.kind!r}"
        )
    cfg = loaded.config
    n = int(episodes if episodes is not None else cfg.evaluation.test_episodes)
    if n < 1:
        raise EvodevoError(
            f"--test-episodes {n} must be at least 1 (the number of fixed test episodes)"
        )
    test_seed = int(seed if seed is not None else cfg.evaluation.test_seed)
    eps = test_episodes(test_seed, n, objects == "test")
    rows: list[dict[str, Any]] = []
    with Evaluator(cfg, loaded.encoder, workers=workers) as ev:
        full = ev.evaluate([loaded.genome], eps)
        s0 = full.success[0]
        k0 = int(s0.sum())
        rows.append(ablation_row("intact", k0, n, k0, n, s0, s0))
        for i, name in enumerate(ABLATIONS):
            genome, acfg = ablate(loaded.genome, name, cfg, np_rng(cfg.seed, ABLATION_KEY, i))
            res = ev.evaluate([genome], eps, config=acfg)
            rows.append(ablation_row(name, int(res.success.sum()), n, k0, n, res.success[0], s0))
    add_holm(rows)
    run = loaded.run
    stem = ablations_stem(overrides)
    run.write_csv(f"{stem}.csv", rows)
    meta: dict[str, Any] = {"objects": objects, "test_seed": test_seed}
    if overrides:
        meta["overrides"] = dict(overrides)
    write_json(run / f"{stem}.json", {**meta, "rows": rows})
    atomic_write_text(run / f"{stem}.md", ablations_markdown(rows, objects, test_seed))
    return rows


def ablations_stem(overrides: Mapping[str, Any] | None = None, kind: str = "ablations") -> str:
    """Base name of the ablation files: ``ablations`` (or ``modulator_ablations``), with the
    suffix of a test changed by ``--set``.

    >>> ablations_stem(), ablations_stem({"evaluation": {"max_steps": 4}})
    ('ablations', 'ablations_set-6ba60c9b')
    """
    return f"{kind}{set_suffix(overrides)}"


def ablation_row(
    name: str,
    k: int,
    n: int,
    k0: int,
    n0: int,
    succ: np.ndarray | None = None,
    succ0: np.ndarray | None = None,
) -> dict[str, Any]:
    """One ablation's row; with the per-episode successes (same episodes as intact) also the
    paired exact McNemar p."""
    r = rate(k, n)
    lo, hi = difference_interval(k, n, k0, n0)
    paired: dict[str, Any] = {}
    if succ is not None and succ0 is not None:
        a, i = np.asarray(succ, bool), np.asarray(succ0, bool)
        paired = {
            "mcnemar_p": mcnemar_exact(succ, succ0),
            # the discordant episodes, so that tables of several seeds can be pooled paired
            "only_ablated": int(np.sum(a & ~i)),
            "only_intact": int(np.sum(~a & i)),
        }
    return {
        "ablation": name,
        "successes": k,
        "episodes": n,
        "success_rate": r.rate,
        "ci_low": r.ci_low,
        "ci_high": r.ci_high,
        "change": r.rate - k0 / n0,
        "change_ci_low": lo,
        "change_ci_high": hi,
        "fisher_p": fisher_exact(k, n, k0, n0),
        **paired,
    }


def add_holm(rows: list[dict[str, Any]]) -> None:
    """``mcnemar_p_holm``: the McNemar p-values of the ablations (not of ``intact``) adjusted
    together (Holm), since one table tests many ablations on the same episodes."""
    idx = [i for i, r in enumerate(rows) if r["ablation"] != "intact" and "mcnemar_p" in r]
    for i, p in zip(idx, holm([rows[i]["mcnemar_p"] for i in idx]), strict=True):
        rows[i]["mcnemar_p_holm"] = p


def ablations_markdown(rows: list[dict[str, Any]], objects: str, test_seed: int) -> str:
    """The ablation table in Markdown."""
    lines = [
        f"Ablations of the best genome: {rows[0]['episodes']} episodes on {objects} objects, "
        f"test seed {test_seed}; change vs intact with Newcombe 95 % interval; Fisher exact p "
        "(unpaired); exact McNemar p on the same episodes (paired), and Holm-adjusted over the "
        "table's ablations.",
        "",
        "| ablation | success [95 % CI] | change [95 % CI] | Fisher p | McNemar p | McNemar p, Holm |",
        "|---|---|---|---|---|---|",
    ]

    def _p(r: dict[str, Any], key: str) -> str:
        return f"{r[key]:.3g}" if key in r else "—"

    for r in rows:
        lines.append(
            f"| {r['ablation']} | {100 * r['success_rate']:.1f} % "
            f"[{100 * r['ci_low']:.1f}, {100 * r['ci_high']:.1f}] | "
            f"{100 * r['change']:+.1f} [{100 * r['change_ci_low']:+.1f}, "
            f"{100 * r['change_ci_high']:+.1f}] | {r['fisher_p']:.3g} | {_p(r, 'mcnemar_p')} "
            f"| {_p(r, 'mcnemar_p_holm')} |"
        )
    return "\n".join(lines) + "\n"


__all__ += ["ablations_markdown", "add_holm", "ablation_row"]
