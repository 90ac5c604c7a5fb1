"""Trace of one surrogate evolution's best genome (docs/results/history.md, "Why the search stalled").

Run from the repo root: python docs/results/grn_vision/surrogate_trace.py '{"gens":40,"eps":10}' 0
"""

import json
import sys

import numpy as np

sys.path.insert(0, "docs/results/grn_vision")
import surrogate_variants as surr

from evodevo.config import load_config
from evodevo.grn.config import GrnConfig
from evodevo.grn.vision_preset import vision_preset

opt = json.loads(sys.argv[1])
seed = int(sys.argv[2])
# re-run evolve but keep best
best_holder = {}
orig_run = surr.run


def evolve_keep(opt, seed):
    over = vision_preset()
    over["evaluation"] = {}
    over["dynamics"] = {**over["dynamics"], "restart": False}
    over["sensors"] = {**over["sensors"], "proprio": True}
    over["mutation"] = {**over["mutation"], "sigma": 0.2}
    for k, v in opt.get("over", {}).items():
        over[k] = {**over.get(k, {}), **v}
    cfg = load_config(GrnConfig, None, over)
    ctrl = surr.Ctrl(cfg, 3)
    ctrl.readout = opt.get("readout", "tanh")
    ctrl.reset = opt.get("reset", False)
    pop, gens, n_eps = opt.get("pop", 12), opt.get("gens", 10), opt.get("eps", 6)
    rng = np.random.default_rng(seed)
    popu = [ctrl.init_genome(rng) for _ in range(pop)]
    trng = np.random.default_rng(seed + 100)
    for _g in range(gens):
        targets = np.stack([trng.uniform(0.5, 0.65, n_eps), trng.uniform(-0.13, 0.13, n_eps)], 1)
        dist = surr.run(ctrl, popu, targets)
        fit = -np.minimum(dist, 0.2).mean(1) / 0.05
        order = surr.rank(fit)
        best = popu[int(order[0])]
        popu = [popu[i] for i in order[:3]] + [
            surr.mutate(ctrl, popu[surr.tournament(fit, 3, rng)], rng, opt) for _ in range(pop - 3)
        ]
    return ctrl, best


ctrl, best = evolve_keep(opt, seed)
# trajectories
WX, WY = surr.WX, surr.WY
tg = np.array([[0.52, -0.1], [0.6, 0.0], [0.64, 0.1], [0.55, 0.05], [0.5, -0.001]])
B = len(tg)
st = ctrl.reset_state([best] * B)
ee = np.tile([0.532, -0.001], (B, 1))
rngs = [np.random.default_rng(i) for i in range(B)]
for k in range(7):
    d = np.clip((tg - ee) / 0.06, -3, 3)
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
    print(k, "d", np.round(d, 2).tolist(), "a", np.round(a[:, :2], 2).tolist())
    ee = ee + 0.06 * np.clip(a[:, :2], -1, 1)
print("final err cm", np.round(np.hypot(*(ee - tg).T) * 100, 2))
