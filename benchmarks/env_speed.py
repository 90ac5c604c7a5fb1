"""Episodes per second of ``evodevo/KukaDiverseObject-v0`` against the original (SPEC §3).

Both environments run the same fixed policies on the same episode seeds. The original
(``pybullet_envs.bullet.kuka_diverse_object_gym_env``, which needs the dead ``gym`` package) runs
in a subprocess with the Python of an isolated venv (``--orig-python``, ``$EVODEVO_ORIG_PYTHON``
or ``/work/origvenv/bin/python``). In that subprocess the original module's global random sources
(``random.random``, ``np.random.uniform``, ``np.random.choice``) are replaced by one
``numpy.random.default_rng(seed)`` per episode, drawn in the same order as the port draws from
``self.np_random``, and its file list is sorted as the port's is; so episode *i* of both starts
from the same camera, objects and drop poses, and the success rates can be compared episode by
episode as well as in total.

Policies: ``zero`` (all-zero action), ``down`` (d-angle −1 on every step: dx = dy = 0),
``random`` (uniform in [−1, 1]^3 from ``default_rng([seed, 1])`` of the episode).

Usage::

    python benchmarks/env_speed.py --json [--episodes N] [--policy down] [--orig-python PATH]

The last line of output is JSON: ``{"ratio": ours_eps_per_s / orig_eps_per_s, ...}``.
Rates are episodes per second of process CPU time (the machine is shared, so wall time is
noisier); wall-clock rates are reported too.

This file is also the subprocess worker (``--worker orig|ours``); the ``orig`` worker imports
neither ``evodevo`` nor Gymnasium.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "POLICIES",
    "orig_python",
    "run_worker",
    "run_episodes",
    "run",
    "compare_success",
    "stats_table",
    "main",
]

POLICIES = ("zero", "down", "random")
#: ``make orig-venv`` creates this venv beside the checkout's ``.venv``.
REPO_ORIG_PYTHON = str(Path(__file__).resolve().parents[1] / ".venv-orig/bin/python")
DEFAULT_ORIG_PYTHON = "/work/origvenv/bin/python"


def orig_python(explicit: str | None = None) -> str | None:
    """The isolated venv's Python that can import the original environment, if there is one."""
    for cand in (
        explicit,
        os.environ.get("EVODEVO_ORIG_PYTHON"),
        REPO_ORIG_PYTHON,
        DEFAULT_ORIG_PYTHON,
    ):
        if cand and os.path.exists(cand):
            return cand
    return None


def _action(policy: str, rng: np.random.Generator) -> np.ndarray:
    if policy == "zero":
        return np.zeros(3, dtype=np.float32)
    if policy == "down":
        return np.array([0.0, 0.0, -1.0], dtype=np.float32)
    if policy == "random":
        return rng.uniform(-1.0, 1.0, 3).astype(np.float32)
    raise SystemExit(f"unknown policy {policy!r}; choose one of {POLICIES}")


class _RngHolder:
    """Stands in for the ``random`` and ``numpy.random`` modules inside the original."""

    def __init__(self) -> None:
        self.rng = np.random.default_rng(0)

    def random(self) -> float:
        return float(self.rng.random())

    def uniform(self, low: float, high: float) -> float:
        return float(self.rng.uniform(low, high))

    def choice(self, a: Any, size: Any = None) -> Any:
        return self.rng.choice(a, size)


def _patch_original(module: Any, holder: _RngHolder) -> None:
    import glob as glob_module
    import types

    class _Np(types.ModuleType):
        random = holder

        def __getattr__(self, name: str) -> Any:
            return getattr(np, name)

    module.np = _Np("numpy_shim")
    module.random = holder
    module.glob = types.SimpleNamespace(glob=lambda pattern: sorted(glob_module.glob(pattern)))


def _digest(obs: Any) -> str:
    return hashlib.sha1(np.ascontiguousarray(obs, dtype=np.uint8).tobytes()).hexdigest()[:12]


