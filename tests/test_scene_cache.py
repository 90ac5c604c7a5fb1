"""The settled-scene cache of KukaDiverseObject-v0 (SPEC §2.4-2.5, §3).

A cached reset (hit) must give the same episode, bit for bit, as the reset that simulated the
drop (miss); the key must change with every setting of the drop; the memory bound must hold;
a corrupt or foreign on-disk entry is rebuilt and an unwritable folder falls back to memory.
The ≥ 200-episode identity run over several policies is ``benchmarks/scene_identity.py``.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import pybullet_data
import pytest

from evodevo.envs import KukaDiverseObjectEnv
from evodevo.envs import kuka_diverse_object as kdo
from evodevo.envs.scene_cache import SceneCache, SettledScene, key_digest, shared_cache
from evodevo.errors import ConfigError

# Two objects, three actions: the mechanics of a reset without a full benchmark episode.
CHEAP = {"num_objects": 2, "max_steps": 3}
ACTIONS = [np.array(a, np.float32) for a in ([0.3, -0.2, -0.7], [-1.0, 0.5, 1.0], [0, 0, 0])]


def _episode(env: KukaDiverseObjectEnv, seed: int, actions: list[np.ndarray]) -> list[np.ndarray]:
    """Every observation, proprioception and reward of one episode, and the RNG state after it."""
    obs, info = env.reset(seed=seed)
    out = [obs, info["proprio"]]
    done, i = False, 0
    while not done:
        obs, r, term, trunc, info = env.step(actions[min(i, len(actions) - 1)])
        out += [obs, info["proprio"], np.array([r, term, trunc, info["is_success"]])]
        done, i = term or trunc, i + 1
    out.append(env.np_random.integers(0, 2**62, 4))  # later draws continue identically
    return out


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def _fake_scene(i: int) -> SettledScene:
    return SettledScene(
        ("random_urdfs/001/001.urdf",),
        np.full((1, 3), float(i)),
        np.full((1, 13), 0.1 * i),
        np.zeros(14),
        np.zeros(14),
        seed=i,
    )


def _key(i: int) -> dict:
    return {"format": 1, "objects": [["x", float(i).hex()]], "settings": {}}


def test_hits_give_the_episodes_of_misses_bit_for_bit() -> None:
    cache = SceneCache()
    env = KukaDiverseObjectEnv(scene_cache=cache, **CHEAP)
    other = KukaDiverseObjectEnv(scene_cache=SceneCache(), **CHEAP)  # its own misses
    try:
        for seed in (0, 1, 2):
            miss = _episode(env, seed, ACTIONS)
            hit = _episode(env, seed, ACTIONS)
            assert _same(miss, hit), seed
            assert _same(miss, _episode(other, seed, ACTIONS)), seed
        assert (cache.misses, cache.hits, len(cache)) == (3, 3, 3)
        # an unseeded reset uses the same physics but is never stored
        env.reset()
        assert len(cache) == 3
    finally:
        env.close()
        other.close()


def test_full_episode_with_grasp_is_identical_after_a_hit() -> None:
    """A default (5 objects, 8 steps) episode that reaches the automatic grasp."""
    cache = SceneCache()
    env = KukaDiverseObjectEnv(scene_cache=cache)
    try:
        down = [np.array([0.0, 0.0, -1.0], np.float32)]
        miss, hit = _episode(env, 6, down), _episode(env, 6, down)
        assert miss[-2][1] == 1.0  # terminated: the grasp ran
        assert _same(miss, hit) and cache.hits == 1
    finally:
        env.close()


def test_legacy_path_is_kept_and_settles_in_its_own_world() -> None:
    """``scene_cache=False`` settles in the episode's world (bit-identity with the original);
    both paths drop the same objects at the same poses and draw the same numbers."""
    legacy = KukaDiverseObjectEnv(scene_cache=False, **CHEAP)
    cached = KukaDiverseObjectEnv(scene_cache=SceneCache(), **CHEAP)
    try:
        assert legacy.scene_cache is None
        a, b = _episode(legacy, 4, ACTIONS), _episode(cached, 4, ACTIONS)
        assert np.array_equal(a[-1], b[-1])  # same RNG stream after the episode
        assert legacy.worlds_built == cached.worlds_built == 1  # the scratch world is not counted
    finally:
        legacy.close()
        cached.close()


def test_key_changes_with_every_drop_setting_and_only_those(tmp_path, monkeypatch) -> None:
    base = KukaDiverseObjectEnv(scene_cache=SceneCache())
    try:
        k0 = key_digest(base.scene_key(3))
        assert key_digest(base.scene_key(3)) == k0  # no state: the same key twice
        root = tmp_path / "data"
        root.symlink_to(pybullet_data.getDataPath())
        changed = {
            "seed": base.scene_key(4),
            "test_objects": None,
            "num_objects": None,
            "block_random": None,
            "deterministic_pairs": None,
            "urdf_root": None,
        }
        variants = {
            "test_objects": {"test_objects": True},
            "num_objects": {"num_objects": 4},
            "block_random": {"block_random": 0.2},
            "deterministic_pairs": {"deterministic_pairs": False},
            "urdf_root": {"urdf_root": str(root)},
        }
        for name, kwargs in variants.items():
            e = KukaDiverseObjectEnv(scene_cache=False, **kwargs)
            changed[name] = e.scene_key(3)
            e.close()
        for const, value in (("SETTLE_STEPS", 499), ("DROP_HEIGHT", 0.2), ("GRAVITY", -9.81)):
            with monkeypatch.context() as m:
                m.setattr(kdo, const, value)
                e = KukaDiverseObjectEnv(scene_cache=False)
                changed[const] = e.scene_key(3)
                e.close()
        digests = {name: key_digest(k) for name, k in changed.items()}
        assert all(d != k0 for d in digests.values()), digests
        assert len(set(digests.values())) == len(digests)
        # settings that do not change the drop keep the key
        for kwargs in (
            {"camera_random": 1.0},
            {"max_steps": 3},
            {"width": 32, "height": 32},
            {"height_hack": False},
            {"action_repeat": 40},
            {"rebuild_every": 0},
        ):
            e = KukaDiverseObjectEnv(scene_cache=False, **kwargs)
            assert key_digest(e.scene_key(3)) == k0, kwargs
            e.close()
    finally:
        base.close()


def test_lru_bound_holds() -> None:
    cache = SceneCache(max_entries=2)
    for i in range(3):
        cache.put(_key(i), _fake_scene(i))
    assert len(cache) == 2 and cache.get(_key(0)) is None  # the oldest went first
    assert cache.get(_key(1)) is not None  # 1 is now the most recent
    cache.put(_key(3), _fake_scene(3))
    assert cache.get(_key(2)) is None and cache.get(_key(1)) is not None
    assert len(cache) == 2
    with pytest.raises(ValueError, match="max_entries"):
        SceneCache(max_entries=0)


def test_env_uses_a_bounded_shared_cache() -> None:
    env = KukaDiverseObjectEnv(scene_cache_entries=7, **CHEAP)
    try:
        assert env.scene_cache is shared_cache() and env.scene_cache.max_entries >= 7
        with pytest.raises(ConfigError, match="scene_cache_entries"):
            KukaDiverseObjectEnv(scene_cache_entries=0)
        with pytest.raises(ConfigError, match="scene_cache"):
            KukaDiverseObjectEnv(scene_cache="yes")  # type: ignore[arg-type]
    finally:
        env.close()


def test_disk_entries_round_trip_and_bad_ones_are_rebuilt(tmp_path, caplog) -> None:
    folder = str(tmp_path / "scenes")
    first = SceneCache(directory=folder)
    assert first.on_disk
    for i in range(3):
        first.put(_key(i), _fake_scene(i))
    fresh = SceneCache(directory=folder)  # a new session: empty memory
    got = fresh.get(_key(1))
    assert got is not None and np.array_equal(got.objects, _fake_scene(1).objects)
    assert got.seed == 1 and got.files == _fake_scene(1).files

    paths = {i: os.path.join(folder, key_digest(_key(i)) + ".json") for i in range(3)}
    raw = Path(paths[0]).read_bytes()
    Path(paths[0]).write_bytes(raw[:-5] + b"9" + raw[-4:])  # corrupt: one byte changed
    # foreign: another scene's valid entry under this name
    Path(paths[2]).write_bytes(Path(paths[1]).read_bytes())
    with caplog.at_level(logging.WARNING, logger="evodevo.envs.scene_cache"):
        assert fresh.get(_key(0)) is None and fresh.get(_key(2)) is None
    msgs = [r.getMessage() for r in caplog.records]
    assert len(msgs) == 2 and all("\n" not in m and "rebuilding" in m for m in msgs)
    assert "checksum" in msgs[0] and "foreign" in msgs[1]
    assert fresh.rebuilt == 2
    fresh.put(_key(0), _fake_scene(0))  # what the env does after a miss
    assert SceneCache(directory=folder).get(_key(0)) is not None


def test_corrupt_entry_is_rebuilt_by_the_env(tmp_path, caplog) -> None:
    folder = str(tmp_path / "scenes")
    env = KukaDiverseObjectEnv(scene_cache=SceneCache(directory=folder), **CHEAP)
    try:
        ref = _episode(env, 5, ACTIONS)
        (entry,) = [f for f in os.listdir(folder) if f.endswith(".json")]
        path = os.path.join(folder, entry)
        with open(path, "r+b") as fh:
            fh.seek(len("evodevo-settled-scene "))
            fh.write(b"0")  # a version this code does not write
        env.scene_cache = SceneCache(directory=folder)
        with caplog.at_level(logging.WARNING, logger="evodevo.envs.scene_cache"):
            again = _episode(env, 5, ACTIONS)
        assert _same(ref, again)
        assert env.scene_cache.rebuilt == 1 and len(caplog.records) == 1
        assert SceneCache(directory=folder).get(env.scene_key(5)) is not None  # rewritten
    finally:
        env.close()


def test_unwritable_folder_falls_back_to_memory_with_one_warning(tmp_path, caplog) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with caplog.at_level(logging.WARNING, logger="evodevo.envs.scene_cache"):
        cache = SceneCache(directory=str(blocker / "scenes"))
        for i in range(3):
            cache.put(_key(i), _fake_scene(i))
            assert cache.get(_key(i)) is not None
    assert not cache.on_disk and len(cache) == 3
    assert len(caplog.records) == 1 and "memory only" in caplog.records[0].getMessage()


def test_cache_folder_from_the_environment_variable(tmp_path, monkeypatch) -> None:
    from evodevo.envs import scene_cache

    folder = str(tmp_path / "from_env")
    monkeypatch.setenv(scene_cache.CACHE_DIR_ENV, folder)
    monkeypatch.setattr(scene_cache, "_SHARED", {})
    env = KukaDiverseObjectEnv(**CHEAP)
    try:
        assert env.scene_cache is not None and env.scene_cache.directory == folder
        assert env.scene_cache.on_disk and os.path.isdir(folder)
        explicit = KukaDiverseObjectEnv(scene_cache_dir=str(tmp_path / "kw"), **CHEAP)
        assert explicit.scene_cache is not None
        assert explicit.scene_cache.directory == str(tmp_path / "kw")  # the argument wins
        explicit.close()
    finally:
        env.close()
