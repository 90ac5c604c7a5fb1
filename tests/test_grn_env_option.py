"""`grn evolve --env ID` drives any Gymnasium env with a Box observation and Box
actions, its sizes read from the spaces (no hand-edited config); the run evaluates and acts."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

import evodevo
from evodevo.cli import app
from evodevo.errors import EvodevoError
from evodevo.runs import read_json

pytestmark = pytest.mark.usefixtures("one_torch_thread")
runner = CliRunner()
TINY = ["--population", "2", "--generations", "1", "--episodes", "1", "--quiet"]


def _invoke(*args: object):
    res = runner.invoke(app, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output
    return res


@pytest.mark.parametrize("env_id, dim", [("Pendulum-v1", 3), ("MountainCarContinuous-v0", 2)])
def test_env_option_sizes_from_spaces(tmp_path, env_id, dim):
    out = tmp_path / "run"
    _invoke("grn", "evolve", "--env", env_id, *TINY, "--out", out)
    cfg = read_json(out / "config.json")["config"]
    assert cfg["env"] == {"id": env_id, "kwargs": {}}
    assert (cfg["sensors"]["n_visual"], cfg["sensors"]["n_proprio"]) == (0, dim)
    assert cfg["sensors"]["proprio"] is True  # the default preset hides proprioception, not this
    res = _invoke("grn", "evaluate", out, "--objects", "train", "--test-episodes", 1,
                  "--no-baselines", "--json", "--quiet")  # fmt: skip
    assert json.loads(res.stdout.strip().splitlines()[-1])["episodes"] == 1
    policy = evodevo.load(out)
    env = policy.make_env()
    obs, info = env.reset(seed=0)
    policy.reset(seed=0)
    assert env.action_space.contains(policy.predict(obs, info))
    env.close()


@pytest.mark.parametrize(
    "env_id, match",
    [("CartPole-v1", "flat continuous Box action"), ("NoSuchEnv-v0", "NoSuchEnv")],
)
def test_unusable_envs_fail_in_one_line_without_a_run(tmp_path, env_id, match):
    out = tmp_path / "run"
    with pytest.raises(EvodevoError, match=match):
        _invoke("grn", "evolve", "--env", env_id, *TINY, "--out", out)
    assert not out.exists()


def test_a_config_whose_env_cannot_be_made_leaves_no_run(tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("env: {id: NoSuchEnv-v0}\n")
    out = tmp_path / "run"
    with pytest.raises(EvodevoError, match="NoSuchEnv"):
        _invoke("grn", "evolve", "--config", cfg, *TINY, "--out", out)
    assert not out.exists()
