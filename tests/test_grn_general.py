"""Both GRN controllers on any Box-observation / Box-action Gymnasium env (SPEC §5).

For a vector observation the encoder is skipped and the observation, its bounds mapped onto
``sensors.vector_range``, is the sensor vector. Checked on Pendulum-v1 (and the CLI on it).
"""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.config import load_config, replace
from evodevo.errors import EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import make_controller
from evodevo.grn.evaluator import Episode, Evaluator, make_env, run_episodes, scale_observation

PENDULUM = "configs/grn_pendulum.yaml"


class _Spy:
    """A policy recording the sensor values it is given."""

    uses_encoder = True

    def __init__(self) -> None:
        self.seen: list[np.ndarray] = []
        self.features: list[object] = []

    def reset_state(self, genomes: list[object]) -> None:
        return None

    def step(self, state, idx, features, proprio, rngs, noisy):
        self.seen.append(proprio.copy())
        self.features.append(features)
        return np.zeros((len(idx), 1))


def test_scale_observation_maps_bounds_to_the_range():
    box = gym.spaces.Box(np.array([-1.2, -0.07]), np.array([0.6, 0.07]), dtype=np.float64)
    assert scale_observation(np.array([-1.2, 0.07]), box, (-1.0, 1.0)) == pytest.approx([-1, 1])
    assert scale_observation(np.array([-0.3, 0.0]), box, (0.0, 1.0)) == pytest.approx([0.5, 0.5])


def test_vector_observation_is_the_sensor_vector_without_encoder():
    env = make_env("Pendulum-v1")
    spy = _Spy()
    try:
        res = run_episodes([env], None, spy, [None], [Episode(3)], n_proprio=3)
        obs0, _ = env.reset(seed=3)
    finally:
        env.close()
    assert res["steps"][0] == 200 and len(spy.seen) == 200
    assert all(f is None for f in spy.features)
    expected = np.asarray(obs0, np.float64) / np.array([1.0, 1.0, 8.0])  # bounds ±1, ±1, ±8
    assert spy.seen[0][0] == pytest.approx(expected, rel=1e-6)
    assert all(np.all(np.abs(s) <= 1.0 + 1e-9) for s in spy.seen)


def test_sensor_sizes_must_match_the_observation():
    cfg = load_config(GrnConfig, PENDULUM)
    bad = replace(cfg, sensors=replace(cfg.sensors, n_visual=4, n_proprio=4))
    with pytest.raises(EvodevoError, match="n_proprio: 3"):
        Evaluator(bad, None)
    with pytest.raises(EvodevoError, match="--objects train"):
        make_env("Pendulum-v1", test_objects=True)


@pytest.mark.parametrize("kind", ["plain", "neuromodulated"])
def test_both_controllers_drive_pendulum(kind):
    cfg = load_config(GrnConfig, PENDULUM, {"controller": kind})
    with Evaluator(cfg, None) as ev:
        ctrl = make_controller(cfg, ev.n_actions)
        assert ev.n_actions == 1
        genomes = [ctrl.init_genome(np.random.default_rng(i)) for i in range(2)]
        eps = [Episode(i) for i in range(2)]
        res = ev.evaluate(genomes, eps)
        again = ev.evaluate(genomes, eps)
        rnd = ev.evaluate([None], eps, baseline="random")
    assert res.steps.tolist() == [[200, 200], [200, 200]]
    assert np.all(res.reward < 0) and np.array_equal(res.reward, again.reward)
    assert not np.array_equal(res.reward[0], rnd.reward[0])


@pytest.mark.parametrize("kind", ["plain", "neuromodulated"])
def test_cli_evolve_and_evaluate_on_pendulum(tmp_path, kind):
    out = tmp_path / kind
    runner = CliRunner()
    args = ["grn", "evolve", "--config", PENDULUM, "--controller", kind, "--population", "2"]
    args += ["--generations", "1", "--episodes", "1", "--out", str(out), "--quiet"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["controller"] == kind and summary["env_steps"] == 400
    res = runner.invoke(
        app, ["grn", "evaluate", str(out), "--objects", "train", "--test-episodes", "2", "--json"]
    )
    assert res.exit_code == 0, res.output
    result = json.loads(res.output.strip().splitlines()[-1])
    assert result["controller"] == kind and set(result["baselines"]) == {"zero", "random", "turn"}
    rows = (out / "eval_train_0_episodes.csv").read_text().splitlines()
    assert len(rows) == 1 + 4 * 2  # genome, zero, random and turn on the same two seeds
    res = runner.invoke(app, ["grn", "plot", str(out), "--objects", "train"])
    assert res.exit_code == 0, res.output
    names = {p.rsplit("/", 1)[-1] for p in res.output.split()}
    assert "expression_trace.png" in names
    assert ("modulator_trace.png" in names) == (kind == "neuromodulated")
