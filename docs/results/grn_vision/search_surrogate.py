"""Which change lets evolution find an accurate reaching map? The kinematic reach surrogate.

Issue 22, second round (docs/results/history.md, "Why the search stalled"). Same surrogate as
``reach_surrogate.py`` (a target drawn in the tray; the GRN reads the blob features
[dx, dy, size = 0.5, found = 1] and proprioception [x, y, z, angle]; the gripper moves 0.06 m per
unit action for 7 steps, clamped to the workspace; no physics, no grasp, no objects), but every
row is a full config — the preset plus overrides, including population, episodes and
generations — run through the package's own controller, mutation and selection (elites and
tournament of Algorithm 3). Selection fitness: −mean over the generation's episodes of
min(d, 20 cm) / 5 cm, d = final distance. Score: the last generation's best genome on 100 fixed
targets — median final distance (cm) and the fraction within 2 cm.

Run: ``python docs/results/grn_vision/search_surrogate.py [ROW ...] [--seeds N]``
(a few seconds per row and seed on one core).
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from typing import Any

import numpy as np

from evodevo.config import load_config
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.selection import rank, tournament
from evodevo.grn.vision_preset import vision_preset

WX, WY = (0.50, 0.65), (-0.17, 0.22)  # end-effector workspace clamp of the env (m)
TX, TY = (0.50, 0.65), (-0.13, 0.13)  # where targets are drawn (the tray)
START = (0.532, -0.001)  # end-effector start position

#: The first vision preset (commit 3d247aa): dt 0.1 x 10 substeps, ws_std 1, p_weight 0.5,
#: sigma 0.2, 12 genomes x 6 episodes x 10 generations, memory between control steps,
#: proprioception read.
OLD = {
    "dynamics": {"restart": False},
    "sensors": {"proprio": True},
    "mutation": {"sigma": 0.2},
    "evolution": {"generations": 10},
    "evaluation": {"episodes": 6},
}


def _merge(*overs: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for o in overs:
        for k, v in o.items():
            out[k] = {**out.get(k, {}), **v} if isinstance(v, dict) else v
    return out


def _budget(pop: int, eps: int, gens: int) -> dict[str, Any]:
    return {
        "evolution": {"population": pop, "generations": gens},
        "evaluation": {"episodes": eps},
    }


B720, B1800 = _budget(12, 6, 10), _budget(12, 10, 15)
MEM = {"dynamics": {"restart": False}, "sensors": {"proprio": True}}
ROWS: dict[str, dict[str, Any]] = {
    # the first preset and its budget variants
    "old preset (720)": OLD,
    "old preset, 12 x 10 x 15 (1800)": _merge(OLD, B1800),
    "old preset, sigma 0.1, 1800": _merge(OLD, B1800, {"mutation": {"sigma": 0.1}}),
    "old preset, 24 x 6 x 12 (1728)": _merge(OLD, _budget(24, 6, 12)),
    # one change at a time, at 1800 episodes, sigma 0.1
    "proprio off, 1800": _merge(MEM, B1800, {"sensors": {"proprio": False}}),
    "restart, 1800": _merge(MEM, B1800, {"dynamics": {"restart": True}}),
    # both (the new preset) and its neighbours
    "new preset (proprio off + restart, sigma 0.1, 1800)": {},
    "new preset, sigma 0.2": {"mutation": {"sigma": 0.2}},
    "new preset, sigma 0.05": {"mutation": {"sigma": 0.05}},
    "new preset, p_weight 0.2 (thesis)": {"mutation": {"p_weight": 0.2}},
    "new preset, ws_std 0.3 (thesis)": {"genome": {"ws_std": 0.3}},
    "new preset, 12 x 6 x 10 (720)": B720,
    "new preset, 12 x 6 x 25 (1800)": _budget(12, 6, 25),
    "new preset, 24 x 6 x 12 (1728)": _budget(24, 6, 12),
}


def reach(ctrl: Any, genomes: list[Any], targets: np.ndarray) -> np.ndarray:
    """Final distance (m), (len(genomes), len(targets)), of every genome on every target."""
    n_b = len(genomes) * len(targets)
    t = np.tile(targets, (len(genomes), 1))
    state = ctrl.reset_state([g for g in genomes for _ in targets])
    ee = np.tile(START, (n_b, 1))
    rngs = [np.random.default_rng(i) for i in range(n_b)]
    for k in range(7):
        d = np.clip((t - ee) / 0.06, -3, 3)
        feats = np.concatenate([d, np.full((n_b, 1), 0.5), np.ones((n_b, 1))], 1)
        prop = np.stack(
            [
                (ee[:, 0] - 0.575) / 0.075,
                (ee[:, 1] - 0.025) / 0.195,
                np.full(n_b, 0.88 - k * 0.27),
                np.ones(n_b),
            ],
            1,
        )
        a = ctrl.step(state, np.arange(n_b), feats, prop, rngs, np.zeros(n_b, bool))
        ee = ee + 0.06 * np.clip(a[:, :2], -1, 1)
        ee[:, 0] = np.clip(ee[:, 0], *WX)
        ee[:, 1] = np.clip(ee[:, 1], *WY)
    return np.asarray(np.hypot(*(ee - t).T)).reshape(len(genomes), len(targets))


def distance_score(
    cfg: Any, ctrl: Any, pop: list[Any], targets: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Selection fitness of this surrogate: −mean of min(d, 20 cm) / 5 cm per genome."""
    return -np.minimum(reach(ctrl, pop, targets), 0.2).mean(1) / 0.05


