"""Kinematic surrogate of the Kuka reach (no physics, no grasp): how fast does a GRN learn to reach?

Used to choose the vision preset (issue 22; docs/results/grn.md). A target is drawn in the tray,
the GRN reads the blob features [dx, dy, size, found] and proprioception, the gripper moves
0.06 m per unit action for 7 steps (workspace clamp as in the env), and the selection criterion
is the final distance. Run: python docs/results/grn_vision/reach_surrogate.py
"""

import time

import numpy as np

from evodevo.config import load_config
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.selection import rank, tournament
from evodevo.grn.vision_preset import vision_preset

WX, WY = (0.50, 0.65), (-0.17, 0.22)


def run(ctrl, genomes, targets, rng_seed=0):
    B = len(genomes) * len(targets)
    gs = [g for g in genomes for _ in targets]
    t = np.tile(targets, (len(genomes), 1))
    st = ctrl.reset_state(gs)
    ee = np.tile([0.532, -0.001], (B, 1))
    rngs = [np.random.default_rng(rng_seed + i) for i in range(B)]
    for k in range(7):
        d = np.clip((t - ee) / 0.06, -3, 3)
        feats = np.concatenate([d, np.full((B, 1), 0.5), np.ones((B, 1))], 1)
        prop = np.stack(
            [
                (ee[:, 0] - 0.575) / 0.075,
                (ee[:, 1] - 0.025) / 0.195,
                np.full(B, 0.88 - k * 0.27),
                np.ones(B),
            ],
            1,
        )
        a = ctrl.step(st, np.arange(B), feats, prop, rngs, np.zeros(B, bool))
        ee = ee + 0.06 * np.clip(a[:, :2], -1, 1)
        ee[:, 0] = np.clip(ee[:, 0], *WX)
        ee[:, 1] = np.clip(ee[:, 1], *WY)
    dist = np.hypot(*(ee - t).T).reshape(len(genomes), len(targets))
    turn = a[:, 2].reshape(len(genomes), len(targets))
    return dist, turn


def evolve(over, gens=15, pop=12, n_eps=10, seed=0):
    cfg = load_config(GrnConfig, None, over)
    ctrl = PlainGrnController(cfg, 3)
    rng = np.random.default_rng(seed)
    popu = [ctrl.init_genome(rng) for _ in range(pop)]
    trng = np.random.default_rng(seed + 100)
    test_t = np.stack(
        [
            np.random.default_rng(7).uniform(0.5, 0.65, 100),
            np.random.default_rng(8).uniform(-0.13, 0.13, 100),
        ],
        1,
    )
    hist = []
    for _g in range(gens):
        targets = np.stack([trng.uniform(0.5, 0.65, n_eps), trng.uniform(-0.13, 0.13, n_eps)], 1)
        dist, turn = run(ctrl, popu, targets)
        fit = -np.minimum(dist, 0.2).mean(1) / 0.05
        order = rank(fit)
        best = popu[int(order[0])]
        td, tt = run(ctrl, [best], test_t)
        hist.append((round(float(np.median(td)) * 100, 2), round(float((td < 0.02).mean()), 2)))
        elites = [popu[i] for i in order[:3]]
        popu = elites + [ctrl.mutate(popu[tournament(fit, 3, rng)], rng) for _ in range(pop - 3)]
    return hist


base = vision_preset()
base["evaluation"] = {}
for name, dyn in [
    ("thesis dyn", {"dt": 0.05, "substeps": 1}),
    ("dt.05 s20", {"dt": 0.05, "substeps": 20}),
    ("dt.1 s20", {"dt": 0.1, "substeps": 20}),
    ("dt.2 s20", {"dt": 0.2, "substeps": 20}),
    ("dt.1 s5", {"dt": 0.1, "substeps": 5}),
]:
    over = {**base, "dynamics": dyn}
    t0 = time.time()
    res = [evolve(over, seed=s) for s in range(3)]
    print(
        name,
        [h[-1] for h in res],
        "gen5:",
        [h[4] for h in res],
        f"{time.time() - t0:.0f}s",
        flush=True,
    )
