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


def _interleaved(
    agents: dict[str, Any], specs: list[Any], steps: int, rnd: int
) -> tuple[dict[str, list[float]], dict[str, float]]:
    """CPU and wall seconds per task of ``agents`` trained episode by episode in turn.

    The order alternates (``a b | b a | a b ...``), so with two agents each one follows
    itself and the other equally often: cache and load effects of the predecessor hit both.
    """
    from evodevo.neuromod.trainer import TaskRunner

    cpu = {k: [0.0] * len(specs) for k in agents}
    wall = {k: 0.0 for k in agents}
    for i, spec in enumerate(specs):
        runners = {k: TaskRunner(a, spec, i, rnd) for k, a in agents.items()}
        turn = 0
        while any(r.task_steps < steps for r in runners.values()):
            order = list(runners) if turn % 2 == 0 else list(reversed(runners))
            turn += 1
            for k in order:
                r = runners[k]
                if r.task_steps >= steps:
                    continue
                w0, t0 = time.perf_counter(), time.process_time()
                r.episode(max_env_steps=steps)
                cpu[k][i] += time.process_time() - t0
                wall[k] += time.perf_counter() - w0
        for r in runners.values():
            r.close()
    return cpu, wall


def measure(steps: int, rounds: int = 1, learning: str = "fixed") -> dict[str, Any]:
    """Per-task and overall µs/step of biarm (r=32) and biarm (r=128), each against pnn.

    Each BIARM configuration is timed in its own pass, interleaved with a fresh PNN of the
    same seed: two agents in alternating order, so neither is systematically run after the
    other (with three agents in ``a b c | c b a`` order the middle one never follows itself,
    and r = 128's large working set would be charged to r = 32's cache misses).
    """
    from evodevo.config import replace
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import BiarmConfig, ModuleConfig, NetworkConfig
    from evodevo.neuromod.tasks import resolve_tasks
    from evodevo.neuromod.trainer import train_task
    from evodevo.neuromod.variants import get_variant

    base = BiarmConfig()
    base = replace(base, modules=ModuleConfig(learning=learning))  # type: ignore[arg-type]
    specs, d_max = resolve_tasks(base)
    configs = {
        "pnn": (base, "pnn"),
        "biarm": (base, "biarm"),
        "biarm_r128": (replace(base, network=NetworkConfig(adapter_dim=128)), "biarm"),
    }
    # warm-up: first calls pay one-time costs (lazy imports, kernel set-up) that would
    # otherwise be charged to whichever agent happens to run first
    for c, v in configs.values():
        warm = BiarmAgent(c, get_variant(v), d_max, seed=99)
        for i, spec in enumerate(specs[:2]):
            train_task(warm, spec, i, 99, 0, None, None, max_env_steps=200)
    cpu: dict[str, list[float]] = {}
    wall: dict[str, float] = {}
    for k in ("biarm", "biarm_r128"):
        cpu[k], cpu[f"pnn_{k}"] = [0.0] * len(specs), [0.0] * len(specs)
        wall[k] = wall[f"pnn_{k}"] = 0.0
        for rnd in range(rounds):
            pair = {
                name: BiarmAgent(configs[v][0], get_variant(configs[v][1]), d_max, seed=rnd)
                for name, v in ((k, k), (f"pnn_{k}", "pnn"))
            }  # fmt: skip
            tc, tw = _interleaved(pair, specs, steps, rnd)
            for name in pair:
                cpu[name] = [a + b for a, b in zip(cpu[name], tc[name], strict=True)]
                wall[name] += tw[name]
    n = steps * len(specs) * rounds
    us = {k: 1e6 * sum(v) / n for k, v in cpu.items()}

    def ratio(k: str) -> float:
        return us[k] / us[f"pnn_{k}"]

    def per_task(k: str) -> dict[str, float]:
        return {s.env_id: cpu[k][i] / cpu[f"pnn_{k}"][i] for i, s in enumerate(specs)}

    return {
        "ratio": ratio("biarm"),
        "ratio_adapter128": ratio("biarm_r128"),
        "ratio_wall": wall["biarm"] / wall["pnn_biarm"],
        "ratio_adapter128_wall": wall["biarm_r128"] / wall["pnn_biarm_r128"],
        "pnn_us_per_step": us["pnn_biarm"],
        "biarm_us_per_step": us["biarm"],
        "pnn_us_per_step_r128_pass": us["pnn_biarm_r128"],
        "biarm_r128_us_per_step": us["biarm_r128"],
        "per_task_ratio": per_task("biarm"),
        "per_task_ratio_adapter128": per_task("biarm_r128"),
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
