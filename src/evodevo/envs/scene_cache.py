"""Settled-scene cache of ``KukaDiverseObject-v0``: drop the objects of a seed once (SPEC §2.4-2.5, §3).

A reset drops ``num_objects`` objects one by one and lets each settle for 500 simulation steps
(≈ 35 % of an episode's CPU). With common random numbers every genome of a generation, and every
policy of a test, resets the same seeds, so the same scenes are dropped again and again. The
settled scene is a function of the drop alone (which object files, at which poses, with which
physics settings), so it is computed once and kept here:

* :class:`SettledScene`: the dropped objects and their settled state (base pose and velocity of
  every object, position and velocity of every arm joint), a few KB;
* :func:`scene_key`: the key, every setting that changes the drop plus a format version;
* :class:`SceneCache`: a per-process LRU of scenes, optionally backed by a folder of one
  checksummed JSON file per scene, so that runs spanning sessions share it.

How the env uses a scene (docs/kuka_env.md, "Settled-scene cache"): it places the objects into
its world and writes the stored state into the bodies, the same way whether the scene was just
simulated (a miss) or found here (a hit), so hits and misses give bit-identical episodes.

>>> cache = SceneCache(max_entries=2)
>>> len(cache), cache.hits, cache.misses
(0, 0, 0)
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "SCENE_FORMAT_VERSION",
    "DEFAULT_MAX_ENTRIES",
    "CACHE_DIR_ENV",
    "SettledScene",
    "SceneCache",
    "scene_key",
    "key_digest",
    "shared_cache",
]

#: Version of the stored scene and of the code that settles and places it. Raise it whenever
#: the drop, the settle or the placement changes: entries of another version are rebuilt.
SCENE_FORMAT_VERSION = 1
#: Scenes kept in memory per process (a scene takes about 2 KB; 4096 take < 10 MB).
DEFAULT_MAX_ENTRIES = 4096
#: Environment variable naming the default on-disk cache folder (unset: memory only).
CACHE_DIR_ENV = "EVODEVO_SCENE_CACHE_DIR"
#: First line of an on-disk entry: ``MAGIC <format> <sha256 of the rest>``.
_MAGIC = "evodevo-settled-scene"

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SettledScene:
    """One settled scene: what was dropped where, and the state of every body afterwards.

    Attributes:
        files: Object URDF paths relative to the URDF root, in drop order.
        poses: ``(n, 3)`` drop x, y (m) and yaw (rad) of each object.
        objects: ``(n, 13)`` settled base position (3), orientation quaternion (4), linear
            velocity (3) and angular velocity (3) of each object.
        arm_q: Settled position of every arm joint (fixed joints included, as 0).
        arm_qd: Settled velocity of every arm joint.
        seed: Reset seed that first produced the scene (information only, not part of the key).
    """

    files: tuple[str, ...]
    poses: np.ndarray
    objects: np.ndarray
    arm_q: np.ndarray
    arm_qd: np.ndarray
    seed: int | None = None

    def to_json(self, key: dict[str, Any]) -> dict[str, Any]:
        """A JSON-able dict (Python floats round-trip exactly through JSON)."""
        return {
            "key": key,
            "seed": self.seed,
            "files": list(self.files),
            "poses": self.poses.tolist(),
            "objects": self.objects.tolist(),
            "arm_q": self.arm_q.tolist(),
            "arm_qd": self.arm_qd.tolist(),
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SettledScene:
        """Inverse of :meth:`to_json` (the key is checked by the caller).

        Raises:
            ValueError: A field is missing or has the wrong shape.
        """
        n = len(data["files"])
        poses = np.asarray(data["poses"], dtype=np.float64).reshape(n, 3)
        objects = np.asarray(data["objects"], dtype=np.float64).reshape(n, 13)
        arm_q = np.asarray(data["arm_q"], dtype=np.float64).ravel()
        arm_qd = np.asarray(data["arm_qd"], dtype=np.float64).ravel()
        if arm_q.shape != arm_qd.shape:
            raise ValueError("arm_q and arm_qd differ in length")
        seed = data.get("seed")
        return cls(
            tuple(str(f) for f in data["files"]),
            poses,
            objects,
            arm_q,
            arm_qd,
            None if seed is None else int(seed),
        )


def scene_key(
    files: Sequence[str],
    poses: np.ndarray,
    settings: dict[str, Any],
) -> dict[str, Any]:
    """The cache key of a drop: the objects, their drop poses and every setting of the drop.

    The seed, the object split (``test_objects``), ``num_objects`` and ``block_random`` enter
    through ``files`` and ``poses`` (they are what the seed and those options draw); ``settings``
    carries the rest (physics constants, ``deterministic_pairs``, PyBullet's version, the URDF
    root when it is not the installed one). Options that do not change the drop (camera,
    ``max_steps``, action settings, image size) are not part of it.

    >>> k = scene_key(["a.urdf"], np.zeros((1, 3)), {"g": -10})
    >>> k["format"], k["objects"]
    (1, [['a.urdf', '0x0.0p+0', '0x0.0p+0', '0x0.0p+0']])
    """
    pose = np.asarray(poses, dtype=np.float64).reshape(len(files), 3)
    return {
        "format": SCENE_FORMAT_VERSION,
        # float.hex: exact, and a key never depends on how floats are printed
        "objects": [
            [f, *(float(v).hex() for v in row)] for f, row in zip(files, pose, strict=True)
        ],
        "settings": settings,
    }


def key_digest(key: dict[str, Any]) -> str:
    """SHA-256 (hex, 32 characters) of the key's canonical JSON: the on-disk file name."""
    text = json.dumps(key, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class SceneCache:
    """Per-process LRU of settled scenes, optionally backed by a folder (SPEC §2.4-2.5).

    Args:
        max_entries: Scenes kept in memory; the least recently used goes first.
        directory: Folder of on-disk entries (created if missing), or ``None`` for memory only.
            If it cannot be written the cache stays in memory and says so once.

    Attributes:
        hits: Lookups answered from memory or disk.
        misses: Lookups that found nothing usable (the caller then simulates the drop).
        rebuilt: On-disk entries found corrupt or foreign and replaced.
    """

    def __init__(self, max_entries: int = DEFAULT_MAX_ENTRIES, directory: str | None = None):
        if isinstance(max_entries, bool) or not isinstance(max_entries, int) or max_entries < 1:
            raise ValueError(f"max_entries={max_entries!r} must be an integer >= 1")
        self.max_entries = max_entries
        self.directory = os.path.abspath(directory) if directory else None
        self._mem: OrderedDict[str, SettledScene] = OrderedDict()
        self.hits = 0
        self.misses = 0
        self.rebuilt = 0
        self._writable = True
        if self.directory is not None:
            try:
                os.makedirs(self.directory, exist_ok=True)
                with tempfile.TemporaryFile(dir=self.directory):
                    pass
            except OSError as exc:
                self._disable_disk(exc)

    def __len__(self) -> int:
        return len(self._mem)

    @property
    def on_disk(self) -> bool:
        """Whether entries are written to (and read from) :attr:`directory`."""
        return self.directory is not None and self._writable

    def get(self, key: dict[str, Any]) -> SettledScene | None:
        """The scene stored under ``key`` (memory first, then disk), or ``None``."""
        digest = key_digest(key)
        scene = self._mem.get(digest)
        if scene is not None:
            self._mem.move_to_end(digest)
            self.hits += 1
            return scene
        if self.on_disk:
            scene = self._read(digest, key)
            if scene is not None:
                self._remember(digest, scene)
                self.hits += 1
                return scene
        self.misses += 1
        return None

    def put(self, key: dict[str, Any], scene: SettledScene) -> None:
        """Store ``scene`` under ``key`` in memory (evicting the oldest) and on disk."""
        digest = key_digest(key)
        self._remember(digest, scene)
        if self.on_disk:
            self._write(digest, key, scene)

    def clear(self) -> None:
        """Forget every scene held in memory (on-disk entries stay)."""
        self._mem.clear()

    # ------------------------------------------------------------------ internals

    def _remember(self, digest: str, scene: SettledScene) -> None:
        self._mem[digest] = scene
        self._mem.move_to_end(digest)
        while len(self._mem) > self.max_entries:
            self._mem.popitem(last=False)

    def _path(self, digest: str) -> str:
        assert self.directory is not None
        return os.path.join(self.directory, f"{digest}.json")

    def _read(self, digest: str, key: dict[str, Any]) -> SettledScene | None:
        path = self._path(digest)
        try:
            with open(path, "rb") as fh:
                raw = fh.read()
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._rebuild_note(path, f"unreadable ({exc})")
            return None
        head, _, body = raw.partition(b"\n")
        parts = head.decode("utf-8", "replace").split(" ")
        if len(parts) != 3 or parts[0] != _MAGIC:
            self._rebuild_note(path, "not a settled-scene entry")
            return None
        if parts[1] != str(SCENE_FORMAT_VERSION):
            self._rebuild_note(path, f"format {parts[1]}, this code writes {SCENE_FORMAT_VERSION}")
            return None
        if hashlib.sha256(body).hexdigest() != parts[2]:
            self._rebuild_note(path, "checksum mismatch")
            return None
        try:
            data = json.loads(body)
            if data.get("key") != key:
                self._rebuild_note(path, "it holds another scene (foreign key)")
                return None
            return SettledScene.from_json(data)
        except (ValueError, KeyError, TypeError) as exc:
            self._rebuild_note(path, f"unparsable ({exc})")
            return None

    def _write(self, digest: str, key: dict[str, Any], scene: SettledScene) -> None:
        body = json.dumps(scene.to_json(key), sort_keys=True).encode()
        head = f"{_MAGIC} {SCENE_FORMAT_VERSION} {hashlib.sha256(body).hexdigest()}\n".encode()
        assert self.directory is not None
        try:
            fd, tmp = tempfile.mkstemp(dir=self.directory, prefix=".tmp-", suffix=".json")
            try:
                with os.fdopen(fd, "wb") as fh:
                    fh.write(head + body)
                os.replace(tmp, self._path(digest))  # atomic: readers never see half a file
            except BaseException:
                if os.path.exists(tmp):
                    os.unlink(tmp)
                raise
        except OSError as exc:
            self._disable_disk(exc)

    def _rebuild_note(self, path: str, why: str) -> None:
        self.rebuilt += 1
        _log.warning("evodevo: scene cache entry %s is %s; rebuilding it", path, why)

    def _disable_disk(self, exc: OSError) -> None:
        self._writable = False
        _log.warning(
            "evodevo: scene cache folder %s cannot be written (%s); keeping scenes in memory only",
            self.directory,
            exc.strerror or exc,
        )


_SHARED: dict[str | None, SceneCache] = {}


def shared_cache(
    max_entries: int = DEFAULT_MAX_ENTRIES, directory: str | None = None
) -> SceneCache:
    """The process-wide cache of ``directory`` (``None``: memory only), made on first use.

    Every env of a process that asks for the same folder shares one cache; its bound is the
    largest ``max_entries`` asked for.
    """
    folder = os.path.abspath(directory) if directory else None
    cache = _SHARED.get(folder)
    if cache is None:
        cache = _SHARED[folder] = SceneCache(max_entries, folder)
    elif max_entries > cache.max_entries:
        cache.max_entries = max_entries
    return cache
