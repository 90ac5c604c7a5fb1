"""The BIARM grids of one budget under different DQN protocols, side by side (SPEC §1.6-1.7).

A budget trains its variants under ``biarm.protocol`` in ``biarm/`` and under each of
``biarm.other_protocols`` in its own folder (e.g. ``biarm_v1/``). :func:`protocol_table`
reads the finished runs of every grid and writes, per task, PNN's and BIARM's final greedy
return (mean [bootstrap 95 % CI] over seeds) under each protocol beside the thesis' Table 3.2,
and BIARM − PNN paired by seed (mean difference, exact sign-flip p over the shared seeds).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from evodevo.errors import EvodevoError
from evodevo.neuromod.compare import collect
from evodevo.neuromod.thesis_numbers import TABLE_3_2
from evodevo.reproduce.budget import ReproduceConfig
from evodevo.stats import permutation_test, summarise

__all__ = ["protocol_table", "grids"]


def grids(cfg: ReproduceConfig) -> list[tuple[str, str]]:
    """``(folder, protocol)`` of every BIARM grid of a budget, the main one first."""
    b = cfg.biarm
    return [("biarm", b.protocol), *b.other_protocols.items()]


def _finals(runs: dict[str, dict[int, dict[str, Any]]], variant: str, env: str) -> dict[int, float]:
    out: dict[int, float] = {}
    for seed, s in runs.get(variant, {}).items():
        for t in s["tasks"]:
            if t["env_id"] == env:
                out[int(seed)] = float(t["final_return"])
    return out


def _cell(values: dict[int, float]) -> str:
    if not values:
        return "–"
    m = summarise(list(values.values()))
    return f"{m.mean:.1f} [{m.ci_low:.1f}, {m.ci_high:.1f}] (n={m.n})"


def _diff(biarm: dict[int, float], pnn: dict[int, float]) -> str:
    seeds = sorted(set(biarm) & set(pnn))
    if len(seeds) < 2:
        return "–"
    d = [biarm[s] - pnn[s] for s in seeds]
    p = permutation_test([biarm[s] for s in seeds], [pnn[s] for s in seeds], paired=True)
    return f"{sum(d) / len(d):+.1f} (p = {p:.2g}; higher on {sum(x > 0 for x in d)}/{len(d)} seeds)"


def protocol_table(out: Path, cfg: ReproduceConfig) -> list[str]:
    """Markdown lines of the side-by-side table (empty when fewer than two grids ran)."""
    found: list[tuple[str, str, dict[str, dict[int, dict[str, Any]]]]] = []
    for folder, protocol in grids(cfg):
        try:
            found.append((folder, protocol, collect(out / folder)))
        except EvodevoError:
            continue
    if len(found) < 2:
        return []
    envs: list[str] = []
    for _, _, runs in found:
        for seeds in runs.values():
            for s in seeds.values():
                envs += [t["env_id"] for t in s["tasks"] if t["env_id"] not in envs]
    header = ["task", "protocol (folder)", "PNN", "BIARM", "BIARM − PNN (paired)"]
    rows = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for env in envs:
        thesis = TABLE_3_2.get(env)
        if thesis:
            rows.append(
                f"| {env} | thesis (Table 3.2) | {thesis['pnn'][0]:.1f} | "
                f"{thesis['biarm'][0]:.1f} | {thesis['biarm'][0] - thesis['pnn'][0]:+.1f} |"
            )
        for folder, protocol, runs in found:
            pnn, biarm = _finals(runs, "pnn", env), _finals(runs, "biarm", env)
            rows.append(
                f"| {env} | `{protocol}` ({folder}/) | {_cell(pnn)} | {_cell(biarm)} | "
                f"{_diff(biarm, pnn)} |"
            )
    return [
        "### The DQN protocols side by side (SPEC §1.6)",
        "",
        "Final greedy return per task, mean [bootstrap 95 % CI] over seeds, on the SPEC §1.7 "
        "evaluation seeds; BIARM − PNN is paired by seed (exact sign-flip test over seeds). "
        "`v1`: ε × 0.995 per episode, hard target copy every 500 gradient steps, the last "
        "network, unscaled Xavier laterals, and MountainCar's padded inputs left stale (the "
        "padding bug); `v2`: ε × 0.995 per environment step, soft target (τ 0.005), the column "
        "that scored best on 10 validation episodes (its runs also had the padding bug); "
        "`scaled`: v2 with the earlier columns' activations × 0.0001 where a new column's "
        "zero-initialised laterals read them, Eq. 3.7 relative to the modules' resting state, "
        "and zero padding; `v3`: `scaled` with 20 validation episodes per check instead "
        "of 10; `default`: `v3` with CartPole's gradient norm clipped at 1 instead of 10 "
        "(docs/results/biarm.md).",
        "",
        *rows,
        "",
    ]
