"""Exploration behind search_surrogate.py (issue 22, second round): read-outs and operators that
are *not* package options, patched into the controller here. Run from the repo root:
``python docs/results/grn_vision/surrogate_variants.py NAME 'JSON options' SEEDS``; appends one line
to runs/surr/results.jsonl. Options: readout tanh|centred (tanh(W_m^T (x - x0)))|pair
(tanh(sum_i W_m[i] (x_i - x_{i+n/2}))); reset (restart from x0 each control step); noprop /
propmask (zero / scale proprioception); mut thesis|logsigma (per-offspring sigma x 10^U(lo, 0))|
sparse (each entry with probability pe); wm_density; pop, eps, gens (the old preset: 12, 6, 10,
sigma 0.2); over (config overrides). Measured rows: docs/results/history.md, "Why the search stalled".
"""

import json
import sys
import time

import numpy as np

from evodevo.config import load_config
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.dynamics import expression_step
from evodevo.grn.mutation import clip_to_bounds, mutate_genome
from evodevo.grn.selection import rank, tournament
from evodevo.grn.vision_preset import vision_preset

WX, WY = (0.50, 0.65), (-0.17, 0.22)


class Ctrl(PlainGrnController):
    readout = "tanh"
    reset = False

    def step(self, state, idx, features, proprio, rngs, noisy):
        g = state.genome
        n = state.x.shape[1]
        s, eta = self.sense(g.P[idx], n, features, proprio, rngs, noisy)
        x = state.x[idx] if not self.reset else np.full_like(state.x[idx], self.dyn.x0)
        for k in range(self.dyn.substeps):
            if k:
                eta = self.expression_noise(rngs, n)
            x = expression_step(
                x,
                s,
                g.W_s[idx],
                g.W_r[idx],
                g.theta[idx],
                g.delta[idx],
                g.alpha[idx],
                self.dyn.dt,
                eta,
            )
        state.x[idx] = x
        W = g.W_m[idx]
        if self.readout == "tanh":
            return np.tanh(np.einsum("bi,bia->ba", x, W))
        if self.readout == "pair":  # a = tanh(sum_i W_m[i] (x_i - x_{i+n/2})) over gene pairs
            h = n // 2
            return np.tanh(np.einsum("bi,bia->ba", x[:, :h] - x[:, h : 2 * h], W[:, :h]))
        if self.readout == "centred":
            return np.tanh(np.einsum("bi,bia->ba", x - self.dyn.x0, W))
        raise ValueError


def run(ctrl, genomes, targets, rng_seed=0):
    B = len(genomes) * len(targets)
    t = np.tile(targets, (len(genomes), 1))
    st = ctrl.reset_state([g for g in genomes for _ in targets])
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
        if getattr(ctrl, "noprop", False):
            prop = prop * 0
        if getattr(ctrl, "propmask", None) is not None:
            prop = prop * np.asarray(ctrl.propmask)
        a = ctrl.step(st, np.arange(B), feats, prop, rngs, np.zeros(B, bool))
        ee = ee + 0.06 * np.clip(a[:, :2], -1, 1)
        ee[:, 0] = np.clip(ee[:, 0], *WX)
        ee[:, 1] = np.clip(ee[:, 1], *WY)
    return np.hypot(*(ee - t).T).reshape(len(genomes), len(targets))


