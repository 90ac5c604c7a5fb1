"""the Kuka baselines' evaluators on Ray (`--backend ray`) give the local numbers."""

from __future__ import annotations

import json

import pytest
from test_baselines_kuka import TINY, invoke

from evodevo.errors import EvodevoError

pytest.importorskip("pybullet")
pytest.importorskip("neat")

_WALL = {"wall_s", "eval_wall_s", "time_to_target_s", "machine", "evals_per_s"}


def _summary(out):
    s = json.loads((out / "summary.json").read_text())
    return {k: v for k, v in s.items() if k not in _WALL}


def _history(out):
    """history.csv without its wall-clock column."""
    rows = [line.split(",") for line in (out / "history.csv").read_text().splitlines()]
    cut = rows[0].index("elapsed_s")
    return [r[:cut] + r[cut + 1 :] for r in rows]


def _evaluate(out, *extra):
    res = invoke("evaluate", out, "--test-episodes", 2, "--no-baselines", "--json", *extra)
    r = json.loads(res.output.strip().splitlines()[-1])
    return {k: v for k, v in r.items() if k not in _WALL}


# ~45 s; Ray-equals-local stays in the default run for the GRN evaluator (test_grn_evaluator.py),
# the BIARM grid (test_biarm_compare_ray.py) and the pool (test_foundation.py).
@pytest.mark.slow
def test_neat_training_and_evaluation_on_ray_equal_local(tmp_path):
    pytest.importorskip("ray")
    import ray

    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY.replace("population: 2", "population: 3"))
    common = ["kuka", "--method", "neat", "--config", cfg, "--quiet", "--budget-steps", 1]
    invoke(*common, "--out", tmp_path / "local")
    invoke(*common, "--out", tmp_path / "ray", "--backend", "ray", "--workers", 2)
    local, on_ray = _summary(tmp_path / "local"), _summary(tmp_path / "ray")
    assert local["episodes_run"] == 3 and local == on_ray
    assert _history(tmp_path / "local") == _history(tmp_path / "ray")
    assert _evaluate(tmp_path / "local") == _evaluate(
        tmp_path / "local", "--backend", "ray", "--workers", 2
    )
    assert not ray.is_initialized()  # every pool shut down the Ray it started


def test_backend_options_are_checked_before_training(tmp_path):
    with pytest.raises(EvodevoError, match="--backend ray applies to NEAT only: ppo"):
        invoke("kuka", "--method", "ppo", "--backend", "ray", "--out", tmp_path / "x")
    with pytest.raises(EvodevoError, match="--address only goes with --backend ray"):
        invoke("kuka", "--method", "neat", "--address", "auto", "--out", tmp_path / "x")
    with pytest.raises(EvodevoError, match="--backend 'dask' is not known"):
        invoke("evaluate", tmp_path, "--backend", "dask")
    assert not (tmp_path / "x").exists()