def run_episodes(
    which: str, policy: str, seeds: list[int], test_objects: bool = False, exact: bool = False
) -> dict[str, Any]:
    """Run ``policy`` for one episode per seed on the ``ours`` or ``orig`` environment.

    Args:
        which: ``"ours"`` or ``"orig"`` (the latter only in the isolated venv).
        policy: One of :data:`POLICIES`.
        seeds: One episode per seed.
        test_objects: Held-out objects.
        exact: Ours only: a fresh instance with ``deterministic_pairs=False``,
            ``scene_cache=False`` and ``skip_empty_lift=False`` per episode, the setting in
            which the port reproduces the original bit for bit.

    Returns:
        ``{"rewards", "steps", "digests", "cpu_s", "wall_s"}``: final reward and number of
        steps per episode, a digest of every observation (per episode, joined), and the time of
        resets and steps.
    """
    if which == "orig":
        import pybullet_envs.bullet.kuka_diverse_object_gym_env as orig

        holder = _RngHolder()
        _patch_original(orig, holder)
        env: Any = orig.KukaDiverseObjectEnv(renders=False, isDiscrete=False, isTest=test_objects)
    else:
        from evodevo.envs import KukaDiverseObjectEnv

        env = None if exact else KukaDiverseObjectEnv(test_objects=test_objects)
    rewards, steps, digests = [], [], []
    cpu = wall = 0.0
    for seed in seeds:
        if which == "ours" and exact:
            env = KukaDiverseObjectEnv(
                test_objects=test_objects,
                deterministic_pairs=False,
                scene_cache=False,
                skip_empty_lift=False,
            )
        act_rng = np.random.default_rng([seed, 1])
        c0, w0 = time.process_time(), time.perf_counter()
        if which == "orig":
            holder.rng = np.random.default_rng(seed)
            obs = env.reset()
        else:
            obs, _ = env.reset(seed=seed)
        done, n, reward = False, 0, 0.0
        seen = [_digest(obs)]
        while not done:
            a = _action(policy, act_rng)
            if which == "orig":
                obs, reward, done, _ = env.step(a)
            else:
                obs, reward, term, trunc, _ = env.step(a)
                done = term or trunc
            seen.append(_digest(obs))
            n += 1
        cpu += time.process_time() - c0
        wall += time.perf_counter() - w0
        rewards.append(float(reward))
        steps.append(n)
        digests.append("-".join(seen))
        if which == "ours" and exact:
            env.close()
    if which == "ours" and not exact:
        env.close()
    return {"rewards": rewards, "steps": steps, "digests": digests, "cpu_s": cpu, "wall_s": wall}


