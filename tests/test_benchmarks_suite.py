"""``python -m benchmarks --quick`` runs every benchmark in under two minutes and prints
one JSON object of ratios measured in that run.

The default run checks every benchmark's ratios except ``scaling`` (~half of the suite's time;
its equal-results property is tested in test_grn_evaluator.py and test_foundation.py). The
timed run of the whole suite is ``slow``: its CPU time is a budget that a shared CI machine can
miss by a few per cent (108 s against 100 s once), which says nothing about the code.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _suite(*args: str) -> tuple[dict[str, Any], float, float]:
    """Run ``python -m benchmarks --quick --json ARGS``: (results, wall s, CPU s of children)."""
    pytest.importorskip("pybullet")
    pytest.importorskip("stable_baselines3")
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--quick", "--json", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
    )
    wall = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1]), wall, cpu


def _check_ratios(res: dict[str, Any]) -> None:
    assert not [k for k, v in res.items() if "error" in v]
    assert 1.0 < res["biarm_overhead"]["ratio"] < 3.0  # BIARM does more work per step than PNN
    assert res["biarm_overhead"]["ratio_adapter128"] > res["biarm_overhead"]["ratio"]
    floor = res["biarm_floor"]["per_task"]
    assert floor["CartPole-v1"]["flops"] == 1.0  # the first column has no laterals: the same net
    assert floor["CartPole-v1"]["params"] == 1.0
    assert all(floor[t]["flops"] > 1.0 and floor[t]["params"] > 1.0 for t in list(floor)[1:])
    # our DQN step against SB3's, measured interleaved in one run: 1.4-2.8x on this machine
    assert res["dqn_throughput"]["ratio"] > 1.0
    assert 0.0 < res["grn_step"]["controller_share"] < 1.0
    evo = res["evolution_speed"]  # cached / uncached episodes per CPU-second
    assert evo["ratio_generation"] > 0 and evo["ratio_test"] > 0
    # the settled-scene cache changes the cost, never the outcome of an episode
    for arm, same in evo["generation"]["same_success_as_uncached"].items():
        done, total = map(int, same.split("/"))
        assert done == total, (arm, same)
    env = res["env_speed"]
    assert env["ratio"] is None and "make orig-venv" in env["note"] or env["ratio"] > 0


def test_every_benchmark_but_scaling_gives_its_ratios_in_one_json_object():
    sys.path.insert(0, str(ROOT))
    from benchmarks.__main__ import SUITE

    names = [n for n in SUITE if n != "scaling"]
    res, _, _ = _suite("--only", ",".join(names))
    assert list(res) == names
    assert all(res[n]["measures"] == SUITE[n] and res[n]["seconds"] > 0 for n in names)
    _check_ratios(res)


@pytest.mark.slow
def test_quick_suite_runs_every_benchmark_in_under_two_minutes():
    sys.path.insert(0, str(ROOT))
    from benchmarks.__main__ import SUITE

    load = os.getloadavg()[0]
    res, wall, cpu = _suite()
    assert set(res) == set(SUITE)
    _check_ratios(res)
    assert res["scaling"]["same_history"] is True  # 1 worker, 2 processes, 2 Ray actors agree
    assert res["scaling"]["speedup_pool2"] > 0
    # Two minutes on an idle machine: the suite runs mostly one process at a time, so its CPU
    # time (robust to other load; Ray's actors are not counted) bounds its idle wall time.
    # Measured beside two busy experiment processes: 60-72 s CPU, 97-109 s wall. Under heavy
    # load (other processes using most of a core) CPU time itself inflates: a looser budget.
    busy = load > 1.75
    budget = 200 if busy else 130
    assert cpu < budget, f"python -m benchmarks --quick used {cpu:.0f} s of CPU (budget {budget} s)"
    if not busy:
        assert wall < 120, f"python -m benchmarks --quick took {wall:.0f} s (budget 120 s)"
