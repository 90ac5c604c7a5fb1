"""The GRN controller's share of the time of one environment step (SPEC §2.1–2.2).

Runs the plain GRN controller (encoder forward + projection + vectorised dynamics + motor
output) on ``evodevo/KukaDiverseObject-v0`` in one process with one thread, timing the
controller call and the ``env.step`` call separately (process CPU time and wall time), for a
single episode at a time (batch 1, the worst case for the controller's overhead) and for a
lockstep batch of 4 episodes (one encoder forward for all four).

Usage::

    python benchmarks/grn_step.py [--quick]

The last line of output is JSON: ``{"controller_share": controller_s / (controller_s + env_s),
...}`` for batch 1, with the batch-4 figures beside it.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

__all__ = ["run", "main"]


def _measure(batch: int, episodes: int, seed: int) -> dict[str, float]:
    from evodevo.grn.config import GrnConfig
    from evodevo.grn.controller import make_controller
    from evodevo.grn.encoder import Encoder
    from evodevo.grn.env_interface import make_env, proprio_of
    from evodevo.seeding import derive

    cfg = GrnConfig(seed=seed)
    envs = [make_env(cfg.env.id, cfg.env.kwargs) for _ in range(batch)]
    encoder = Encoder.from_seed(seed)
    ctrl = make_controller(cfg, 3)
    rng = np.random.default_rng(seed)
    timers = {"ctrl_cpu": 0.0, "ctrl_wall": 0.0, "env_cpu": 0.0, "env_wall": 0.0}
    steps = 0
    try:
        for rep in range(episodes // batch):
            genomes = [ctrl.init_genome(rng) for _ in range(batch)]
            obs, prop = [], []
            for b, env in enumerate(envs):
                o, info = env.reset(seed=derive(seed, rep, b))
                obs.append(o)
                prop.append(proprio_of(info, 4))
            obs_a, prop_a = np.stack(obs), np.stack(prop)
            state = ctrl.reset_state(genomes)
            rngs = [np.random.default_rng(derive(seed, rep, b, 1)) for b in range(batch)]
            active = np.ones(batch, bool)
            while active.any():
                idx = np.flatnonzero(active)
                c0, w0 = time.process_time(), time.perf_counter()
                feats = encoder.features(obs_a[idx])
                actions = ctrl.step(
                    state, idx, feats, prop_a[idx], [rngs[i] for i in idx], np.zeros(len(idx), bool)
                )
                timers["ctrl_cpu"] += time.process_time() - c0
                timers["ctrl_wall"] += time.perf_counter() - w0
                for j, b in enumerate(idx.tolist()):
                    c0, w0 = time.process_time(), time.perf_counter()
                    o, _, term, trunc, info = envs[b].step(actions[j].astype(np.float32))
                    timers["env_cpu"] += time.process_time() - c0
                    timers["env_wall"] += time.perf_counter() - w0
                    obs_a[b], prop_a[b] = o, proprio_of(info, 4)
                    steps += 1
                    if term or trunc:
                        active[b] = False
    finally:
        for env in envs:
            env.close()
    share = timers["ctrl_cpu"] / (timers["ctrl_cpu"] + timers["env_cpu"])
    return {
        "batch": batch,
        "env_steps": steps,
        "controller_ms_per_step": 1000 * timers["ctrl_cpu"] / steps,
        "env_ms_per_step": 1000 * timers["env_cpu"] / steps,
        "controller_share": share,
        "controller_share_wall": timers["ctrl_wall"] / (timers["ctrl_wall"] + timers["env_wall"]),
    }


def run(quick: bool = False) -> dict[str, Any]:
    """Measure batch 1 and batch 4; returns the result dict (``controller_share`` of batch 1)."""
    from evodevo.parallel import set_single_thread

    set_single_thread()
    episodes = 4 if quick else 16
    single = _measure(1, episodes, seed=0)
    batched = _measure(4, episodes, seed=0)
    return {
        "benchmark": "grn_step",
        "quick": quick,
        "controller_share": single["controller_share"],
        "single": single,
        "lockstep4": batched,
        "cpu_time": "process CPU time, one thread",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="4 episodes instead of 16")
    parser.add_argument("--json", action="store_true", help="(accepted; the last line is JSON)")
    args = parser.parse_args()
    res = run(args.quick)
    for key in ("single", "lockstep4"):
        r = res[key]
        print(
            f"batch {r['batch']}: controller {r['controller_ms_per_step']:.2f} ms/step, "
            f"env {r['env_ms_per_step']:.1f} ms/step, share {100 * r['controller_share']:.2f} %"
        )
    print(json.dumps(res))


if __name__ == "__main__":
    main()