def run_worker(
    which: str,
    policy: str,
    seeds: list[int],
    test_objects: bool = False,
    python: str | None = None,
    timeout: float | None = None,
    exact: bool = False,
) -> dict[str, Any]:
    """:func:`run_episodes` in a fresh subprocess (``python`` defaults to this interpreter)."""
    cmd = [
        python or sys.executable,
        os.path.abspath(__file__),
        "--worker",
        which,
        "--policy",
        policy,
        "--seeds",
        ",".join(map(str, seeds)),
    ]
    if test_objects:
        cmd.append("--test-objects")
    if exact:
        cmd.append("--exact")
    out = subprocess.run(cmd, capture_output=True, text=True, check=False, timeout=timeout)
    if out.returncode != 0:
        raise RuntimeError(f"{which} worker failed ({out.returncode}):\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def run(
    quick: bool = False,
    episodes: int | None = None,
    policies: tuple[str, ...] = ("down", "zero"),
    orig: str | None = None,
    seed0: int = 0,
) -> dict[str, Any]:
    """Time ours and the original on the same policies and seeds, one after the other.

    Args:
        quick: 3 episodes per policy instead of 20 (``episodes`` overrides both).
        episodes: Episodes per policy.
        policies: Fixed policies to run (see :data:`POLICIES`).
        orig: Python of the isolated venv with the original (see :func:`orig_python`).
        seed0: First episode seed.

    Returns:
        ``ratio`` (ours / original episodes per CPU-second; ``None`` without the original),
        rates, success rates, and ``paired_agreement`` (share of episodes with equal rewards).
    """
    n = episodes if episodes is not None else (3 if quick else 20)
    seeds = list(range(seed0, seed0 + n))
    py = orig_python(orig)
    res: dict[str, Any] = {"episodes_per_policy": n, "policies": list(policies)}
    totals: dict[str, dict[str, float]] = {}
    per_policy: dict[str, Any] = {}
    # Alternate ours and the original policy by policy, so that both see the same machine load.
    for pol in policies:
        for which in ("ours", "orig"):
            if which == "orig" and py is None:
                continue
            tot = totals.setdefault(
                which, {"cpu_s": 0.0, "wall_s": 0.0, "episodes": 0, "success": 0.0}
            )
            r = run_worker(which, pol, seeds, python=py if which == "orig" else None)
            per_policy.setdefault(pol, {})[which] = r["rewards"]
            tot["cpu_s"] += r["cpu_s"]
            tot["wall_s"] += r["wall_s"]
            tot["episodes"] += len(r["rewards"])
            tot["success"] += sum(r["rewards"])
    for which, tot in totals.items():
        res[f"{which}_episodes_per_s"] = tot["episodes"] / tot["cpu_s"]
        res[f"{which}_episodes_per_wall_s"] = tot["episodes"] / tot["wall_s"]
        res[f"{which}_success"] = tot["success"] / tot["episodes"]
    if "orig" in totals:
        res["ratio"] = res["ours_episodes_per_s"] / res["orig_episodes_per_s"]
        same = [
            a == b
            for pol in policies
            for a, b in zip(per_policy[pol]["ours"], per_policy[pol]["orig"], strict=True)
        ]
        res["paired_agreement"] = sum(same) / len(same)
    else:
        res["ratio"] = None
        res["orig_episodes_per_s"] = None
        res["orig_success"] = None
        res["note"] = (
            "original not run: no isolated venv (run `make orig-venv`, or set --orig-python or "
            "EVODEVO_ORIG_PYTHON to a Python with pybullet==3.2.7 gym==0.23.1 'setuptools<82')"
        )
    res["per_policy_success"] = {
        pol: {w: sum(v) / len(v) for w, v in d.items()} for pol, d in per_policy.items()
    }
    return res


def compare_success(
    episodes: int = 150,
    policies: tuple[str, ...] = POLICIES,
    orig: str | None = None,
    seed0: int = 0,
    jobs: int = 2,
    chunk: int = 10,
    test_objects: bool = False,
    cache: str | None = None,
) -> dict[str, Any]:
    """Success rates of ours and the original under the same policies and episode seeds.

    Workers (chunks of ``chunk`` episodes) run ``jobs`` at a time, chunk by chunk over the
    policies. Ours runs as in normal use (one instance, ``deterministic_pairs=True``), so
    episodes are paired with the original's but not bit-identical to them. With ``cache`` (a
    folder), each chunk's result is stored there and reused, so an interrupted run resumes.

    Returns:
        Per policy: successes, n, Wilson 95 % intervals, the two-sided Fisher exact p-value of
        the difference, and the share of seeds on which both give the same reward.

    Raises:
        RuntimeError: The original's venv is missing.
    """
    from concurrent.futures import ThreadPoolExecutor

    from evodevo.stats import fisher_exact, wilson_interval

    py = orig_python(orig)
    if py is None:
        raise RuntimeError("the original's venv is missing; see --orig-python")
    seeds = list(range(seed0, seed0 + episodes))
    chunks = [seeds[i : i + chunk] for i in range(0, len(seeds), chunk)]
    tasks = [(w, pol, c) for c in chunks for pol in policies for w in ("orig", "ours")]

    def one(task: tuple[str, str, list[int]]) -> dict[str, Any]:
        w, pol, c = task
        path = None
        if cache:
            os.makedirs(cache, exist_ok=True)
            name = f"{w}_{pol}_{'test' if test_objects else 'train'}_{c[0]}-{c[-1]}.json"
            path = os.path.join(cache, name)
            if os.path.exists(path):
                with open(path) as fh:
                    return json.load(fh)
        out = run_worker(w, pol, c, test_objects, python=py if w == "orig" else None)
        if path:
            with open(path, "w") as fh:
                json.dump(out, fh)
        return out

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        outs = list(pool.map(one, tasks))
    rewards: dict[tuple[str, str], list[float]] = {}
    for (w, pol, _), out in zip(tasks, outs, strict=True):
        rewards.setdefault((pol, w), []).extend(out["rewards"])
    res: dict[str, Any] = {"episodes": episodes, "seed0": seed0, "test_objects": test_objects}
    for pol in policies:
        row: dict[str, Any] = {}
        for w in ("ours", "orig"):
            r = rewards[(pol, w)]
            k = int(sum(r))
            row[w] = {"successes": k, "n": len(r), "rate": k / len(r)}
            row[w]["wilson95"] = list(wilson_interval(k, len(r)))
        row["fisher_p"] = fisher_exact(
            row["ours"]["successes"], episodes, row["orig"]["successes"], episodes
        )
        same = [a == b for a, b in zip(rewards[(pol, "ours")], rewards[(pol, "orig")], strict=True)]
        row["paired_agreement"] = sum(same) / len(same)
        res[pol] = row
    return res


