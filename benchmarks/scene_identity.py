"""Identity of cached and uncached Kuka resets over many episodes and policies (SPEC §3).

For every (seed, policy) the episode runs twice with the settled-scene cache: once as a miss
(the cache is emptied first, so the reset drops and settles the objects) and once as a hit
(the scene comes from the cache). Every observation, every ``info["proprio"]``, the reward,
``terminated``/``truncated`` and the env's RNG state after the episode must be equal bit for
bit. Policies: ``zero`` (all-zero action), ``turn`` (constant d-angle −1), ``random``
(uniform, seeded per episode) and ``grn`` (an evolved genome of a committed thesis-protocol
run, driven by the GRN evaluator's own episode loop). Seeds alternate between held-out and
training objects.

Optionally (``--legacy``) each episode also runs with ``scene_cache=False``, the port without
the cache (objects settle in the episode's own world), and the script counts the episodes whose
success agrees with the cached one (these are not bit-identical; docs/kuka_env.md).

Usage::

    python benchmarks/scene_identity.py [--seeds 50] [--legacy] [--out FILE]

The last line of output is JSON: ``{"episodes": n, "identical": k, ...}``.
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

__all__ = ["POLICIES", "run", "main"]

POLICIES = ("zero", "turn", "random", "grn")
DEFAULT_RUN = Path(__file__).resolve().parents[1] / "docs/results/thesis/grn/plain_s1"


class _Recorder(gym.Wrapper):  # type: ignore[type-arg]
    """Hashes everything an episode returns (observations, proprio, rewards, flags)."""

    def __init__(self, env: gym.Env) -> None:  # type: ignore[type-arg]
        super().__init__(env)
        self.digest = hashlib.sha256()
        self.reward = 0.0

    def reset(self, **kwargs: Any) -> Any:
        self.digest = hashlib.sha256()
        obs, info = self.env.reset(**kwargs)
        self.digest.update(obs.tobytes() + info["proprio"].tobytes())
        return obs, info

    def step(self, action: Any) -> Any:
        obs, r, term, trunc, info = self.env.step(action)
        self.digest.update(obs.tobytes() + info["proprio"].tobytes())
        self.digest.update(np.array([r, term, trunc, info["is_success"]], np.float64).tobytes())
        self.reward = float(r)
        return obs, r, term, trunc, info

    def finish(self) -> str:
        state = self.env.unwrapped.np_random.bit_generator.state["state"]["state"]
        self.digest.update(int(state).to_bytes(16, "little"))
        return self.digest.hexdigest()[:16]


def play(env: gym.Env, seed: int, policy: str, grn: Any) -> None:  # type: ignore[type-arg]
    """One episode of ``policy`` on seed ``seed`` (``grn``: :func:`load_grn`'s result)."""
    if policy == "grn":
        from evodevo.grn.evaluator import Episode, run_episodes

        encoder, controller, genome = grn
        run_episodes([env], encoder, controller, [genome], [Episode(seed)])
        return
    rng = np.random.default_rng([seed, 1])
    env.reset(seed=seed)
    done = False
    while not done:
        if policy == "zero":
            a = np.zeros(3, np.float32)
        elif policy == "turn":
            a = np.array([0.0, 0.0, -1.0], np.float32)
        else:
            a = rng.uniform(-1.0, 1.0, 3).astype(np.float32)
        _, _, term, trunc, _ = env.step(a)
        done = term or trunc


def load_grn(policies: tuple[str, ...], run_dir: str | Path) -> Any:
    """(encoder, controller, genome) of the committed run when ``grn`` is a policy, else None."""
    if "grn" not in policies:
        return None
    from evodevo.grn.controller import make_controller
    from evodevo.grn.evaluation import load_run

    loaded = load_run(run_dir)
    return loaded.encoder, make_controller(loaded.config, 3), loaded.genome


def _episode(env: _Recorder, seed: int, policy: str, grn: Any) -> tuple[str, float]:
    play(env, seed, policy, grn)
    return env.finish(), env.reward


def run(
    seeds: int = 50,
    policies: tuple[str, ...] = POLICIES,
    legacy: bool = False,
    seed0: int = 0,
    run_dir: str | Path = DEFAULT_RUN,
) -> dict[str, Any]:
    """Run ``seeds`` × ``policies`` episodes as miss and as hit (and legacy); see the docstring."""
    from evodevo.envs import KukaDiverseObjectEnv
    from evodevo.envs.scene_cache import SceneCache

    grn = load_grn(policies, run_dir)
    cache = SceneCache()
    envs: dict[tuple[bool, str], _Recorder] = {}
    for test in (False, True):
        # miss and hit share one cache: the miss fills it, the hit reads it
        envs[(test, "miss")] = _Recorder(KukaDiverseObjectEnv(test_objects=test, scene_cache=cache))
        envs[(test, "hit")] = _Recorder(KukaDiverseObjectEnv(test_objects=test, scene_cache=cache))
        if legacy:
            envs[(test, "legacy")] = _Recorder(
                KukaDiverseObjectEnv(test_objects=test, scene_cache=False)
            )
    rows = []
    cpu = {"miss": 0.0, "hit": 0.0, "legacy": 0.0}
    try:
        for seed in range(seed0, seed0 + seeds):
            test = seed % 2 == 1
            for pol in policies:
                out: dict[str, Any] = {"seed": seed, "policy": pol, "test_objects": test}
                for arm in ("miss", "hit", "legacy") if legacy else ("miss", "hit"):
                    if arm == "miss":
                        cache.clear()
                    c0 = time.process_time()
                    out[arm] = _episode(envs[(test, arm)], seed, pol, grn)
                    cpu[arm] += time.process_time() - c0
                rows.append(out)
    finally:
        for e in envs.values():
            e.close()
    res: dict[str, Any] = {
        "episodes": len(rows),
        "seeds": seeds,
        "policies": list(policies),
        "identical": sum(r["miss"] == r["hit"] for r in rows),
        "cache_hits": cache.hits,
        "cache_misses": cache.misses,
        "cpu_s": {k: round(v, 1) for k, v in cpu.items() if v},
        "success_rate": {
            arm: {
                pol: float(np.mean([r[arm][1] for r in rows if r["policy"] == pol]))
                for pol in policies
            }
            for arm in (("miss", "hit", "legacy") if legacy else ("miss", "hit"))
        },
        "differing": [{k: r[k] for k in ("seed", "policy")} for r in rows if r["miss"] != r["hit"]],
    }
    if legacy:
        same = [r["legacy"][1] == r["hit"][1] for r in rows]
        res["legacy_same_success"] = f"{sum(same)}/{len(same)}"
        res["legacy_same_success_per_policy"] = {
            pol: f"{sum(s for s, r in zip(same, rows, strict=True) if r['policy'] == pol)}/"
            f"{sum(r['policy'] == pol for r in rows)}"
            for pol in policies
        }
    return res


def main(argv: list[str] | None = None) -> None:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50, help="seeds (each runs every policy)")
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--policy", action="append", choices=POLICIES, help="repeatable")
    ap.add_argument("--legacy", action="store_true", help="also run scene_cache=False")
    ap.add_argument("--out", default=None, help="write the JSON result here too")
    args = ap.parse_args(argv)
    res = run(args.seeds, tuple(args.policy or POLICIES), args.legacy, args.seed0)
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))
    print(json.dumps(res))


if __name__ == "__main__":
    main()
