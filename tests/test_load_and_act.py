"""``evodevo.load(run)`` → ``reset`` → ``predict`` for every trained object, acting
exactly as the evaluators do; the README's snippet runs as written."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import evodevo
from evodevo.cli import app
from evodevo.errors import EvodevoError
from evodevo.runs import read_json

pytestmark = pytest.mark.usefixtures("one_torch_thread")

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "configs" / "grn_pendulum.yaml"
runner = CliRunner()

TINY_BIARM = """
tasks:
  - {env_id: CartPole-v1, episodes: 3, max_steps: 40}
  - {env_id: Acrobot-v1, episodes: 2, max_steps: 40}
dqn: {batch_size: 16, learning_starts: 16}
modules: {sample_interval: 10}
eval: {episodes: 2}
"""
TINY_KUKA_BASELINE = """\
budget: {eval_every_steps: 8, eval_episodes: 1, checkpoint_every_steps: 8}
ppo: {n_steps: 8, batch_size: 8, n_epochs: 1}
"""


def _cli(*args: object) -> None:
    res = runner.invoke(app, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output


def _grn_run(out: Path, *extra: object) -> Path:
    _cli("grn", "evolve", "--config", PENDULUM, "--population", 2, "--generations", 1,
         "--episodes", 1, *extra, "--quiet", "--out", out)  # fmt: skip
    return out


def _episode(policy, env, seed: int) -> tuple[float, int]:
    """Total reward and steps of one episode acted by ``policy`` (the README loop)."""
    obs, info = env.reset(seed=seed)
    policy.reset(seed=seed)
    total, steps, reward = 0.0, 0, None
    while True:
        action = policy.predict(obs, info, reward)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
        if terminated or truncated:
            return total, steps


@pytest.mark.parametrize("controller", ["plain", "neuromodulated", "open_loop"])
def test_grn_policy_acts_as_the_evaluator(tmp_path, controller):
    from evodevo.grn.evaluation import load_run, test_episodes
    from evodevo.grn.evaluator import Evaluator

    run = _grn_run(tmp_path / controller, "--controller", controller)
    loaded = load_run(run)
    eps = test_episodes(11, 2, False)
    with Evaluator(loaded.config, loaded.encoder) as ev:
        res = ev.evaluate([loaded.genome], eps)
    policy = evodevo.load(run)
    env = policy.make_env()
    try:
        for j, ep in enumerate(eps):
            total, steps = _episode(policy, env, ep.seed)
            assert steps == res.steps[0, j]
            assert total == pytest.approx(res.reward[0, j], rel=1e-12, abs=1e-12)
    finally:
        env.close()


def test_neuromodulated_grn_asks_for_the_reward(tmp_path):
    policy = evodevo.load(_grn_run(tmp_path / "nm", "--controller", "neuromodulated"))
    env = policy.make_env()
    obs, info = env.reset(seed=0)
    policy.reset(seed=0)
    obs, *_, info = env.step(policy.predict(obs, info))
    with pytest.raises(EvodevoError, match="pass the previous step's reward"):
        policy.predict(obs, info)
    env.close()


def test_biarm_columns_act_as_evaluate_column(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY_BIARM)
    run = tmp_path / "biarm"
    _cli("biarm", "train", "--config", cfg, "--seed", 1, "--quiet", "--out", run)
    summary = read_json(run / "summary.json")
    with pytest.raises(EvodevoError, match="one column per task"):
        evodevo.load(run)
    first = evodevo.load(run, task=0)
    for i, t in enumerate(summary["tasks"]):
        policy = first.column(i) if i else first
        assert policy.env_id == t["env_id"] == evodevo.load(run, task=t["env_id"]).env_id
        env = policy.make_env()
        returns = [_episode(policy, env, s)[0] for s in summary["eval_seeds"]]
        env.close()
        assert returns == pytest.approx(t["eval_returns_final"], abs=1e-9)
    with pytest.raises(EvodevoError, match="not a column"):
        evodevo.load(run, task=5)


def test_kuka_baseline_policy_acts_as_the_evaluator(tmp_path):
    pytest.importorskip("stable_baselines3")
    from evodevo.grn.evaluation import load_run, test_episodes
    from evodevo.grn.evaluator import Evaluator

    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY_KUKA_BASELINE)
    run = tmp_path / "ppo"
    _cli("baselines", "kuka", "--method", "ppo", "--budget-steps", 8, "--config", cfg,
         "--quiet", "--out", run)  # fmt: skip
    loaded = load_run(run)
    eps = test_episodes(3, 1, True)
    with Evaluator(loaded.config, loaded.encoder) as ev:
        res = ev.evaluate([loaded.genome], eps)
    policy = evodevo.load(run)
    env = policy.make_env(test_objects=True)
    total, steps = _episode(policy, env, eps[0].seed)
    env.close()
    assert (total, steps) == (res.reward[0, 0], res.steps[0, 0])


def _readme_snippet() -> str:
    text = (ROOT / "README.md").read_text()
    m = re.search(r"<!-- load-and-act -->\s*```python\n(.*?)```", text, re.S)
    assert m, "README.md lost its load-and-act snippet"
    return m.group(1)


def test_readme_snippet_runs(tmp_path):
    """The README's snippet, as written, on the run directories `make run` writes (tiny ones)."""
    pytest.importorskip("pybullet")
    kuka = tmp_path / "runs" / "quick" / "grn" / "plain_s0"
    _cli("grn", "evolve", "--population", 2, "--generations", 1, "--episodes", 1,
         "--quiet", "--out", kuka)  # fmt: skip
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY_BIARM)
    biarm = tmp_path / "runs" / "quick" / "biarm" / "runs" / "biarm__s0"
    _cli("biarm", "train", "--config", cfg, "--quiet", "--out", biarm)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        scope: dict[str, object] = {}
        exec(compile(_readme_snippet(), "README.md", "exec"), scope)
    finally:
        os.chdir(cwd)
    assert isinstance(scope["action"], (int, np.integer))  # the last line acted with a column