def stats_table(res: dict[str, Any]) -> str:
    """Markdown table of :func:`compare_success`'s result."""
    lines = [
        "| policy | ours | original | Fisher p | same reward on a seed |",
        "|---|---|---|---|---|",
    ]
    for pol in POLICIES:
        if pol not in res:
            continue
        row = res[pol]
        cells = []
        for w in ("ours", "orig"):
            c = row[w]
            lo, hi = c["wilson95"]
            cells.append(
                f"{c['successes']}/{c['n']} = {100 * c['rate']:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]"
            )
        lines.append(
            f"| {pol} | {cells[0]} | {cells[1]} | {row['fisher_p']:.2f} | "
            f"{100 * row['paired_agreement']:.0f} % |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print only the JSON result line")
    ap.add_argument("--quick", action="store_true", help="3 episodes per policy")
    ap.add_argument("--episodes", type=int, default=None, help="episodes per policy")
    ap.add_argument("--policy", action="append", choices=POLICIES, help="repeatable")
    ap.add_argument("--orig-python", default=None, help="Python of the venv with the original")
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument(
        "--stats", action="store_true", help="success rates of ours vs the original (slow)"
    )
    ap.add_argument("--jobs", type=int, default=2, help="parallel workers for --stats")
    ap.add_argument("--out", default=None, help="write the JSON result here too")
    ap.add_argument("--cache", default=None, help="folder of per-chunk results for --stats")
    ap.add_argument("--worker", choices=("orig", "ours"), help=argparse.SUPPRESS)
    ap.add_argument("--seeds", default="", help=argparse.SUPPRESS)
    ap.add_argument("--test-objects", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--exact", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        seeds = [int(s) for s in args.seeds.split(",") if s]
        pol = (args.policy or ["down"])[0]
        print(json.dumps(run_episodes(args.worker, pol, seeds, args.test_objects, args.exact)))
        return
    if args.stats:
        res = compare_success(
            episodes=args.episodes or 150,
            policies=tuple(args.policy or POLICIES),
            orig=args.orig_python,
            seed0=args.seed0,
            jobs=args.jobs,
            cache=args.cache,
        )
        if not args.json:
            print(stats_table(res))
    else:
        res = run(
            quick=args.quick,
            episodes=args.episodes,
            policies=tuple(args.policy or ("down", "zero")),
            orig=args.orig_python,
            seed0=args.seed0,
        )
        if not args.json:
            for k, v in res.items():
                print(f"{k}: {v}")
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(res, fh, indent=1)
    print(json.dumps(res))


if __name__ == "__main__":
    main()
