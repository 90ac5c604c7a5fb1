"""Does recombination join an x map and a y map? Crossover on the noisy reach surrogate.

Issue 22, ninth session (docs/results/grn.md, "Crossover"). The real-env runs learn the map
from the target's x offset or the one from its y offset, rarely both; Algorithm 3 breeds by
mutation alone. Here a child is, with probability ``p_cross``, first a recombination of two
tournament-picked parents, then mutated as usual:

* ``gene``: uniform crossover gene by gene — gene k's sensor weights W_s[:, k], its regulatory
  row W_r[k, :], its motor weights W_m[k, :] and its theta, delta, alpha come from one parent;
* ``motor``: the child takes each action's motor column W_m[:, j] from either parent, the rest
  from the first.

Everything else is ``noisy_surrogate.py`` (its success model, its shaping, its score).
Run: ``python docs/results/grn_vision/crossover_surrogate.py [ROW ...] [--seeds N]
[--first-seed S]``; lines appended to ``crossover_surrogate.jsonl``.
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from noisy_surrogate import noisy_score, p_success
from search_surrogate import TX, TY, _merge, reach

from evodevo.config import load_config
from evodevo.grn.config import GrnConfig, vision_preset
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.selection import rank, tournament

ROWS: dict[str, dict[str, Any]] = {
    "preset (no crossover)": {"p_cross": 0.0},
    "gene crossover, p 0.5": {"p_cross": 0.5, "kind": "gene"},
    "gene crossover, p 1": {"p_cross": 1.0, "kind": "gene"},
    "motor-column crossover, p 0.5": {"p_cross": 0.5, "kind": "motor"},
}


def cross(a: Any, b: Any, kind: str, rng: np.random.Generator) -> Any:
    child = a.copy()
    if kind == "motor":
        take = rng.random(a.W_m.shape[1]) < 0.5
        child.W_m[:, take] = b.W_m[:, take]
        return child
    take = rng.random(a.n_genes) < 0.5
    child.W_s[:, take] = b.W_s[:, take]
    child.W_r[take, :] = b.W_r[take, :]
    child.W_m[take, :] = b.W_m[take, :]
    for name in ("theta", "delta", "alpha"):
        getattr(child, name)[take] = getattr(b, name)[take]
    return child


def evolve(row: dict[str, Any], seed: int) -> tuple[float, float]:
    row = copy.deepcopy(row)
    p_cross, kind = row.pop("p_cross"), row.pop("kind", "gene")
    cfg = load_config(GrnConfig, None, _merge(vision_preset(), row))
    ctrl = PlainGrnController(cfg, 3)
    evo = cfg.evolution
    rng = np.random.default_rng(seed)
    pop = [ctrl.init_genome(rng) for _ in range(evo.population)]
    trng = np.random.default_rng(seed + 100)
    test = np.stack(
        [np.random.default_rng(7).uniform(*TX, 100), np.random.default_rng(8).uniform(*TY, 100)], 1
    )
    n_eps = cfg.evaluation.episodes
    best = pop[0]
    for _ in range(evo.generations):
        targets = np.stack([trng.uniform(*TX, n_eps), trng.uniform(*TY, n_eps)], 1)
        fit = noisy_score(cfg, ctrl, pop, targets, trng)
        order = rank(fit)
        best = pop[int(order[0])]
        children = []
        for _ in range(evo.population - evo.elites):
            parent = pop[tournament(fit, evo.tournament, rng)]
            if rng.random() < p_cross:
                parent = cross(parent, pop[tournament(fit, evo.tournament, rng)], kind, rng)
            children.append(ctrl.mutate(parent, rng))
        pop = [pop[i] for i in order[: evo.elites]] + children
    d = reach(ctrl, [best], test)[0]
    return round(float(np.median(d)) * 100, 2), round(float(p_success(d).mean()), 3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", nargs="*", help="row names (default: all)")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=40)
    args = ap.parse_args()
    print("| variant | median final distance per seed (cm) | mean | expected success, mean |")
    print("|---|---|---|---|")
    out = Path(__file__).with_name("crossover_surrogate.jsonl")
    for name in args.rows or list(ROWS):
        t0 = time.time()
        seeds = range(args.first_seed, args.first_seed + args.seeds)
        res = [evolve(ROWS[name], s) for s in seeds]
        med, ps = [r[0] for r in res], [r[1] for r in res]
        print(
            f"| {name} | {', '.join(f'{m:.2f}' for m in med)} | {np.mean(med):.2f} | "
            f"{np.mean(ps):.3f} |",
            flush=True,
        )
        with open(out, "a") as fh:
            fh.write(json.dumps({"row": name, "seeds": list(seeds), "median_cm": med, "p_success": ps,
                                 "s": round(time.time() - t0)}) + "\n")  # fmt: skip


if __name__ == "__main__":
    main()
