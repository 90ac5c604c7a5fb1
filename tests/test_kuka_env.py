"""Tests of the Gymnasium port of KukaDiverseObjectEnv (SPEC §3)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import gymnasium as gym
import numpy as np
import pybullet as p
import pytest
from gymnasium.utils.env_checker import check_env

import evodevo.envs
from evodevo.envs import ENV_ID, KukaDiverseObjectEnv, is_test_object, object_files
from evodevo.errors import EvodevoError

# Cheap settings for tests that only need the mechanics, not a full benchmark episode.
CHEAP = {"num_objects": 2, "max_steps": 3}


@pytest.fixture(scope="module")
def env() -> Iterator[KukaDiverseObjectEnv]:
    e = KukaDiverseObjectEnv()
    yield e
    e.close()


def _episode(e: gym.Env, seed: int, action: np.ndarray) -> list[np.ndarray]:
    obs, info = e.reset(seed=seed)
    out = [obs, info["proprio"]]
    done = False
    while not done:
        obs, r, term, trunc, info = e.step(action)
        out += [obs, info["proprio"], np.array([r])]
        done = term or trunc
    return out


def test_registered_and_make_kwargs() -> None:
    assert ENV_ID in gym.registry
    evodevo.envs.register_envs()  # a second registration is a no-op
    e = gym.make(ENV_ID, test_objects=True, **CHEAP)
    try:
        assert isinstance(e.unwrapped, KukaDiverseObjectEnv)
        assert e.unwrapped.test_objects and e.unwrapped.num_objects == 2
        assert e.action_space == gym.spaces.Box(-1, 1, (3,), np.float32)
    finally:
        e.close()


def test_reset_obs_and_info(env: KukaDiverseObjectEnv) -> None:
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.uint8 and obs.shape == (48, 48, 3)
    assert env.observation_space.contains(obs)
    assert set(info) >= {"proprio", "is_success"} and info["is_success"] is False
    pr = info["proprio"]
    assert pr.dtype == np.float32 and pr.shape == (4,)
    assert np.all(np.abs(pr) <= 1.5)


def test_seeded_reset_is_reproducible(env: KukaDiverseObjectEnv) -> None:
    obs_a, info_a = env.reset(seed=11)
    env.step(np.array([0.5, -0.5, 1.0], np.float32))  # disturb the world in between
    obs_b, info_b = env.reset(seed=11)
    obs_c, _ = env.reset(seed=12)
    assert np.array_equal(obs_a, obs_b)
    assert np.array_equal(info_a["proprio"], info_b["proprio"])
    assert not np.array_equal(obs_a, obs_c)


def test_height_hack_episode(env: KukaDiverseObjectEnv) -> None:
    env.reset(seed=4)
    steps = 0
    for _ in range(env.max_steps):
        steps += 1
        obs, reward, term, trunc, info = env.step(np.array([0.0, 0.0, -1.0], np.float32))
        assert obs.shape == (48, 48, 3) and obs.dtype == np.uint8
        assert reward in (0.0, 1.0)
        assert isinstance(info["is_success"], bool) and info["is_success"] == (reward == 1.0)
        assert info["proprio"].dtype == np.float32 and np.all(np.abs(info["proprio"]) <= 1.5)
        if term or trunc:
            break
    assert term or trunc
    assert steps <= env.max_steps


def test_check_env() -> None:
    e = KukaDiverseObjectEnv(**CHEAP)
    try:
        check_env(e, skip_render_check=True)
    finally:
        e.close()


def test_test_objects_are_the_held_out_tenth() -> None:
    train, test = object_files(test=False), object_files(test=True)
    assert len(train) == 900 and len(test) == 100
    assert not set(train) & set(test)
    assert all(is_test_object(f) for f in test) and not any(is_test_object(f) for f in train)
    assert {os.path.basename(os.path.dirname(f))[-1] for f in test} == {"0"}
    e = KukaDiverseObjectEnv(test_objects=True)
    try:
        assert e._files == test
    finally:
        e.close()


def test_two_instances_do_not_interfere() -> None:
    act = np.array([0.2, -0.3, 0.5], np.float32)
    alone = []
    for seed in (1, 2):
        e = KukaDiverseObjectEnv(**CHEAP)
        alone.append(_episode(e, seed, act))
        e.close()
    a, b = KukaDiverseObjectEnv(**CHEAP), KukaDiverseObjectEnv(**CHEAP)
    try:
        ra, rb = list(a.reset(seed=1)[0:1]), list(b.reset(seed=2)[0:1])
        for _ in range(CHEAP["max_steps"]):
            ra.append(a.step(act)[0])
            rb.append(b.step(act)[0])
        for got, ref in ((ra, alone[0]), (rb, alone[1])):
            ref_obs = [ref[0]] + ref[2::3]
            assert len(got) == len(ref_obs)
            assert all(np.array_equal(x, y) for x, y in zip(got, ref_obs, strict=True))
    finally:
        a.close()
        b.close()


def test_vector_env() -> None:
    venv = gym.vector.SyncVectorEnv([lambda: gym.make(ENV_ID, **CHEAP) for _ in range(2)])
    try:
        obs, info = venv.reset(seed=[3, 4])
        assert obs.shape == (2, 48, 48, 3) and info["proprio"].shape == (2, 4)
        assert not np.array_equal(obs[0], obs[1])
        obs, r, term, trunc, info = venv.step(np.zeros((2, 3), np.float32))
        assert obs.shape == (2, 48, 48, 3) and r.shape == (2,)
    finally:
        venv.close()


@pytest.mark.parametrize(
    "kwargs",
    [
        {"num_objects": 0},
        {"max_steps": 0},
        {"camera_random": 2.0},
        {"render_mode": "human"},
        {"width": -1},
    ],
)
def test_bad_options(kwargs: dict) -> None:
    with pytest.raises(EvodevoError):
        KukaDiverseObjectEnv(**kwargs)


def test_bad_actions(env: KukaDiverseObjectEnv) -> None:
    env.reset(seed=0)
    with pytest.raises(EvodevoError, match="shape"):
        env.step(np.zeros(4))
    with pytest.raises(EvodevoError, match="finite"):
        env.step(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(EvodevoError):
        env.reset(seed=0, options={"num_objects": 3})


def test_other_action_spaces_and_render() -> None:
    e = KukaDiverseObjectEnv(height_hack=False, render_mode="rgb_array", **CHEAP)
    try:
        assert e.action_space.shape == (4,)
        e.reset(seed=0)
        e.step(np.array([0.0, 0.0, -1.0, 0.0], np.float32))
        frame = e.render()
        assert frame is not None and frame.shape[2] == 3 and frame.shape[0] > 48
    finally:
        e.close()
    d = KukaDiverseObjectEnv(is_discrete=True, **CHEAP)
    try:
        assert d.action_space == gym.spaces.Discrete(7)
        d.reset(seed=0)
        d.step(5)
        with pytest.raises(EvodevoError):
            d.step(7)
    finally:
        d.close()


# ---------------------------------------------------------------- against the original (slow)


def _env_speed():
    import importlib.util
    import pathlib

    path = pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / "env_speed.py"
    spec = importlib.util.spec_from_file_location("env_speed", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


_ORIG_PYTHON = _env_speed().orig_python()
requires_original = pytest.mark.skipif(
    _ORIG_PYTHON is None,
    reason="no isolated venv with the original (set EVODEVO_ORIG_PYTHON or create /work/origvenv)",
)


@pytest.mark.slow
@requires_original
@pytest.mark.parametrize("policy", ["down", "random"])
def test_bit_identical_to_original(policy: str) -> None:
    """With the original's pair order, a fresh instance replays the original bit for bit."""
    es = _env_speed()
    seeds = [0, 1, 2]
    ours = es.run_worker("ours", policy, seeds, exact=True)
    orig = es.run_worker("orig", policy, seeds, python=_ORIG_PYTHON)
    assert ours["rewards"] == orig["rewards"]
    assert ours["steps"] == orig["steps"]
    assert ours["digests"] == orig["digests"]