def mutate(ctrl, g, rng, opt):
    cfg = ctrl.config
    mode = opt.get("mut", "thesis")
    if mode == "thesis":
        return mutate_genome(g, cfg, rng)
    if mode == "logsigma":  # per-offspring sigma = sigma * 10^U(lo, 0)
        s = cfg.mutation.sigma * 10 ** rng.uniform(opt.get("lo", -1.5), 0)
        old = cfg.mutation.sigma
        cfg.mutation.sigma = s
        try:
            return mutate_genome(g, cfg, rng)
        finally:
            cfg.mutation.sigma = old
    if mode == "sparse":  # each entry of a chosen matrix with prob pe
        child = g.copy()
        m = cfg.mutation
        pe = opt["pe"]
        if rng.random() < m.p_struct:
            n = child.W_r.shape[0]
            k, i = rng.integers(n), rng.integers(n)
            child.W_r[k, i] = 0.0 if child.W_r[k, i] != 0 else rng.normal(0, m.struct_std)
        for name in ("W_s", "W_r", "W_m", "P"):
            if rng.random() < m.p_weight:
                w = getattr(child, name)
                mask = rng.random(w.shape) < pe
                if name == "W_r" or (name == "W_m" and opt.get("wm_present")):
                    mask &= w != 0
                w[mask] += rng.normal(0, m.sigma, w.shape)[mask]
        for name in ("theta", "delta", "alpha"):
            if rng.random() < m.p_param:
                v = getattr(child, name)
                mask = rng.random(v.shape) < pe
                v[mask] += rng.normal(0, m.sigma, v.shape)[mask]
        return clip_to_bounds(child, cfg)
    raise ValueError(mode)


def evolve(opt, seed):
    over = vision_preset()
    over["evaluation"] = {}
    # pin the first vision preset (these rows were measured before restart/proprio existed)
    over["dynamics"] = {**over["dynamics"], "restart": False}
    over["sensors"] = {**over["sensors"], "proprio": True}
    over["mutation"] = {**over["mutation"], "sigma": 0.2}
    for k, v in opt.get("over", {}).items():
        over.setdefault(k, {})
        over[k] = {**over[k], **v}
    cfg = load_config(GrnConfig, None, over)
    ctrl = Ctrl(cfg, 3)
    ctrl.readout = opt.get("readout", "tanh")
    ctrl.reset = opt.get("reset", False)
    ctrl.noprop = opt.get("noprop", False)
    ctrl.propmask = opt.get("propmask")
    pop, gens, n_eps = opt.get("pop", 12), opt.get("gens", 10), opt.get("eps", 6)
    elites = opt.get("elites", max(1, pop // 4))
    rng = np.random.default_rng(seed)
    popu = [ctrl.init_genome(rng) for _ in range(pop)]
    if opt.get("wm_density"):
        for gg in popu:
            gg.W_m *= rng.random(gg.W_m.shape) < opt["wm_density"]
    trng = np.random.default_rng(seed + 100)
    test_t = np.stack(
        [
            np.random.default_rng(7).uniform(0.5, 0.65, 100),
            np.random.default_rng(8).uniform(-0.13, 0.13, 100),
        ],
        1,
    )
    for _g in range(gens):
        targets = np.stack([trng.uniform(0.5, 0.65, n_eps), trng.uniform(-0.13, 0.13, n_eps)], 1)
        dist = run(ctrl, popu, targets)
        fit = -np.minimum(dist, 0.2).mean(1) / 0.05
        order = rank(fit)
        best = popu[int(order[0])]
        popu = [popu[i] for i in order[:elites]] + [
            mutate(ctrl, popu[tournament(fit, 3, rng)], rng, opt) for _ in range(pop - elites)
        ]
    td = run(ctrl, [best], test_t)[0]
    return round(float(np.median(td)) * 100, 2), round(float((td < 0.02).mean()), 2)


if __name__ == "__main__":
    name = sys.argv[1]
    opt = json.loads(sys.argv[2])
    seeds = range(int(sys.argv[3]) if len(sys.argv) > 3 else 3)
    t0 = time.time()
    res = [evolve(opt, s) for s in seeds]
    med = [r[0] for r in res]
    w2 = [r[1] for r in res]
    line = {
        "name": name,
        "opt": opt,
        "median_cm": med,
        "within2cm": w2,
        "mean_median": round(float(np.mean(med)), 2),
        "s": round(time.time() - t0),
    }
    print(json.dumps(line), flush=True)
    import os

    os.makedirs("runs/surr", exist_ok=True)
    with open("runs/surr/results.jsonl", "a") as f:
        f.write(json.dumps(line) + "\n")
