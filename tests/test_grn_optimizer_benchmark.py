"""benchmarks/grn_optimizer.py: the time-to-a-controller benchmark keeps to its wall-clock budget."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_a_generation_starts_only_if_it_fits_before_the_deadline(tmp_path):
    pytest.importorskip("pybullet")
    sys.path.insert(0, str(ROOT))
    from benchmarks.grn_optimizer import run

    # a budget of 0.1 s: the first generation always runs, and none fits after it
    res = run("ga", minutes=0.1 / 60, workers=1, quick=True, progress=False, out=tmp_path / "r")
    assert res["generations_run"] == 1 and res["stopped_by"] == "clock"
    assert res["longest_generation_s"] > 0.1 and not res["within_budget"]
    assert res["test"]["n"] == 4 and (tmp_path / "r" / "config.json").is_file()

    # a budget with room: the quick config's 2 generations, within it
    res = run("cmaes", minutes=5, workers=1, quick=True, progress=False)
    assert res["generations_run"] == 2 and res["stopped_by"] == "generations"
    assert res["within_budget"] and res["wall_to_controller_s"] <= 300