@pytest.mark.slow
@requires_original
def test_success_rate_matches_original() -> None:
    """SPEC §3: same success rate as the original under a seeded random policy."""
    es = _env_speed()
    res = es.compare_success(episodes=80, policies=("random",), orig=_ORIG_PYTHON, jobs=2)
    row = res["random"]
    lo_a, hi_a = row["ours"]["wilson95"]
    lo_b, hi_b = row["orig"]["wilson95"]
    assert lo_a <= hi_b and lo_b <= hi_a, row
    assert row["fisher_p"] > 0.01, row


def test_rebuilt_world_gives_the_same_episodes_and_bounds_memory() -> None:
    """Every ``rebuild_every`` resets the client is replaced (PyBullet keeps ~70 KB per
    loadURDF until a disconnect); an episode is the same in a fresh or a reused world."""
    act = np.array([0.3, -0.2, -0.7], np.float32)
    kept = KukaDiverseObjectEnv(rebuild_every=0, **CHEAP)
    rebuilt = KukaDiverseObjectEnv(rebuild_every=2, **CHEAP)
    try:
        for seed in (5, 6, 7, 8, 9):
            a, b = _episode(kept, seed, act), _episode(rebuilt, seed, act)
            assert len(a) == len(b)
            assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True)), seed
        assert (kept.worlds_built, rebuilt.worlds_built) == (1, 3)  # resets 1-2, 3-4, 5
        # the same bodies (plane, table, tray, arm and the objects) in both worlds
        n = [p.getNumBodies(physicsClientId=e._cid) for e in (kept, rebuilt)]
        assert n[0] == n[1] == 4 + CHEAP["num_objects"]
    finally:
        kept.close()
        rebuilt.close()
    with pytest.raises(EvodevoError, match="rebuild_every"):
        KukaDiverseObjectEnv(rebuild_every=-1)
