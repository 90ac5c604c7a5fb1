"""Outcomes with and without the skipped lift of KukaDiverseObject-v0 (SPEC §3).

For every (seed, policy) the episode runs twice, both with the settled-scene cache (warmed
before timing, so both arms place the same scene): once with ``skip_empty_lift=True`` (the
default: the automatic grasp's lift stops once nothing is held and the arm is clear above every
object) and once with ``False`` (the full 500-step lift). Reward, ``terminated``, ``truncated``
and ``is_success`` must agree in every episode; every observation and ``info["proprio"]``
before the last step must be equal bit for bit (the skip acts only inside the last step), and
so must the whole episode when the lift was not cut. Policies as in
``benchmarks/scene_identity.py``: ``zero``, ``turn`` (constant d-angle −1, the action
(0, 0, −1)), ``random`` (uniform, seeded per episode) and ``grn`` (the evolved genome of a
committed thesis-protocol run, driven by the GRN evaluator's episode loop). Seeds alternate
between training (even) and held-out (odd) objects.

Also reported: the CPU seconds of each arm, the lifts cut and the simulation steps saved, and
how far the gripper-to-nearest-object distance at the episode's end (the shaped training
fitness' ``grasp_distance``) moves when the lift is cut.

Usage::

    python benchmarks/lift_identity.py [--seeds 50] [--policy turn ...] [--out FILE]

The last line of output is JSON: ``{"episodes": n, "same_outcome": k, ...}``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

try:
    from benchmarks.scene_identity import load_grn, play
except ModuleNotFoundError:  # run as `python benchmarks/lift_identity.py`
    from scene_identity import load_grn, play  # type: ignore[no-redef]

__all__ = ["POLICIES", "run", "main"]

POLICIES = ("zero", "turn", "random", "grn")
DEFAULT_RUN = Path(__file__).resolve().parents[1] / "docs/results/thesis/grn/plain_s1"
ARMS = ("skip", "full")


class _Recorder(gym.Wrapper):  # type: ignore[type-arg]
    """Hashes an episode before its last step, the last step, and keeps the final flags."""

    def __init__(self, env: gym.Env) -> None:  # type: ignore[type-arg]
        super().__init__(env)
        self.before = hashlib.sha256()
        self.last = b""
        self.flags: list[float] = []

    def reset(self, **kwargs: Any) -> Any:
        self.before, self.last, self.flags = hashlib.sha256(), b"", []
        obs, info = self.env.reset(**kwargs)
        self.before.update(obs.tobytes() + info["proprio"].tobytes())
        return obs, info

    def step(self, action: Any) -> Any:
        obs, r, term, trunc, info = self.env.step(action)
        self.before.update(self.last)  # the previous step was not the last one
        self.last = obs.tobytes() + info["proprio"].tobytes()
        self.flags = [float(r), float(term), float(trunc), float(info["is_success"])]
        return obs, r, term, trunc, info

    def result(self) -> dict[str, Any]:
        from evodevo.grn.env_interface import grasp_distance

        return {
            "before": self.before.hexdigest()[:16],
            "last": hashlib.sha256(self.last).hexdigest()[:16],
            "flags": self.flags,
            "distance": grasp_distance(self.env),
        }


def _episode(env: _Recorder, seed: int, policy: str, grn: Any) -> dict[str, Any]:
    play(env, seed, policy, grn)
    return env.result()


def run(
    seeds: int = 50,
    policies: tuple[str, ...] = POLICIES,
    seed0: int = 0,
    run_dir: str | Path = DEFAULT_RUN,
) -> dict[str, Any]:
    """Run ``seeds`` × ``policies`` episodes with and without the skip; see the docstring."""
    from evodevo.envs import KukaDiverseObjectEnv
    from evodevo.envs.scene_cache import SceneCache

    grn = load_grn(policies, run_dir)
    cache = SceneCache()
    envs: dict[tuple[bool, str], _Recorder] = {}
    for test in (False, True):
        for arm in ARMS:
            envs[(test, arm)] = _Recorder(
                KukaDiverseObjectEnv(
                    test_objects=test, scene_cache=cache, skip_empty_lift=arm == "skip"
                )
            )
    rows = []
    cpu = dict.fromkeys(ARMS, 0.0)
    try:
        for seed in range(seed0, seed0 + seeds):
            test = seed % 2 == 1
            envs[(test, "full")].reset(seed=seed)  # warm the cache: both arms place the scene
            for pol in policies:
                out: dict[str, Any] = {"seed": seed, "policy": pol, "test_objects": test}
                for arm in ARMS if (seed + len(rows)) % 2 == 0 else ARMS[::-1]:
                    env = envs[(test, arm)]
                    cut = env.unwrapped.lift_steps_skipped  # type: ignore[attr-defined]
                    c0 = time.process_time()
                    out[arm] = _episode(env, seed, pol, grn)
                    cpu[arm] += time.process_time() - c0
                    out[arm]["steps_saved"] = env.unwrapped.lift_steps_skipped - cut  # type: ignore[attr-defined]
                rows.append(out)
    finally:
        for e in envs.values():
            e.close()
    skip = [r["skip"] for r in rows]
    full = [r["full"] for r in rows]
    cut = [s["steps_saved"] > 0 for s in skip]
    moved = [
        abs(s["distance"] - f["distance"]) for s, f, c in zip(skip, full, cut, strict=True) if c
    ]
    whole = sum(
        s["before"] == f["before"] and s["last"] == f["last"]
        for s, f, c in zip(skip, full, cut, strict=True)
        if not c
    )
    res: dict[str, Any] = {
        "episodes": len(rows),
        "seeds": seeds,
        "policies": list(policies),
        "same_outcome": sum(s["flags"] == f["flags"] for s, f in zip(skip, full, strict=True)),
        "same_before_last_step": sum(
            s["before"] == f["before"] for s, f in zip(skip, full, strict=True)
        ),
        "identical_when_not_cut": f"{whole}/{cut.count(False)}",
        "grasps": sum(f["flags"][1] == 1.0 for f in full),
        "successes": sum(f["flags"][3] == 1.0 for f in full),
        "lifts_cut": sum(cut),
        "lifts_cut_of_successes": sum(
            c and s["flags"][3] == 1.0 for s, c in zip(skip, cut, strict=True)
        ),
        "lift_steps_saved": sum(s["steps_saved"] for s in skip),
        "mean_steps_saved_per_cut": (
            float(np.mean([s["steps_saved"] for s in skip if s["steps_saved"]]))
            if any(cut)
            else 0.0
        ),
        "cpu_s": {k: round(v, 1) for k, v in cpu.items()},
        "cpu_ratio_full_over_skip": round(cpu["full"] / cpu["skip"], 3) if cpu["skip"] else None,
        "success_rate": {
            arm: {
                pol: float(np.mean([r[arm]["flags"][3] for r in rows if r["policy"] == pol]))
                for pol in policies
            }
            for arm in ARMS
        },
        "grasp_distance_moved_m": {
            "max": round(max(moved), 4) if moved else 0.0,
            "mean": round(float(np.mean(moved)), 4) if moved else 0.0,
        },
        "differing": [
            {"seed": r["seed"], "policy": r["policy"]}
            for r in rows
            if r["skip"]["flags"] != r["full"]["flags"]
        ],
    }
    return res


def main(argv: list[str] | None = None) -> None:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50, help="seeds (each runs every policy)")
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--policy", action="append", choices=POLICIES, help="repeatable")
    ap.add_argument("--run", default=str(DEFAULT_RUN), help="GRN run of the grn policy")
    ap.add_argument("--out", default=None, help="write the JSON result here too")
    args = ap.parse_args(argv)
    res = run(args.seeds, tuple(args.policy or POLICIES), args.seed0, args.run)
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))
    print(json.dumps(res))


if __name__ == "__main__":
    main()
