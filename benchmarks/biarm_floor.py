"""What BIARM's DQN update must cost over PNN's at the SPEC's sizes, against what ours costs.

For each task of the four-task sequence (the column of task i has i - 1 frozen predecessors),
with BIARM and PNN agents side by side in this one process:

* ``params``: trainable parameters of the column (what the gradient clip, Adam and the
  target copy touch every step), BIARM / PNN;
* ``flops``: matrix-product FLOPs of one update (online and target forward, frozen features,
  backward), counted by :class:`torch.utils.flop_counter.FlopCounterMode` on the autograd
  path, BIARM / PNN. This is the arithmetic the method itself asks for (SPEC §1.2: V and
  W_alpha map 128 -> r = 32, U maps r -> the layer width, also for the Q-head), not a
  property of our code;
* ``loss``: measured time of our loss-and-gradient call (the C++ TD update, or autograd when
  the kernels are not built), median of interleaved blocks, BIARM / PNN;
* ``update``: the same for the whole gradient step (loss, clip, Adam), BIARM / PNN.

``loss`` close to ``flops`` means the implementation adds no overhead of its own to what the
method needs; the remaining end-to-end overhead (``biarm_overhead.py``) is then the method's.

    python benchmarks/biarm_floor.py --json [--blocks 30]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

__all__ = ["measure", "run"]


def measure(blocks: int = 30, per_block: int = 40, seed: int = 0) -> dict[str, Any]:
    """Per-task ratios BIARM / PNN of parameters, FLOPs, loss time and update time."""
    import numpy as np
    from torch.utils.flop_counter import FlopCounterMode

    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import BiarmConfig
    from evodevo.neuromod.replay import ReplayBuffer
    from evodevo.neuromod.tasks import resolve_tasks
    from evodevo.neuromod.variants import get_variant

    cfg = BiarmConfig()
    specs, d_max = resolve_tasks(cfg)
    agents = {v: BiarmAgent(cfg, get_variant(v), d_max, seed=seed) for v in ("pnn", "biarm")}
    rng = np.random.default_rng(seed)
    out: dict[str, Any] = {}
    for spec in specs:
        buf = ReplayBuffer(cfg.dqn.replay_size, d_max)
        for _ in range(cfg.dqn.replay_size // 2):
            obs = rng.standard_normal(d_max).astype(np.float32)
            nobs = rng.standard_normal(d_max).astype(np.float32)
            buf.add(obs, int(rng.integers(spec.n_actions)), float(rng.standard_normal()), nobs,
                    False, 1.0)  # fmt: skip
        for a in agents.values():
            a.begin_task(spec.n_actions)
        params, flops = {}, {}
        for v, a in agents.items():
            assert a.flat is not None
            params[v] = a.flat.param.numel()
            counter = FlopCounterMode(display=False)
            with counter:
                a._loss_autograd(buf.sample(rng, cfg.dqn.batch_size)).backward()
            flops[v] = counter.get_total_flops()
            a.flat.zero_grad()
        loss_t: dict[str, list[float]] = {v: [] for v in agents}
        upd_t: dict[str, list[float]] = {v: [] for v in agents}
        for blk in range(blocks):
            order = list(agents) if blk % 2 == 0 else list(reversed(agents))
            for v in order:
                a = agents[v]
                loss_fn = a._loss_cpp if a._td_cpp is not None else a._loss_autograd
                batches = [buf.sample(rng, cfg.dqn.batch_size) for _ in range(per_block)]
                t0 = time.perf_counter()
                for b in batches:
                    loss_fn(b)
                loss_t[v].append((time.perf_counter() - t0) / per_block)
                t0 = time.perf_counter()
                for b in batches:
                    a.update(b)
                upd_t[v].append((time.perf_counter() - t0) / per_block)
        loss_us = {v: 1e6 * float(np.median(x)) for v, x in loss_t.items()}
        upd_us = {v: 1e6 * float(np.median(x)) for v, x in upd_t.items()}
        out[spec.env_id] = {
            "params": params["biarm"] / params["pnn"],
            "flops": flops["biarm"] / flops["pnn"],
            "loss": loss_us["biarm"] / loss_us["pnn"],
            "update": upd_us["biarm"] / upd_us["pnn"],
            "params_n": params,
            "mflops": {v: f / 1e6 for v, f in flops.items()},
            "loss_us": loss_us,
            "update_us": upd_us,
            "kernel": "cpp" if agents["biarm"]._td_cpp is not None else "autograd",
        }
    return {"per_task": out, "blocks": blocks, "updates_per_block": per_block}


def run(quick: bool = False) -> dict[str, Any]:
    """Suite entry point: fewer timing blocks when ``quick``."""
    from evodevo.parallel import set_single_thread

    set_single_thread()
    return measure(blocks=4 if quick else 30, per_block=20 if quick else 40)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    ap.add_argument("--blocks", type=int, default=30, help="interleaved timing blocks per task")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    from evodevo.parallel import set_single_thread

    set_single_thread()
    res = measure(args.blocks, seed=args.seed)
    for env_id, r in res["per_task"].items():
        print(
            f"{env_id:16s} params {r['params']:.3f}  flops {r['flops']:.3f}  "
            f"loss {r['loss']:.3f}  update {r['update']:.3f}  ({r['kernel']})"
        )
    if args.json:
        print(json.dumps(res))


if __name__ == "__main__":
    main()
