"""the blob front-end, substeps, front-end records in genomes, the vision preset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from evodevo.config import load_config
from evodevo.errors import CheckpointError, ConfigError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.dynamics import expression_step, motor_output
from evodevo.grn.frontends import DXY_UNIT, BlobLocaliser, check_features, encode
from evodevo.grn.genome import init_genome

ROOT = Path(__file__).resolve().parents[1]
GRAY = 120


def _fe() -> BlobLocaliser:
    return BlobLocaliser(np.full((48, 48, 3), GRAY, np.uint8))


def _image(fe: BlobLocaliser, points: list[tuple[float, float]], half: int = 1) -> np.ndarray:
    """The empty tray with a red square (2·half+1 pixels wide) at each table point (x, y)."""
    img = fe.background.copy()
    for x, y in points:
        r, c = (round(v) for v in fe.table_to_pixel(x, y))
        img[r - half : r + half + 1, c - half : c + half + 1] = (200, 30, 30)
    return img[None]


def _proprio(ee_x: float, ee_y: float) -> np.ndarray:
    """Proprioception of a gripper at table (ee_x, ee_y) (the env's normalisation)."""
    return np.array([[(ee_x - 0.575) / 0.075, (ee_y - 0.025) / 0.195, 0.8, 1.0]])


def _features(fe: BlobLocaliser, img: np.ndarray, prop: np.ndarray) -> np.ndarray:
    return encode(fe, img, prop, fe.reset(1), np.arange(1))[0]


def test_pixel_table_round_trip():
    fe = _fe()
    for x, y in [(0.5, 0.0), (0.62, -0.1), (0.45, 0.12)]:
        r, c = fe.table_to_pixel(x, y)
        np.testing.assert_allclose(fe.pixel_to_table(r, c), [x, y], atol=1e-9)


def test_one_object_gives_its_offset_from_the_gripper():
    fe = _fe()
    f = _features(fe, _image(fe, [(0.6, 0.05)]), _proprio(0.53, 0.0))
    assert f[3] == 1.0 and 0.3 < f[2] < 0.6  # 9 pixels / 20
    # a 3x3 square's centroid is its centre pixel: within half a pixel (~0.5 cm) of the point
    np.testing.assert_allclose(f[:2], [(0.6 - 0.53) / DXY_UNIT, 0.05 / DXY_UNIT], atol=0.15)


def test_no_object_gives_zeros():
    fe = _fe()
    assert _features(fe, fe.background[None], _proprio(0.53, 0.0)).tolist() == [0, 0, 0, 0]


def test_two_objects_the_one_nearest_the_gripper():
    fe = _fe()
    img = _image(fe, [(0.45, -0.1), (0.62, 0.1)])
    near_second = _features(fe, img, _proprio(0.6, 0.08))
    np.testing.assert_allclose(near_second[:2], [0.02 / DXY_UNIT, 0.02 / DXY_UNIT], atol=0.15)
    near_first = _features(fe, img, _proprio(0.48, -0.05))
    np.testing.assert_allclose(near_first[:2], [-0.03 / DXY_UNIT, -0.05 / DXY_UNIT], atol=0.15)


def test_object_under_the_gripper_and_the_target_is_held():
    fe = _fe()
    state = fe.reset(1)
    f0 = encode(fe, _image(fe, [(0.55, 0.02)]), _proprio(0.55, 0.02), state, np.arange(1))[0]
    np.testing.assert_allclose(f0[:2], [0.0, 0.0], atol=0.15)
    # later frames: the arm occludes the tray; the target of the first frame is kept and the
    # offset follows the gripper (here moved 6 cm in -x)
    f1 = encode(fe, fe.background[None], _proprio(0.49, 0.02), state, np.arange(1))[0]
    np.testing.assert_allclose(f1[:2], f0[:2] + [1.0, 0.0], atol=1e-9)
    assert f1[3] == 1.0


def test_offsets_are_clipped_and_tiny_blobs_ignored():
    fe = _fe()
    far = _features(fe, _image(fe, [(0.7, 0.15)]), _proprio(0.45, -0.17))
    assert abs(far[0]) <= 3.0 and abs(far[1]) <= 3.0
    img = fe.background.copy()[None]
    img[0, 20, 20] = (0, 255, 0)  # a one-pixel speck is noise, not an object
    assert _features(fe, img, _proprio(0.5, 0.0))[3] == 0.0


def test_bad_observations_and_features_are_clear_errors():
    fe = _fe()
    with pytest.raises(EvodevoError, match="camera images"):
        fe.encode(np.zeros((1, 8)), np.zeros((1, 4)), fe.reset(1), np.arange(1))
    with pytest.raises(EvodevoError, match="uint8"):
        fe.encode(np.zeros((1, 48, 48, 3)), np.zeros((1, 4)), fe.reset(1), np.arange(1))
    with pytest.raises(EvodevoError, match="non-finite"):
        check_features(np.array([[0.0, np.nan]]), "blob")


def test_config_choices_are_checked():
    with pytest.raises(ConfigError, match="encoder"):
        load_config(GrnConfig, None, {"sensors": {"encoder": "sift"}})
    with pytest.raises(ConfigError, match="feature_dim"):
        load_config(GrnConfig, None, {"sensors": {"encoder": "blob"}})
    with pytest.raises(ConfigError, match="substeps"):
        load_config(GrnConfig, None, {"dynamics": {"substeps": 0}})


def _old_step(ctrl, state, idx, feats, prop, rngs, noisy):
    """The controller step before substeps existed (one Euler step), for the bit-for-bit test."""
    g = state.genome
    s, eta = ctrl.sense(g.P[idx], state.x.shape[1], feats, prop, rngs, noisy)
    x = expression_step(
        state.x[idx], s, g.W_s[idx], g.W_r[idx], g.theta[idx], g.delta[idx], g.alpha[idx],
        ctrl.dyn.dt, eta,
    )  # fmt: skip
    state.x[idx] = x
    return motor_output(x, g.W_m[idx])


def test_substeps_1_is_the_thesis_step_bit_for_bit():
    cfg = GrnConfig()
    assert cfg.dynamics.substeps == 1
    ctrl = PlainGrnController(cfg, 3)
    gs = [init_genome(cfg, 3, np.random.default_rng(i)) for i in range(3)]
    new, old = ctrl.reset_state(gs), ctrl.reset_state(gs)
    data = np.random.default_rng(9)
    for _ in range(7):
        feats, prop = data.normal(size=(3, 128)), data.normal(size=(3, 4))
        noisy = np.array([False, True, True])
        a = ctrl.step(new, np.arange(3), feats, prop, [np.random.default_rng(5)] * 3, noisy)
        b = _old_step(ctrl, old, np.arange(3), feats, prop, [np.random.default_rng(5)] * 3, noisy)
        assert np.array_equal(a, b) and np.array_equal(new.x, old.x)


def test_substeps_k_is_k_euler_steps_on_one_input():
    cfg = load_config(GrnConfig, None, {"dynamics": {"substeps": 3, "noise_std": 0.0}})
    ctrl = PlainGrnController(cfg, 3)
    g = init_genome(cfg, 3, np.random.default_rng(0))
    state = ctrl.reset_state([g])
    feats, prop = np.full((1, 128), 0.1), np.full((1, 4), 0.5)
    a = ctrl.step(state, np.arange(1), feats, prop, [np.random.default_rng(0)], np.array([False]))
    s = np.concatenate([feats @ g.P, prop], axis=1)
    x = np.full((1, 50), 0.3)
    for _ in range(3):
        x = expression_step(
            x, s, g.W_s[None], g.W_r[None], g.theta[None], g.delta[None], g.alpha[None], cfg.dynamics.dt,
            np.zeros((1, 50)),
        )  # fmt: skip
    np.testing.assert_allclose(state.x, x)
    np.testing.assert_allclose(a, motor_output(x, g.W_m[None]))


def _vision_cfg() -> GrnConfig:
    return load_config(GrnConfig, ROOT / "configs" / "grn_vision.yaml")


def test_genome_refuses_another_front_end(tmp_path):
    vis, cnn = _vision_cfg(), GrnConfig()
    from evodevo.config import to_dict

    g = init_genome(vis, 3, np.random.default_rng(0))
    np.testing.assert_array_equal(g.P, np.eye(4))  # p_init: identity
    g.save(tmp_path / "blob.npz", to_dict(vis))
    assert PlainGrnController(vis, 3).load_genome(tmp_path / "blob.npz").P.shape == (4, 4)
    with pytest.raises(CheckpointError, match="front-end 'blob'"):
        PlainGrnController(cnn, 3).load_genome(tmp_path / "blob.npz")
    c = init_genome(cnn, 3, np.random.default_rng(0))
    c.save(tmp_path / "cnn.npz", to_dict(cnn))
    with pytest.raises(CheckpointError, match="front-end 'cnn'"):
        PlainGrnController(vis, 3).load_genome(tmp_path / "cnn.npz")


def test_evaluator_refuses_a_front_end_other_than_the_configs():
    pytest.importorskip("pybullet")
    from evodevo.grn.encoder import Encoder
    from evodevo.grn.evaluator import Evaluator

    with pytest.raises(EvodevoError, match="front-end 'blob'"):
        Evaluator(_vision_cfg(), Encoder.from_seed(0))


def test_camera_model_is_the_envs_camera():
    pytest.importorskip("pybullet")
    import gymnasium as gym

    import evodevo.envs  # noqa: F401

    env = gym.make("evodevo/KukaDiverseObject-v0")
    try:
        env.reset(seed=0)
        u = env.unwrapped
        view = np.array(u._view_matrix).reshape(4, 4).T
        proj = np.array(u._proj_matrix).reshape(4, 4).T
    finally:
        env.close()
    fe = _fe()
    np.testing.assert_allclose(fe.view, view, atol=1e-6)
    np.testing.assert_allclose(fe.proj, proj, atol=1e-6)


def test_the_vision_yaml_is_the_default_preset():
    from evodevo.config import to_dict
    from evodevo.grn.vision_preset import vision_preset

    assert to_dict(_vision_cfg()) == to_dict(load_config(GrnConfig, None, vision_preset()))
    # the thesis file is the thesis defaults, unchanged
    assert to_dict(load_config(GrnConfig, ROOT / "configs" / "grn.yaml")) == to_dict(GrnConfig())


def test_smoke_evolution_with_the_default_preset_through_the_cli(tmp_path):
    """`grn evolve` without --config is the vision preset (2 genomes x 1 episode x 1 gen)."""
    pytest.importorskip("pybullet")
    import json

    from typer.testing import CliRunner

    from evodevo.cli import app

    out = tmp_path / "run"
    args = ["grn", "evolve", "--population", "2", "--generations", "1", "--episodes", "1"]
    res = CliRunner().invoke(app, [*args, "--quiet", "--out", str(out)])
    assert res.exit_code == 0, (res.output, res.exception)
    saved = json.loads((out / "config.json").read_text())["config"]
    assert saved["sensors"]["encoder"] == "blob" and saved["dynamics"]["substeps"] == 10
    assert saved["dynamics"]["restart"] is True and saved["sensors"]["proprio"] is False
    assert (out / "frontend.npz").is_file() and not (out / "encoder.pt").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["episodes_run"] == 2
    from evodevo.grn.evaluation import load_run

    loaded = load_run(out)
    assert loaded.encoder.name == "blob" and loaded.genome.P.shape == (4, 4)


def test_the_neuromodulated_grn_runs_on_the_blob_front_end():
    from evodevo.grn.neuromodulated import NeuromodGrnController

    cfg = load_config(GrnConfig, None, {**vision_preset_dict(), "controller": "neuromodulated"})
    ctrl = NeuromodGrnController(cfg, 3)
    g = ctrl.init_genome(np.random.default_rng(0))
    state = ctrl.reset_state([g, g])
    feats = np.array([[1.0, -0.5, 0.4, 1.0], [0.0, 0.0, 0.0, 0.0]])
    a = ctrl.step(state, np.arange(2), feats, np.zeros((2, 4)),
                  [np.random.default_rng(1), np.random.default_rng(2)], np.array([False, True]))  # fmt: skip
    assert a.shape == (2, 3) and np.all(np.isfinite(a))


def vision_preset_dict() -> dict:
    from evodevo.grn.vision_preset import vision_preset

    return vision_preset()
