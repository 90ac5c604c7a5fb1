"""Our DQN training throughput vs Stable-Baselines3 DQN on CartPole-v1 (SPEC §1.6).

Both train the same network (2x128 ReLU, one output per action) with batch 64, one gradient
step per environment step (train_freq 1, gradient_steps 1), the same learning_starts (64),
replay 10,000, target update every 500 steps, gradient clip 10, Adam lr 1e-3, one torch
thread. SB3 gets a ``gym.make("CartPole-v1")`` env object. The two are interleaved (ours, SB3,
ours, SB3, ...) and each measured by wall time and by process CPU time; ``ratio`` is
our steps/s over SB3's steps/s on CPU time (robust to other load on a shared machine);
``ratio_wall`` is the same on wall time. Last line of ``--json`` output is the result.

    python benchmarks/dqn_throughput.py --json [--steps 5000]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

__all__ = ["run", "measure"]


def _ours(steps: int, seed: int) -> tuple[float, float]:
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import BiarmConfig, TaskConfig
    from evodevo.neuromod.tasks import resolve_tasks
    from evodevo.neuromod.trainer import train_task
    from evodevo.neuromod.variants import get_variant

    cfg = BiarmConfig(tasks=[TaskConfig("CartPole-v1", 100_000, 500)])
    specs, d = resolve_tasks(cfg)
    agent = BiarmAgent(cfg, get_variant("pnn"), d, seed)
    w, c = time.perf_counter(), time.process_time()
    train_task(agent, specs[0], 0, seed, 0, None, None, max_env_steps=steps)
    return time.perf_counter() - w, time.process_time() - c


def _sb3(steps: int, seed: int) -> tuple[float, float]:
    import gymnasium as gym
    from stable_baselines3 import DQN

    env = gym.make("CartPole-v1")
    model = DQN(
        "MlpPolicy",
        env,
        learning_rate=1e-3,
        buffer_size=10_000,
        learning_starts=64,
        batch_size=64,
        gamma=0.99,
        train_freq=1,
        gradient_steps=1,
        target_update_interval=500,
        max_grad_norm=10.0,
        policy_kwargs={"net_arch": [128, 128]},
        seed=seed,
        device="cpu",
        verbose=0,
    )
    w, c = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=steps)
    out = time.perf_counter() - w, time.process_time() - c
    env.close()
    return out


def measure(steps: int, rounds: int = 2) -> dict[str, Any]:
    """Interleaved rounds; returns steps/s of both and the ratios."""
    t = {"ours": [0.0, 0.0], "sb3": [0.0, 0.0]}
    for rnd in range(rounds):
        for name, fn in (
            (("ours", _ours), ("sb3", _sb3))
            if rnd % 2 == 0
            else (
                ("sb3", _sb3),
                ("ours", _ours),
            )
        ):
            w, c = fn(steps, rnd)
            t[name][0] += w
            t[name][1] += c
    n = steps * rounds
    return {
        "ratio": t["sb3"][1] / t["ours"][1],
        "ratio_wall": t["sb3"][0] / t["ours"][0],
        "ours_steps_per_s_cpu": n / t["ours"][1],
        "sb3_steps_per_s_cpu": n / t["sb3"][1],
        "ours_steps_per_s_wall": n / t["ours"][0],
        "sb3_steps_per_s_wall": n / t["sb3"][0],
        "steps": steps,
        "rounds": rounds,
    }


def run(quick: bool = False) -> dict[str, Any]:
    """Suite entry point."""
    from evodevo.parallel import set_single_thread

    set_single_thread()
    return measure(steps=1500 if quick else 5000, rounds=2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    ap.add_argument("--steps", type=int, default=5000, help="environment steps per round")
    ap.add_argument("--rounds", type=int, default=2, help="interleaved rounds")
    args = ap.parse_args()
    from evodevo.parallel import set_single_thread

    set_single_thread()
    res = measure(args.steps, args.rounds)
    if not args.json:
        for k, v in res.items():
            print(f"{k}: {v}")
    print(json.dumps(res))


if __name__ == "__main__":
    main()
