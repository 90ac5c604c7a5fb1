"""BIARM vs PNN time per training step through the four-task sequence (SPEC §1.7, Table 3.3).

All agents run in this one process, interleaved episode by episode (the order alternates,
so that load drifts on a shared machine hit every agent alike), each for the same fixed number of
environment steps per task with one gradient step per environment step after
``learning_starts``. Time is process CPU time (robust to other load on a shared machine;
``ratio_wall`` gives the wall-clock ratio too); per-step means over all steps of all tasks. The last line of ``--json`` output is
``{"ratio": biarm_us / pnn_us, "ratio_adapter128": ..., ...}``; SPEC target: ratio <= 1.10.

    python benchmarks/biarm_overhead.py --json [--steps 2000]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

__all__ = ["run", "measure"]


def measure(steps: int, rounds: int = 1, learning: str = "fixed") -> dict[str, Any]:
    """Per-task and overall µs/step of pnn, biarm (r=32) and biarm (r=128)."""
    from evodevo.config import replace
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import BiarmConfig, ModuleConfig, NetworkConfig
    from evodevo.neuromod.tasks import resolve_tasks
    from evodevo.neuromod.trainer import TaskRunner, train_task
    from evodevo.neuromod.variants import get_variant

    base = BiarmConfig()
    base = replace(base, modules=ModuleConfig(learning=learning))  # type: ignore[arg-type]
    specs, d_max = resolve_tasks(base)
    configs = {
        "pnn": (base, "pnn"),
        "biarm": (base, "biarm"),
        "biarm_r128": (replace(base, network=NetworkConfig(adapter_dim=128)), "biarm"),
    }
    totals = {k: 0.0 for k in configs}
    walls = {k: 0.0 for k in configs}
    per_task: dict[str, list[float]] = {k: [0.0] * len(specs) for k in configs}
    # warm-up: first calls pay one-time costs (lazy imports, kernel set-up) that would
    # otherwise be charged to whichever agent happens to run first
    for c, v in configs.values():
        warm = BiarmAgent(c, get_variant(v), d_max, seed=99)
        for i, spec in enumerate(specs[:2]):
            train_task(warm, spec, i, 99, 0, None, None, max_env_steps=200)
    for rnd in range(rounds):
        agents = {
            k: BiarmAgent(c, get_variant(v), d_max, seed=rnd) for k, (c, v) in configs.items()
        }
        for i, spec in enumerate(specs):
            runners = {k: TaskRunner(a, spec, i, rnd) for k, a in agents.items()}
            turn = 0
            # one episode of each agent in turn (order alternating), so load drifts on a
            # shared machine hit all agents alike
            while any(r.task_steps < steps for r in runners.values()):
                order = list(runners) if turn % 2 == 0 else list(reversed(runners))
                turn += 1
                for k in order:
                    r = runners[k]
                    if r.task_steps >= steps:
                        continue
                    w0, t0 = time.perf_counter(), time.process_time()
                    r.episode(max_env_steps=steps)
                    dt = time.process_time() - t0
                    walls[k] += time.perf_counter() - w0
                    totals[k] += dt
                    per_task[k][i] += dt
            for r in runners.values():
                r.close()
    n = steps * len(specs) * rounds
    us = {k: 1e6 * v / n for k, v in totals.items()}
    return {
        "ratio": us["biarm"] / us["pnn"],
        "ratio_adapter128": us["biarm_r128"] / us["pnn"],
        "ratio_wall": walls["biarm"] / walls["pnn"],
        "ratio_adapter128_wall": walls["biarm_r128"] / walls["pnn"],
        "pnn_us_per_step": us["pnn"],
        "biarm_us_per_step": us["biarm"],
        "biarm_r128_us_per_step": us["biarm_r128"],
        "per_task_ratio": {
            s.env_id: per_task["biarm"][i] / per_task["pnn"][i] for i, s in enumerate(specs)
        },
        "per_task_ratio_adapter128": {
            s.env_id: per_task["biarm_r128"][i] / per_task["pnn"][i] for i, s in enumerate(specs)
        },
        "steps_per_task": steps,
        "rounds": rounds,
        "module_learning": learning,
    }


def run(quick: bool = False) -> dict[str, Any]:
    """Suite entry point: a short measurement when ``quick``."""
    from evodevo.parallel import set_single_thread

    set_single_thread()
    return measure(steps=400 if quick else 2000, rounds=1 if quick else 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    ap.add_argument("--steps", type=int, default=2000, help="environment steps per task")
    ap.add_argument("--rounds", type=int, default=2, help="repetitions with fresh agents")
    ap.add_argument("--learning", default="fixed", choices=["fixed", "learned"])
    args = ap.parse_args()
    from evodevo.parallel import set_single_thread

    set_single_thread()
    res = measure(args.steps, args.rounds, args.learning)
    if not args.json:
        for k, v in res.items():
            print(f"{k}: {v}")
    print(json.dumps(res))


if __name__ == "__main__":
    main()