def mutation_only(ctrl: Any, pop: list[Any], fit: np.ndarray, evo: Any, rng: Any) -> list[Any]:
    """Algorithm 3's offspring: mutated copies of tournament-picked parents."""
    return [
        ctrl.mutate(pop[tournament(fit, evo.tournament, rng)], rng)
        for _ in range(evo.population - evo.elites)
    ]


def evolve_best(
    over: dict[str, Any], seed: int, score: Any = distance_score, breed: Any = mutation_only
) -> tuple[Any, Any, np.ndarray]:
    """Evolve with preset + ``over`` scored by ``score(cfg, ctrl, pop, targets, rng)`` (``rng``
    the generator the targets came from), offspring from ``breed(ctrl, pop, fit, evo, rng)``;
    (controller, last generation's best, 100 test targets)."""
    cfg = load_config(GrnConfig, None, _merge(vision_preset(), copy.deepcopy(over)))
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
        fit = score(cfg, ctrl, pop, targets, trng)
        order = rank(fit)
        best = pop[int(order[0])]
        pop = [pop[i] for i in order[: evo.elites]] + breed(ctrl, pop, fit, evo, rng)
    return ctrl, best, test


def evolve(over: dict[str, Any], seed: int) -> tuple[float, float]:
    """Evolve with preset + ``over``; (median final distance cm, fraction within 2 cm)."""
    ctrl, best, test = evolve_best(over, seed)
    d = reach(ctrl, [best], test)[0]
    return round(float(np.median(d)) * 100, 2), round(float((d < 0.02).mean()), 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", nargs="*", help="row names (default: all)")
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args()
    print(
        "| variant | median final distance per seed (cm) | mean | seeds ≤ 2 cm | within 2 cm, mean |"
    )
    print("|---|---|---|---|---|")
    for name in args.rows or list(ROWS):
        t0 = time.time()
        res = [evolve(ROWS[name], s) for s in range(args.seeds)]
        med = [r[0] for r in res]
        w2 = [r[1] for r in res]
        print(
            f"| {name} | {', '.join(f'{m:.2f}' for m in med)} | {np.mean(med):.2f} | "
            f"{sum(m <= 2 for m in med)}/{len(med)} | {np.mean(w2):.2f} |",
            flush=True,
        )
        with open("search_surrogate.jsonl", "a") as fh:
            fh.write(json.dumps({"row": name, "median_cm": med, "within2": w2,
                                 "s": round(time.time() - t0)}) + "\n")  # fmt: skip


if __name__ == "__main__":
    main()
