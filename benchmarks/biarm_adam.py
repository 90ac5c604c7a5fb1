"""The Adam step of a BIARM column: ``Adam(fused=True).step()`` against one direct call of the
fused kernel (:func:`evodevo.neuromod.flat_params.adam_step`; same numbers bit for bit).

For each task's BIARM column (its trainable parameters in one flat buffer, as in training) it
times blocks of steps of both, interleaved, and reports the medians and their ratio, plus the
share of one whole DQN gradient step (:meth:`BiarmAgent.update` on a filled replay buffer) that
the ``step()`` path's Python dispatch took. Run: ``python benchmarks/biarm_adam.py [--json]``.
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import time
from typing import Any

import numpy as np
import torch

from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.flat_params import adam_step
from evodevo.neuromod.replay import ReplayBuffer
from evodevo.neuromod.variants import get_variant

ACTIONS = (2, 3, 3, 4)  # CartPole, Acrobot, MountainCar, LunarLander


def _block(fn: Any, n: int) -> float:
    t = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t) / n * 1e6


def run(quick: bool = False) -> dict[str, Any]:
    torch.set_num_threads(1)
    blocks, per = (5, 100) if quick else (15, 200)
    agent = BiarmAgent(BiarmConfig(), get_variant("biarm"), 8, 0)
    out: dict[str, Any] = {"tasks": []}
    for a in ACTIONS:
        agent.begin_task(a)
        opt, lr = agent.optimizer, agent.cfg.dqn.lr
        assert opt is not None and agent.flat is not None
        agent.flat.grad.normal_(0.0, 1e-3)
        t_step, t_direct = [], []
        for _ in range(blocks):
            t_step.append(_block(opt.step, per))
            t_direct.append(_block(functools.partial(adam_step, opt, lr), per))
        buf = ReplayBuffer(1000, 8)
        rng = np.random.default_rng(1)
        for _ in range(1000):
            buf.add(rng.normal(size=8), int(rng.integers(a)), 0.0, rng.normal(size=8), False, 0.0)
        update = statistics.median(
            _block(lambda b=buf, r=rng: agent.update(b.sample(r, 64)), per // 2)
            for _ in range(blocks // 3 + 1)
        )
        step, direct = statistics.median(t_step), statistics.median(t_direct)
        out["tasks"].append({
            "params": agent.flat.param.numel(), "step_us": round(step, 1),
            "direct_us": round(direct, 1), "ratio": round(direct / step, 3),
            "update_us": round(update, 1),
            "saved_share_of_update": round((step - direct) / (update + step - direct), 3),
        })  # fmt: skip
    out["ratio"] = round(statistics.mean(t["ratio"] for t in out["tasks"]), 3)
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    res = run(args.quick)
    print(json.dumps(res) if args.json else json.dumps(res, indent=1))
