"""Does a grasp-like noisy success hide the reach from selection? The reach surrogate with luck.

Issue 22, third round (docs/results/history.md, "Selection under a noisy success"). On the real env
the preset's evolutions end with rough, offset reach maps (67.8 % pooled), while on the
kinematic surrogate (``search_surrogate.py``, fitness = the reach distance alone) the same
config finds accurate ones (0.65 cm). The surrogate here adds what the real env's fitness has:
each episode succeeds with probability

    p(d) = P_FAR + (P_NEAR - P_FAR) * exp(-(d / D_SCALE)^2),   d = final reach distance,

(P_NEAR 0.85 ~ the scripted pipeline's 82.5 % with the localiser's ~1.5 cm error; P_FAR 0.45 ~
the constant actions' 35-57 %), reward = success, and selection fitness = Eq. 4.6 of the package
(``fitness_matrix``) minus ``distance_weight`` x ``distance_penalty`` (the preset's shaping),
exactly as ``Evolution.step`` scores real episodes; common random numbers: every genome sees the
same targets *and the same uniform draws* for its success coin in a generation. Score: the last
generation's best genome on 100 fixed targets, median distance (cm) and expected success
(mean p(d)).

Run: ``python docs/results/grn_vision/noisy_surrogate.py [ROW ...] [--seeds N] [--first-seed S]``
(a few seconds per row and seed on one core; lines appended to ``noisy_surrogate.jsonl``).
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from search_surrogate import _merge, distance_score, evolve_best, reach

from evodevo.grn.fitness import distance_penalty, fitness_matrix

P_NEAR, P_FAR, D_SCALE = 0.85, 0.45, 0.03


def p_success(d: np.ndarray) -> np.ndarray:
    return P_FAR + (P_NEAR - P_FAR) * np.exp(-((d / D_SCALE) ** 2))


def _budget(pop: int, eps: int, gens: int) -> dict[str, Any]:
    return {"evolution": {"population": pop, "generations": gens}, "evaluation": {"episodes": eps}}


#: Every row: the preset + overrides; ``noise: False`` scores by distance alone (as before).
ROWS: dict[str, dict[str, Any]] = {
    "distance only (the earlier surrogate)": {"noise": False},
    "preset: success + 1.0 x distance": {},
    "success only (no shaping)": {"evaluation": {"distance_weight": 0.0}},
    "success + 3 x distance": {"evaluation": {"distance_weight": 3.0}},
    "success + 10 x distance": {"evaluation": {"distance_weight": 10.0}},
    "preset, 12 x 20 x 7 (1680)": _budget(12, 20, 7),
    "preset, 24 x 5 x 15 (1800)": _budget(24, 5, 15),
    "preset, 36 x 5 x 10 (1800)": _budget(36, 5, 10),
    "preset, 24 x 4 x 18 (1728)": _budget(24, 4, 18),
    "preset, 48 x 3 x 12 (1728)": _budget(48, 3, 12),
    "preset, 24 x 3 x 25 (1800)": _budget(24, 3, 25),
    "24 x 4 x 18, 3 x distance": _merge(
        _budget(24, 4, 18), {"evaluation": {"distance_weight": 3.0}}
    ),
    "preset, 2 x budget (12 x 10 x 30)": _budget(12, 10, 30),
    "24 x 5 x 30 (2 x budget)": _budget(24, 5, 30),
    "3 x distance, 2 x budget": _merge(
        {"evaluation": {"distance_weight": 3.0}}, _budget(12, 10, 30)
    ),
    # 2026-12-05: selection pressure (the real env's vision8_t5 config)
    "preset, tournament 5": {"evolution": {"tournament": 5}},
    "preset, tournament 2": {"evolution": {"tournament": 2}},
    "preset, 1 elite": {"evolution": {"elite_fraction": 0.09}},
    "preset, tournament 5, 1 elite": {"evolution": {"tournament": 5, "elite_fraction": 0.09}},
    # 2026-12-06: a mutation step per block (mutation.block_sigma / block_p)
    "W_s, W_m sigma 0.3": {"mutation": {"block_sigma": {"W_s": 0.3, "W_m": 0.3}}},
    "W_s, W_m sigma 0.2, p 1": {
        "mutation": {"block_sigma": {"W_s": 0.2, "W_m": 0.2}, "block_p": {"W_s": 1.0, "W_m": 1.0}}
    },
    "W_r, theta, delta, alpha sigma 0.03": {
        "mutation": {"block_sigma": {"W_r": 0.03, "theta": 0.03, "delta": 0.03, "alpha": 0.03}}
    },
    "W_r, P sigma 0": {"mutation": {"block_p": {"W_r": 0.0, "P": 0.0}}},
    "W_s, W_m sigma 0.05": {"mutation": {"block_sigma": {"W_s": 0.05, "W_m": 0.05}}},
}


def noisy_score(
    cfg: Any, ctrl: Any, pop: list[Any], targets: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Eq. 4.6 on coin-flip successes p(d) minus the preset's distance shaping (module doc)."""
    d = reach(ctrl, pop, targets)
    coin = rng.uniform(size=len(targets))  # common random numbers across genomes
    succ = (coin[None, :] < p_success(d)).astype(float)
    weight = cfg.evaluation.distance_weight
    return np.asarray(fitness_matrix(succ, succ.astype(bool)) - weight * distance_penalty(d))


def evolve(over: dict[str, Any], seed: int) -> tuple[float, float]:
    over = copy.deepcopy(over)
    noisy = over.pop("noise", True)
    ctrl, best, test = evolve_best(over, seed, noisy_score if noisy else distance_score)
    dt = reach(ctrl, [best], test)[0]
    return round(float(np.median(dt)) * 100, 2), round(float(p_success(dt).mean()), 3)


def run_rows(
    rows: dict[str, dict[str, Any]], names: list[str], evolve_fn: Any, seeds: range, out: Path
) -> None:
    """Print one Markdown row per name (``evolve_fn(row, seed)`` → (median cm, expected
    success) per seed) and append it to the JSON lines file ``out``."""
    print("| variant | median final distance per seed (cm) | mean | expected success, mean |")
    print("|---|---|---|---|")
    for name in names or list(rows):
        t0 = time.time()
        res = [evolve_fn(rows[name], s) for s in seeds]
        med, ps = [r[0] for r in res], [r[1] for r in res]
        print(
            f"| {name} | {', '.join(f'{m:.2f}' for m in med)} | {np.mean(med):.2f} | "
            f"{np.mean(ps):.3f} |",
            flush=True,
        )
        with open(out, "a") as fh:
            fh.write(json.dumps({"row": name, "seeds": list(seeds), "median_cm": med, "p_success": ps,
                                 "s": round(time.time() - t0)}) + "\n")  # fmt: skip


def rows_cli(
    doc: str, rows: dict[str, dict[str, Any]], evolve_fn: Any, out: Path, seeds: int, first: int
) -> None:
    """The command line of a surrogate script: ``[ROW ...] [--seeds N] [--first-seed S]``."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("rows", nargs="*", help="row names (default: all)")
    ap.add_argument("--seeds", type=int, default=seeds)
    ap.add_argument("--first-seed", type=int, default=first)
    args = ap.parse_args()
    run_rows(rows, args.rows, evolve_fn, range(args.first_seed, args.first_seed + args.seeds), out)


def main() -> None:
    rows_cli(__doc__, ROWS, evolve, Path(__file__).with_name("noisy_surrogate.jsonl"), 10, 0)


if __name__ == "__main__":
    main()
