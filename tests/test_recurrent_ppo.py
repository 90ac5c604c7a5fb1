"""RecurrentPPO (sb3-contrib) on the Kuka blob features: the recurrent baseline of the memory
task. It trains through `evodevo baselines kuka --method recurrent_ppo`, its model is saved
without pickle and loads back acting identically (LSTM state included), the evaluator runs it
with one LSTM state per episode, and a planted pickle under its file name runs no code."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml
from test_safe_loading import _forbid_unpickling, _refused, _sb3_zip
from typer.testing import CliRunner

import evodevo
from evodevo.config import from_dict, load_config, to_dict
from evodevo.errors import CheckpointError
from evodevo.runs import RunDir

pytest.importorskip("pybullet")
pytest.importorskip("sb3_contrib")

from evodevo.baselines.kuka_config import KukaBaselineConfig  # noqa: E402
from evodevo.baselines.policies import Sb3Model, load_sb3  # noqa: E402
from evodevo.baselines.recurrent_ppo import RecurrentPpoPolicy, build_recurrent_ppo  # noqa: E402
from evodevo.baselines.sb3_files import KIND, load_sb3_policy, restore_sb3  # noqa: E402
from evodevo.cli.baselines import app  # noqa: E402
from evodevo.grn.controller import make_controller  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread")

ROOT = Path(__file__).resolve().parents[1]
MEMORY_YAML = ROOT / "configs" / "baselines_kuka_memory.yaml"
STEPS = 192
TINY = f"""\
budget:
  eval_every_steps: {STEPS}
  eval_episodes: 1
  checkpoint_every_steps: {STEPS}
ppo:
  n_steps: 64
  batch_size: 32
  n_epochs: 1
recurrent_ppo:
  lstm_hidden_size: 8
evaluation:
  lockstep: 2
env:
  kwargs: {{max_steps: 8, num_objects: 1, lateral_dv: 0.02, dark_after: 1}}
