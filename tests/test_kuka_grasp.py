"""The automatic grasp's skipped lift of KukaDiverseObject-v0 (SPEC §3).

``skip_empty_lift`` may stop the lift early only when that cannot change the outcome: with a
fixed seed and actions, on and off give the same reward, ``terminated`` and ``is_success``; a
failed grasp really runs fewer simulation steps; a successful one runs them all and is the same
episode bit for bit. The 200-episode identity run over four policies is
``benchmarks/lift_identity.py``. Four full episodes (~1 s each).
"""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from evodevo.envs import KukaDiverseObjectEnv, kuka_grasp
from evodevo.envs.kuka_grasp import GRASP_CLOSE_STEPS, GRASP_LIFT_STEPS
from evodevo.envs.scene_cache import SceneCache
from evodevo.errors import ConfigError
from evodevo.grn.evaluator import make_env

DOWN = np.array([0.0, 0.0, -1.0], np.float32)  # constant turn: succeeds in about half the seeds
SUCCEEDS, FAILS = 0, 1  # seeds of DOWN with a grasp that succeeds / fails


def _episode(env: KukaDiverseObjectEnv, seed: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Every observation and proprio of the episode, and its last (reward, term, trunc, success)."""
    obs, info = env.reset(seed=seed)
    frames = [obs, info["proprio"]]
    done = False
    while not done:
        obs, r, term, trunc, info = env.step(DOWN)
        frames += [obs, info["proprio"]]
        done = term or trunc
    return frames, np.array([r, term, trunc, info["is_success"]], np.float64)


@pytest.fixture(scope="module")
def envs():
    cache = SceneCache()  # shared: the second env's resets are hits, same scenes
    skip = KukaDiverseObjectEnv(scene_cache=cache)
    full = KukaDiverseObjectEnv(scene_cache=cache, skip_empty_lift=False)
    yield skip, full
    skip.close()
    full.close()


class _CountingPybullet:
    """``pybullet`` for :mod:`evodevo.envs.kuka_grasp`, counting the grasp's simulation steps."""

    def __init__(self) -> None:
        self.steps = 0

    def stepSimulation(self, *args, **kwargs):  # noqa: N802 - pybullet's name
        self.steps += 1
        return p.stepSimulation(*args, **kwargs)

    def __getattr__(self, name: str):
        return getattr(p, name)


def _counted(monkeypatch, env: KukaDiverseObjectEnv, seed: int):
    """The episode and the number of simulation steps its automatic grasp ran."""
    counter = _CountingPybullet()
    with monkeypatch.context() as m:
        m.setattr(kuka_grasp, "p", counter)
        return (*_episode(env, seed), counter.steps)


def test_failed_grasp_skips_the_rest_of_the_lift_with_the_same_outcome(envs, monkeypatch) -> None:
    skip, full = envs
    assert skip.skip_empty_lift and not full.skip_empty_lift  # on by default
    grasps, lifts, steps = skip.grasps, skip.lifts_skipped, skip.lift_steps_skipped
    frames_s, out_s, n_s = _counted(monkeypatch, skip, FAILS)
    frames_f, out_f, n_f = _counted(monkeypatch, full, FAILS)
    assert out_s.tolist() == out_f.tolist() == [0.0, 1.0, 0.0, 0.0]  # grasped, failed
    assert (skip.grasps - grasps, skip.lifts_skipped - lifts) == (1, 1)
    assert full.lifts_skipped == full.lift_steps_skipped == 0
    saved = skip.lift_steps_skipped - steps
    assert 0 < saved < GRASP_LIFT_STEPS
    assert n_f == GRASP_CLOSE_STEPS + GRASP_LIFT_STEPS
    assert n_f - n_s == saved  # the steps really did not run
    # everything before the grasp is the same; the terminal proprio shows the arm lower
    assert all(np.array_equal(a, b) for a, b in zip(frames_s[:-2], frames_f[:-2], strict=True))
    assert frames_s[-1][2] < frames_f[-1][2]


def test_successful_grasp_lifts_fully_and_is_the_same_episode(envs) -> None:
    skip, full = envs
    before = (skip.lifts_skipped, skip.lift_steps_skipped)
    frames_s, out_s = _episode(skip, SUCCEEDS)
    frames_f, out_f = _episode(full, SUCCEEDS)
    assert out_s.tolist() == out_f.tolist() == [1.0, 1.0, 0.0, 1.0]
    assert (skip.lifts_skipped, skip.lift_steps_skipped) == before
    assert all(np.array_equal(a, b) for a, b in zip(frames_s, frames_f, strict=True))


def test_option_is_validated_and_reaches_the_env_through_gym_make() -> None:
    with pytest.raises(ConfigError, match="skip_empty_lift='yes'"):
        KukaDiverseObjectEnv(skip_empty_lift="yes")  # type: ignore[arg-type]
    # the path of the GRN evaluator and of config files: env.kwargs -> gymnasium.make
    for kwargs, expected in (({"max_steps": 8}, True), ({"skip_empty_lift": False}, False)):
        env = make_env("evodevo/KukaDiverseObject-v0", kwargs)
        try:
            assert env.unwrapped.skip_empty_lift is expected  # type: ignore[attr-defined]
        finally:
            env.close()


def test_distance_shaped_training_keeps_the_full_lift() -> None:
    """The shaped fitness reads the gripper's end pose, which a skipped lift moves."""
    import dataclasses

    from evodevo.grn.config import GrnConfig
    from evodevo.grn.evaluator import evaluator_env_kwargs

    cfg = GrnConfig()
    assert "skip_empty_lift" not in evaluator_env_kwargs(cfg)  # the env's default: on
    shaped = dataclasses.replace(
        cfg, evaluation=dataclasses.replace(cfg.evaluation, distance_weight=1.0)
    )
    assert evaluator_env_kwargs(shaped)["skip_empty_lift"] is False
    chosen = dataclasses.replace(
        shaped, env=dataclasses.replace(cfg.env, kwargs={"skip_empty_lift": True})
    )
    assert evaluator_env_kwargs(chosen)["skip_empty_lift"] is True


def test_distance_at_grasp_reads_the_reach_and_keeps_the_skipped_lift() -> None:
    """``evaluation.distance_at: grasp`` reads the distance when the automatic grasp starts
    (recorded by the env, NaN before), so the skipped lift stays on; bad values are refused."""
    import dataclasses

    from evodevo.grn.config import EvaluationConfig, GrnConfig
    from evodevo.grn.env_interface import evaluator_env_kwargs, grasp_distance

    cfg = GrnConfig()
    at_grasp = dataclasses.replace(
        cfg,
        evaluation=dataclasses.replace(cfg.evaluation, distance_weight=1.0, distance_at="grasp"),
    )
    assert "skip_empty_lift" not in evaluator_env_kwargs(at_grasp)
    with pytest.raises(ConfigError, match="distance_at"):
        EvaluationConfig(distance_at="start").validate()
    env = KukaDiverseObjectEnv(max_steps=8)
    try:
        env.reset(seed=SUCCEEDS)
        assert np.isnan(env.distance_at_grasp)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(DOWN)
            done = term or trunc
        assert term and np.isfinite(env.distance_at_grasp)
        assert grasp_distance(env, "grasp") == env.distance_at_grasp
        assert info["is_success"]  # a grasped object was within the fingers' reach
        assert env.distance_at_grasp < 0.08  # object base to end effector; 5.7 cm here
        env.reset(seed=FAILS)
        assert np.isnan(env.distance_at_grasp)
    finally:
        env.close()
