"""Related task sequences (SPEC §6): environment ids with parameters, the parametrised CartPole,
named sequences, and ``--tasks`` / ``--sequence`` on the command line."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from typer.testing import CliRunner

import evodevo.envs  # noqa: F401  (registers evodevo/CartPole-v1)
from evodevo.cli.biarm import app as biarm_app
from evodevo.config import replace
from evodevo.envs.env_ids import parse_env_id, split_env_ids
from evodevo.errors import ConfigError, EvodevoError
from evodevo.neuromod.config import BiarmConfig, TaskConfig
from evodevo.neuromod.sequences import load_sequence, sequence_names
from evodevo.neuromod.tasks import resolve_tasks, tasks_from_ids

runner = CliRunner()


def _rollout(env: gym.Env, seed: int, actions: list[int]) -> np.ndarray:
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for a in actions:
        obs, *_ = env.step(a)
        out.append(obs)
    return np.array(out)


def test_parametrised_cartpole_with_defaults_is_cartpole_v1() -> None:
    actions = [0, 1, 1, 0, 1, 0, 0, 1] * 3
    ours = _rollout(gym.make("evodevo/CartPole-v1"), 7, actions)
    theirs = _rollout(gym.make("CartPole-v1"), 7, actions)
    np.testing.assert_array_equal(ours, theirs)
    assert gym.make("evodevo/CartPole-v1").spec.max_episode_steps == 500


def test_a_longer_pole_changes_the_dynamics() -> None:
    actions = [1] * 10
    short = _rollout(gym.make("evodevo/CartPole-v1"), 7, actions)
    long = _rollout(gym.make("evodevo/CartPole-v1", length=1.0), 7, actions)
    np.testing.assert_array_equal(short[0], long[0])  # same start
    assert not np.allclose(short[-1], long[-1])


def test_ids_with_parameters_parse_and_split() -> None:
    assert parse_env_id("LunarLander-v3[gravity=-5,enable_wind=true]") == (
        "LunarLander-v3",
        {"gravity": -5, "enable_wind": True},
    )
    assert split_env_ids("a[x=1,y=2], b ,c[z=3]") == ["a[x=1,y=2]", "b", "c[z=3]"]
    for bad in ("a[x=1", "a]x[", "a[x]", "a[x=1,x=2]", "[x=1]"):
        with pytest.raises(ConfigError):
            split_env_ids(bad) if bad.count("[") != bad.count("]") else parse_env_id(bad)


def test_a_parameter_the_environment_does_not_take_is_one_clear_error() -> None:
    cfg = BiarmConfig(tasks=[TaskConfig("CartPole-v1[wind=3]", 2, 20)])
    with pytest.raises(EvodevoError, match=r"CartPole-v1\[wind=3\].*CartPole-v1 takes"):
        resolve_tasks(cfg)


def test_tasks_with_parameters_are_distinct_tasks_with_the_thesis_budget() -> None:
    cfg = BiarmConfig()
    ids = ["evodevo/CartPole-v1", "evodevo/CartPole-v1[length=1.0]", "LunarLander-v3[gravity=-5]"]
    tasks = tasks_from_ids(cfg, ids)
    assert [(t.env_id, t.episodes) for t in tasks] == [
        ("evodevo/CartPole-v1", 400),
        ("evodevo/CartPole-v1[length=1.0]", 400),
        ("LunarLander-v3[gravity=-5]", 800),
    ]
    specs, d_max = resolve_tasks(replace(cfg, tasks=tasks))
    assert [s.obs_dim for s in specs] == [4, 4, 8] and d_max == 8


def test_named_sequences_share_spaces_and_the_reversed_order_is_the_reverse() -> None:
    assert {"cartpole-dynamics", "cartpole-dynamics-reversed"} <= set(sequence_names())
    fwd = load_sequence("cartpole-dynamics")
    rev = load_sequence("cartpole-dynamics-reversed")
    assert [t.env_id for t in rev] == [t.env_id for t in reversed(fwd)]
    specs, _ = resolve_tasks(BiarmConfig(tasks=fwd))
    assert len(specs) == 4 and {(s.obs_dim, s.n_actions) for s in specs} == {(4, 2)}
    with pytest.raises(ConfigError, match="cartpole-dynamics"):
        load_sequence("nope")


def test_train_runs_a_named_sequence_and_refuses_both_tasks_and_sequence(tmp_path) -> None:
    out = tmp_path / "run"
    args = ["train", "--variant", "pnn", "--sequence", "cartpole-dynamics", "--quiet"]
    args += ["--episodes-scale", "0.003", "--set", "eval.episodes=1"]
    args += ["--set", "eval.validation_episodes=1", "--out", str(out)]
    res = runner.invoke(biarm_app, args)
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "summary.json").read_text())
    assert [t["env_id"] for t in summary["tasks"]] == [
        t.env_id for t in load_sequence("cartpole-dynamics")
    ]
    both = runner.invoke(
        biarm_app,
        ["train", "--tasks", "CartPole-v1", "--sequence", "cartpole-dynamics", "--out", str(out)],
    )
    assert both.exit_code != 0 and "give one of them" in str(both.exception)


def test_tasks_with_parameters_are_normalised_against_their_own_random_policy() -> None:
    """Forward transfer on a related sequence needs each task's anchors: the solved threshold of
    its base id and a random policy measured in that very environment."""
    from evodevo.evidence.normalise import solved_return, task_scale
    from evodevo.neuromod.continual_metrics import scale_of

    assert solved_return("evodevo/CartPole-v1[length=1.0]") == 475.0
    long_pole = task_scale("evodevo/CartPole-v1[length=1.0]", episodes=50)
    plain = task_scale("evodevo/CartPole-v1", episodes=50)
    assert long_pole.random_return != plain.random_return  # another task, another anchor
    assert scale_of("evodevo/CartPole-v1[length=1.0]", 500) is not None
    assert scale_of("evodevo/CartPole-v1[length=1.0]", 200) is None  # another step limit