"""


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A RecurrentPPO run of a few hundred env steps on the dark Kuka env's blob features."""
    folder = tmp_path_factory.mktemp("recurrent")
    cfg = folder / "tiny.yaml"
    cfg.write_text(TINY)
    out = folder / "run"
    args = ["kuka", "--method", "recurrent_ppo", "--budget-steps", str(STEPS)]
    res = CliRunner().invoke(app, [*args, "--config", str(cfg), "--out", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    return out


def _config(run: Path) -> KukaBaselineConfig:
    return from_dict(KukaBaselineConfig, json.loads((run / "config.json").read_text())["config"])


def _sequence(n_steps: int, n_envs: int) -> np.ndarray:
    """Blob-feature-like inputs: (steps, envs, 4), dark (all 0) from the second step on."""
    rng = np.random.default_rng(7)
    x = np.zeros((n_steps, n_envs, 4), np.float32)
    x[0, :, :2] = rng.uniform(-3, 3, (n_envs, 2))
    x[0, :, 2:] = (0.5, 1.0)
    return x


def _roll(policy: object, xs: np.ndarray) -> np.ndarray:
    """Deterministic actions of ``policy`` over ``xs``, its LSTM state carried between steps."""
    state, start, out = None, np.ones(xs.shape[1], bool), []
    for x in xs:
        a, state = policy.predict(x, state=state, episode_start=start, deterministic=True)  # type: ignore[attr-defined]
        start = np.zeros_like(start)
        out.append(a)
    return np.stack(out)


def test_recurrent_ppo_trains_on_the_kuka_features_to_the_step_budget(trained):
    summary = json.loads((trained / "summary.json").read_text())
    assert summary["method"] == "recurrent_ppo" and summary["env_steps"] == STEPS
    policy = load_sb3("recurrent_ppo", trained / "model.safetensors")
    assert policy.observation_space.shape == (4,)  # the blob features, not the image
    assert policy.lstm_hidden_state_shape == (1, 1, 8)  # the run's LSTM, not sb3-contrib's 256


def test_the_saved_model_loads_without_unpickling_and_acts_identically(trained, monkeypatch):
    cfg = _config(trained)
    model = build_recurrent_ppo(cfg, _feature_env(cfg))
    restore_sb3(model, trained / "model.safetensors")  # the trained weights, as on resume
    with monkeypatch.context() as m:
        _forbid_unpickling(m)
        loaded = load_sb3_policy("recurrent_ppo", trained / "model.safetensors")
    for a, b in zip(loaded.parameters(), model.policy.parameters(), strict=True):
        assert torch.equal(a, b)
    xs = _sequence(6, 3)
    want = _roll(model, xs)
    np.testing.assert_array_equal(_roll(loaded, xs), want)
    # the memory matters: the same dark inputs after another first frame give other actions
    assert not np.array_equal(want[1:, 0], want[1:, 1])


def test_the_evaluator_policy_keeps_one_lstm_state_per_episode(trained):
    cfg = _config(trained)
    ev_cfg = cfg.evaluator_config()
    assert ev_cfg.controller == "recurrent_ppo"
    assert isinstance(make_controller(ev_cfg, 3), RecurrentPpoPolicy)
    assert ev_cfg.sensors.encoder == "blob"
    pol = RecurrentPpoPolicy(ev_cfg, 3)
    pol.frontend = None  # feed the features directly (the front-end's own test is elsewhere)
    ref = Sb3Model("recurrent_ppo", str(trained / "model.safetensors"))
    xs = _sequence(5, 3)
    want = _roll(load_sb3("recurrent_ppo", ref.path), xs)
    state = pol.reset_state([ref] * 3)
    none = np.zeros(3, bool)
    got = [pol.step(state, np.arange(3), x, np.zeros((3, 4)), [], none) for x in xs[:2]]
    # slot 1 ends after two steps: the others go on alone, each with its own memory
    for x in xs[2:]:
        idx = np.array([0, 2])
        a = pol.step(state, idx, x[idx], np.zeros((2, 4)), [], none[idx])
        np.testing.assert_allclose(a, want[len(got)][idx], rtol=1e-6)
        got.append(np.zeros_like(want[0]))
    np.testing.assert_allclose(np.stack(got[:2]), want[:2], rtol=1e-6)


def test_the_run_is_evaluated_by_the_grn_evaluate_code(trained):
    from evodevo.cli.baselines import app as baselines_app

    res = CliRunner().invoke(
        baselines_app, ["evaluate", str(trained), "--test-episodes", "1", "--json"]
    )
    assert res.exit_code == 0, res.output
    result = json.loads(res.output.strip().splitlines()[-1])
    assert result["controller"] == "recurrent_ppo" and result["episodes"] == 1
    # in the dark both scripted reference policies run beside it
    assert {"scripted", "scripted_memory"} <= set(result["baselines"])


def _feature_env(cfg: KukaBaselineConfig) -> object:
    from stable_baselines3.common.vec_env import DummyVecEnv

    from evodevo.baselines.feature_env import FeatureObservation
    from evodevo.baselines.policies import blob_frontend
    from evodevo.grn.evaluator import make_env

    env = make_env(cfg.env.id, cfg.env.kwargs)
    return DummyVecEnv([lambda: FeatureObservation(env, blob_frontend(cfg.env.id, cfg.env.kwargs))])


@pytest.mark.parametrize("name", ["model.safetensors", "model.zip"])
def test_a_planted_recurrent_ppo_model_runs_no_code(tmp_path, name):
    run = RunDir(tmp_path / "rppo")
    cfg = from_dict(KukaBaselineConfig, {"method": "recurrent_ppo"})
    run.write_config(to_dict(cfg), kind="baseline")
    marker = tmp_path / "marker"
    planted = run.path / name
    planted.write_bytes(_sb3_zip(marker))
    _refused(lambda: evodevo.load(run.path), planted, marker)
    _refused(lambda: load_sb3("recurrent_ppo", run.path / "model.safetensors"), planted, marker)


def test_a_recurrent_model_naming_a_class_outside_the_allowlist_is_refused(trained, tmp_path):
    from evodevo.safe_io import load_state, save_state

    path = tmp_path / "evil.safetensors"
    state = load_state(trained / "model.safetensors", KIND)
    state["policy_params"]["features_extractor_class"] = {"class": "builtins.eval"}
    save_state(path, KIND, state)
    with pytest.raises(CheckpointError, match="names the class 'builtins.eval'"):
        load_sb3_policy("recurrent_ppo", path)
    # a PPO file is not a RecurrentPPO model
    with pytest.raises(CheckpointError, match="not a saved RECURRENT_PPO model"):
        state["algo"] = "ppo"
        save_state(path, KIND, state)
        load_sb3_policy("recurrent_ppo", path)


def test_the_memory_baseline_config_is_the_grns_memory_task():
    cfg = load_config(KukaBaselineConfig, MEMORY_YAML, {"method": "recurrent_ppo"})
    grn = yaml.safe_load((ROOT / "configs" / "grn_memory.yaml").read_text())
    assert cfg.env.kwargs == grn["env"]["kwargs"]  # the same task as the GRN arms
    assert cfg.env.kwargs["dark_after"] == 1 and cfg.ppo.encoder == "blob"
    assert cfg.evaluator_config().sensors.encoder == "blob"
