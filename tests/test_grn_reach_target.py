"""the shaped training fitness' reach to the target the front-end saw (SPEC §2.4).

``evaluation.distance_to: target`` measures the gripper's distance to the table point the blob
front-end localised on the first frame (the robot's own estimate and pose, no simulator object
pose), read when the automatic grasp starts or at the episode's end. One Kuka episode (~1.5 s).
"""

from __future__ import annotations

import numpy as np
import pytest

from evodevo.config import load_config
from evodevo.errors import ConfigError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.env_interface import grasp_distance
from evodevo.grn.frontends import BlobLocaliser, encode
from evodevo.grn.vision_preset import vision_preset

GRAY = 120


def _fe() -> BlobLocaliser:
    return BlobLocaliser(np.full((48, 48, 3), GRAY, np.uint8))


def _cfg(**evaluation: object) -> GrnConfig:
    d = vision_preset()
    d["evaluation"] = {**d["evaluation"], **evaluation}
    return load_config(GrnConfig, None, d)


def test_seen_target_is_the_first_frames_localisation_or_nan():
    fe = _fe()
    state = fe.reset(2)
    img = fe.background.copy()
    r, c = (round(v) for v in fe.table_to_pixel(0.6, 0.05))
    img[r - 1 : r + 2, c - 1 : c + 2] = (200, 30, 30)
    prop = np.array([[0.0, 0.0, 0.8, 1.0]] * 2)
    encode(fe, np.stack([img, fe.background]), prop, state, np.arange(2))
    np.testing.assert_allclose(fe.seen_target(state, 0), [0.6, 0.05], atol=0.006)
    assert np.isnan(fe.seen_target(state, 1)).all()  # no blob on slot 1's first frame
    assert np.isnan(fe.seen_target(fe.reset(1), 0)).all()  # nothing seen yet


def test_distance_to_is_checked():
    assert _cfg(distance_to="target").evaluation.distance_to == "target"
    with pytest.raises(ConfigError, match="distance_to"):
        _cfg(distance_to="centre")
    with pytest.raises(ConfigError, match="distance_to=target"):
        load_config(GrnConfig, None, {"evaluation": {"distance_to": "target"}})  # thesis CNN


class _Arm:
    """A stand-in for the env: where the gripper was at the grasp and where it is now."""

    def __init__(self, at_grasp: tuple[float, float], now: tuple[float, float]) -> None:
        self.gripper_xy_at_grasp = np.array(at_grasp)
        self._now = np.array(now)
        self.unwrapped = self

    def end_effector_xy(self) -> np.ndarray:
        return self._now

    def nearest_object_distance(self) -> float:
        return 0.5


def test_grasp_distance_to_a_target_reads_the_robots_own_pose():
    env = _Arm(at_grasp=(0.50, 0.00), now=(0.53, 0.04))
    target = np.array([0.50, 0.03])
    assert grasp_distance(env, "grasp", target) == pytest.approx(0.03)  # type: ignore[arg-type]
    assert grasp_distance(env, "end", target) == pytest.approx(np.hypot(0.03, 0.01))  # type: ignore[arg-type]
    assert grasp_distance(env, "end") == 0.5  # type: ignore[arg-type]  # nearest object
    no_grasp = _Arm(at_grasp=(np.nan, np.nan), now=(0.50, 0.07))
    assert grasp_distance(no_grasp, "grasp", target) == pytest.approx(0.04)  # type: ignore[arg-type]
    assert np.isnan(grasp_distance(env, "grasp", np.full(2, np.nan)))  # type: ignore[arg-type]


def test_a_blind_policy_is_scored_on_the_reach_to_the_target_its_front_end_saw():
    """The front-end runs for the blind control too; the distance is the gripper's at the grasp
    to the front-end's target, exactly."""
    pytest.importorskip("pybullet")
    from evodevo.grn.controller import PlainGrnController
    from evodevo.grn.evaluator import Episode, make_env, run_episodes

    d = vision_preset()
    d["sensors"] = {**d["sensors"], "blind": True}
    d["evaluation"] = {**d["evaluation"], "distance_at": "grasp", "distance_to": "target"}
    cfg = load_config(GrnConfig, None, d)
    ctrl = PlainGrnController(cfg, 3)
    assert not ctrl.uses_encoder
    env = make_env("evodevo/KukaDiverseObject-v0", {"max_steps": 8})
    fe = _fe()  # a grey "empty tray": the whole scene is one blob; the plumbing is under test
    seen: list[np.ndarray] = []
    reset, seen_target = fe.reset, fe.seen_target

    def keep_state(n: int):  # type: ignore[no-untyped-def]
        state = reset(n)
        seen.append(state)
        return state

    fe.reset = keep_state  # type: ignore[method-assign]
    try:
        g = ctrl.init_genome(np.random.default_rng(0))
        res = run_episodes(
            [env], fe, ctrl, [g], [Episode(3)], measure_distance=True,
            distance_at="grasp", distance_to="target",
        )  # fmt: skip
        u = env.unwrapped
        target = seen_target(seen[0], 0)
        assert np.isfinite(target).all()
        want = float(np.hypot(*(u.gripper_xy_at_grasp - target)))  # type: ignore[attr-defined]
        assert res["distance"][0] == pytest.approx(want, abs=1e-12)
        with pytest.raises(EvodevoError, match="distance_to=target"):
            run_episodes(
                [env], None, ctrl, [g], [Episode(3)], measure_distance=True, distance_to="target"
            )
    finally:
        env.close()
