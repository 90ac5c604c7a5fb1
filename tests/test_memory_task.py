"""Tasks that need memory: the Kuka camera going dark (``dark_after``), the blob front-end and
the scripted reference policies on dark frames, and the classic-control tasks with the velocity
hidden (``evodevo/PendulumNoVelocity-v1``, ``evodevo/MountainCarContinuousNoVelocity-v0``)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from typer.testing import CliRunner

import evodevo.envs  # noqa: F401  (registers the env ids)
from evodevo.baselines import policies
from evodevo.config import from_dict, load_config, resolve
from evodevo.errors import ConfigError
from evodevo.grn.config import GrnConfig
from evodevo.grn.evaluation import default_baselines
from evodevo.grn.frontends import DXY_UNIT, BlobLocaliser
from evodevo.grn.vision_preset import vision_preset

ROOT = Path(__file__).resolve().parents[1]
KUKA = "evodevo/KukaDiverseObject-v0"
GRAY = 120


def _kuka(**kwargs):
    return gym.make(KUKA, **kwargs).unwrapped


def test_dark_after_zeroes_the_image_after_k_observations_and_nothing_else():
    lit, dark = _kuka(), _kuka(dark_after=2)
    try:
        o_lit, i_lit = lit.reset(seed=10_000)
        o_dark, i_dark = dark.reset(seed=10_000)
        seen = [(o_lit, o_dark)]
        action = np.array([0.5, -0.5, -1.0], np.float32)
        for _ in range(3):
            o_lit, r_lit, t_lit, tr_lit, i_lit = lit.step(action)
            o_dark, r_dark, t_dark, tr_dark, i_dark = dark.step(action)
            seen.append((o_lit, o_dark))
            # physics, reward and info are the same: only the picture differs
            assert (r_lit, t_lit, tr_lit) == (r_dark, t_dark, tr_dark)
            np.testing.assert_array_equal(i_lit["proprio"], i_dark["proprio"])
        for t, (a, b) in enumerate(seen):
            assert a.shape == b.shape == (48, 48, 3) and b.dtype == np.uint8
            assert a.any(), "a lit camera never shows an all-black frame"
            if t < 2:  # the reset's observation and the first step's are the camera's
                np.testing.assert_array_equal(a, b)
            else:
                assert not b.any()
    finally:
        lit.close()
        dark.close()


def test_dark_after_off_by_default_and_bad_values_are_refused():
    env = _kuka()
    try:
        assert env.dark_after is None
    finally:
        env.close()
    for bad in (-1, 1.5, True, "2"):
        with pytest.raises(ConfigError, match=r"dark_after=.*integer >= 0"):
            _kuka(dark_after=bad)


def _fe() -> BlobLocaliser:
    return BlobLocaliser(np.full((48, 48, 3), GRAY, np.uint8))


def _scene(fe: BlobLocaliser, x: float, y: float) -> np.ndarray:
    img = fe.background.copy()
    r, c = (round(v) for v in fe.table_to_pixel(x, y))
    img[r - 1 : r + 2, c - 1 : c + 2] = (200, 30, 30)
    return img[None]


def _proprio(ee_x: float, ee_y: float) -> np.ndarray:
    return np.array([[(ee_x - 0.575) / 0.075, (ee_y - 0.025) / 0.195, 0.8, 1.0]])


DARK = np.zeros((1, 48, 48, 3), np.uint8)


def test_a_dark_frame_carries_nothing_through_the_blob_front_end():
    fe = _fe()
    state = fe.reset(1)
    lit = fe.encode(_scene(fe, 0.6, 0.05), _proprio(0.53, 0.0), state, np.arange(1))[0]
    assert lit[3] == 1.0
    assert fe.encode(DARK, _proprio(0.53, 0.0), state, np.arange(1)).tolist() == [[0.0] * 4]
    # the front-end still holds what it saw: held() is what a lit frame would give
    held = fe.held(_proprio(0.47, 0.0), state, np.arange(1))[0]
    np.testing.assert_allclose(held[:2], lit[:2] + [1.0, 0.0], atol=1e-9)
    # a dark first frame is not the first look: nothing is localised on it
    state = fe.reset(1)
    fe.encode(DARK, _proprio(0.53, 0.0), state, np.arange(1))
    assert not state.seen[0] and not state.found[0]


def test_the_scripted_policy_turns_in_the_dark_its_remembering_twin_steers(monkeypatch):
    fe = _fe()
    monkeypatch.setattr(policies, "blob_frontend", lambda env_id, kwargs: fe)
    cfg = GrnConfig()
    plain = policies.ScriptedPolicy(cfg, 3)
    memory = policies.RememberingScriptedPolicy(cfg, 3)
    s_plain, s_memory = plain.reset_state([None]), memory.reset_state([None])
    idx, none = np.arange(1), np.zeros(1, bool)
    first = _scene(fe, 0.62, 0.05)
    a = plain.step(s_plain, idx, first, _proprio(0.53, 0.0), [], none)
    b = memory.step(s_memory, idx, first, _proprio(0.53, 0.0), [], none)
    np.testing.assert_array_equal(a, b)  # lit: the same policy
    assert a[0, 0] == 1.0  # 9 cm ahead in x: a full step
    a = plain.step(s_plain, idx, DARK, _proprio(0.59, 0.0), [], none)
    b = memory.step(s_memory, idx, DARK, _proprio(0.59, 0.0), [], none)
    assert a.tolist() == [[0.0, 0.0, -1.0]]  # nothing seen: the constant turn
    np.testing.assert_allclose(b[0, :2], [0.03 / DXY_UNIT, 0.05 / DXY_UNIT], atol=0.15)
    assert b[0, 2] == -1.0


def test_the_remembering_scripted_policy_runs_by_default_only_in_the_dark():
    lit = GrnConfig()
    dark = from_dict(GrnConfig, {"env": {"kwargs": {"max_steps": 8, "dark_after": 2}}})
    assert "scripted" in default_baselines(lit) and "scripted_memory" not in default_baselines(lit)
    assert {"scripted", "scripted_memory"} <= set(default_baselines(dark))


@pytest.mark.parametrize(
    ("env_id", "base", "kept"),
    [
        ("evodevo/PendulumNoVelocity-v1", "Pendulum-v1", [0, 1]),
        ("evodevo/MountainCarContinuousNoVelocity-v0", "MountainCarContinuous-v0", [0]),
    ],
)
def test_the_hidden_velocity_tasks_drop_the_velocity_and_keep_the_dynamics(env_id, base, kept):
    from gymnasium.utils.env_checker import check_env

    hidden, full = gym.make(env_id), gym.make(base)
    assert hidden.spec.max_episode_steps == full.spec.max_episode_steps
    assert hidden.observation_space.shape == (len(kept),)
    np.testing.assert_array_equal(hidden.observation_space.low, full.observation_space.low[kept])
    o_h, _ = hidden.reset(seed=3)
    o_f, _ = full.reset(seed=3)
    np.testing.assert_array_equal(o_h, o_f[kept])
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1, 1, full.action_space.shape).astype(np.float32)
        o_h, r_h, *_ = hidden.step(a)
        o_f, r_f, *_ = full.step(a)
        np.testing.assert_array_equal(o_h, o_f[kept])
        assert r_h == r_f
    with warnings.catch_warnings():  # gymnasium's advice on Pendulum's [-2, 2] action bounds
        warnings.simplefilter("ignore", UserWarning)
        check_env(gym.make(env_id).unwrapped)


def test_hide_velocity_refuses_bad_indices():
    from gymnasium.envs.classic_control.pendulum import PendulumEnv

    from evodevo.envs.hidden_velocity import HideVelocity

    for keep in ([], [0, 0], [3]):
        with pytest.raises(ConfigError, match=r"keep=.*distinct entries of the 3-value"):
            HideVelocity(PendulumEnv(), keep)


def test_grn_evolve_runs_on_the_hidden_velocity_pendulum(tmp_path):
    from evodevo.cli import app

    out = tmp_path / "run"
    res = CliRunner().invoke(
        app,
        [
            "grn", "evolve", "--env", "evodevo/PendulumNoVelocity-v1", "--out", str(out),
            "--population", "2", "--generations", "1", "--episodes", "1", "--quiet",
            "--set", "dynamics.restart=false",
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    saved = json.loads((out / "config.json").read_text())["config"]
    assert saved["env"]["id"] == "evodevo/PendulumNoVelocity-v1"
    assert saved["sensors"]["n_proprio"] == 2 and saved["sensors"]["n_visual"] == 0
    assert saved["dynamics"]["restart"] is False


MEMORY_YAML = ROOT / "configs" / "grn_memory.yaml"


def test_the_memory_yaml_is_the_vision_preset_in_the_dark_with_carried_expression():
    want = load_config(
        GrnConfig,
        None,
        {
            **vision_preset(),
            "dynamics": {**vision_preset()["dynamics"], "restart": False},
            "env": {
                "kwargs": {"max_steps": 8, "num_objects": 1, "lateral_dv": 0.02, "dark_after": 1}
            },
        },
    )
    assert load_config(GrnConfig, MEMORY_YAML) == want


@pytest.mark.parametrize(
    ("sets", "flags", "check"),
    [
        ([], {}, lambda c: c.controller == "plain" and not c.dynamics.restart),
        (["dynamics.restart=true"], {}, lambda c: c.controller == "plain" and c.dynamics.restart),
        ([], {"controller": "linear"}, lambda c: c.controller == "linear"),
        ([], {"controller": "mlp"}, lambda c: c.controller == "mlp"),
        (["env.kwargs.dark_after=2"], {}, lambda c: c.env.kwargs["dark_after"] == 2),
    ],
)
def test_the_arms_resolve_from_the_memory_yaml_through_set_and_controller(sets, flags, check):
    cfg = resolve(GrnConfig, path=MEMORY_YAML, sets=sets, flags=flags)
    assert check(cfg)
    assert cfg.env.kwargs["max_steps"] == 8 and cfg.sensors.encoder == "blob"


def test_grn_evolve_in_the_dark_through_the_cli(tmp_path):
    """The documented path: the memory config, the carried-over arm, k set with --set."""
    from evodevo.cli import app

    out = tmp_path / "dark"
    res = CliRunner().invoke(
        app,
        [
            "grn", "evolve", "--config", str(MEMORY_YAML), "--out", str(out),
            "--population", "2", "--generations", "1", "--episodes", "1", "--quiet",
            "--set", "env.kwargs.dark_after=2",
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    saved = json.loads((out / "config.json").read_text())["config"]
    assert saved["env"]["kwargs"] == {
        "max_steps": 8,
        "num_objects": 1,
        "lateral_dv": 0.02,
        "dark_after": 2,
    }
    assert saved["dynamics"]["restart"] is False and saved["sensors"]["encoder"] == "blob"


def test_lateral_dv_slows_the_sideways_moves_only():
    """The arm's target moves by lateral_dv per unit of dx, dy; the descent and the turn keep
    the benchmark's 0.06 m and 0.25 rad, so an episode lasts as long."""
    moves = {}
    for lateral in (None, 0.02):
        env = _kuka(lateral_dv=lateral)
        try:
            env.reset(seed=10_000)
            arm = env._arm  # the commanded end-effector target (not the lagging pose)
            before = np.array([*arm.end_effector_target, arm.end_effector_angle])
            env.step(np.array([0.5, -0.5, 1.0], np.float32))
            moves[lateral] = np.array([*arm.end_effector_target, arm.end_effector_angle]) - before
        finally:
            env.close()
    np.testing.assert_allclose(moves[None][:3], [0.03, -0.03, -0.06], atol=1e-6)
    np.testing.assert_allclose(moves[0.02][:3], [0.01, -0.01, -0.06], atol=1e-6)
    assert moves[None][3] == moves[0.02][3] != 0.0
    for bad in (0, -0.01, "fast", True):
        with pytest.raises(ConfigError, match=r"lateral_dv=.*positive number"):
            _kuka(lateral_dv=bad)
