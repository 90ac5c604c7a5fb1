"""MountainCar third in the sequence under ``network.lateral_scale`` (issue 21; SPEC §1.2).

Takes a finished run's frozen CartPole and Acrobot columns (``checkpoints/task1.pt``, trained
with scale 1), builds the MountainCar column with the given lateral scale and trains it as
the run did (same seeds, same episodes, ``dqn.keep`` as configured), then evaluates its
greedy return on the evaluation seeds. One JSON line per call is appended to ``--out``.

    python docs/results/biarm_sweep/lateral_scale.py RUN SCALE [--init zero] [--out FILE] [--diagnose]

``--diagnose`` only prints the new column's initial Q-values on 500 random MountainCar states
(no training): the size of what the frozen features do to the column before it learns.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

from evodevo.config import from_dict
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.checkpoint import load_checkpoint
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.evaluation import eval_seeds, evaluate_column
from evodevo.neuromod.tasks import resolve_tasks
from evodevo.neuromod.trainer import EpisodeInfo, TaskRunner
from evodevo.neuromod.variants import get_variant
from evodevo.runs import read_json


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run")
    ap.add_argument("scale", type=float)
    ap.add_argument("--out", default=None)
    ap.add_argument("--diagnose", action="store_true")
    ap.add_argument("--init", default=None, help="network.lateral_init of the new column")
    args = ap.parse_args()
    torch.set_num_threads(1)
    saved = dict(read_json(f"{args.run}/config.json")["config"])
    variant, seed = str(saved.pop("variant")), int(saved.pop("seed"))
    saved["network"] = {**saved["network"], "lateral_scale": args.scale}
    if args.init is not None:
        saved["network"]["lateral_init"] = args.init
    cfg = from_dict(BiarmConfig, saved)
    specs, d_max = resolve_tasks(cfg)
    task = 2
    spec = specs[task]
    agent = BiarmAgent(cfg, get_variant(variant), d_max, seed)
    ckpt = load_checkpoint(f"{args.run}/checkpoints/task{task - 1}.pt")
    agent.load_state(ckpt["agent"])
    if args.diagnose:
        agent.begin_task(spec.n_actions)
        rng = np.random.default_rng(0)
        x = torch.zeros(500, d_max)
        x[:, 0] = torch.as_tensor(rng.uniform(-1.2, 0.6, 500), dtype=torch.float32)
        x[:, 1] = torch.as_tensor(rng.uniform(-0.07, 0.07, 500), dtype=torch.float32)
        q = agent.greedy_q(x, agent.col)
        print(
            f"scale {args.scale}: initial Q mean {q.mean():.3f} std {q.std():.3f}, "
            f"greedy action counts {np.bincount(q.argmax(1).numpy(), minlength=3).tolist()}"
        )
        return
    step0 = int(ckpt["step"])
    runner = TaskRunner(agent, spec, task, seed, step0)
    t0, c0 = time.perf_counter(), time.process_time()
    returns: list[float] = []

    def on_episode(info: EpisodeInfo) -> None:
        returns.append(float(info.ret))

    runner.hook = on_episode
    try:
        while runner.episodes_done < spec.episodes:
            runner.episode()
            runner.validate()
            if runner.episodes_done % 100 == 0:
                recent = returns[-100:]
                print(
                    f"{args.run} s={args.scale} episode {runner.episodes_done}: mean return "
                    f"{np.mean(recent):.1f}, flags {sum(r > -200 for r in recent)}/100",
                    flush=True,
                )
    finally:
        runner.close()
    seeds = eval_seeds(cfg.eval.seed, cfg.eval.episodes)
    last = evaluate_column(agent, task, spec, seeds)
    kept = runner.keep()
    final = evaluate_column(agent, task, spec, seeds)
    row = {
        "run": args.run,
        "variant": variant,
        "seed": seed,
        "lateral_scale": args.scale,
        "lateral_init": cfg.network.lateral_init,
        "episodes": spec.episodes,
        "final_return": float(np.mean(final)),
        "last_network_return": float(np.mean(last)),
        "training_flags": int(sum(r > -200 for r in returns)),
        "validation": kept,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
    }
    print(json.dumps({k: v for k, v in row.items() if k != "validation"}), flush=True)
    if args.out:
        with open(args.out, "a") as fh:
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
