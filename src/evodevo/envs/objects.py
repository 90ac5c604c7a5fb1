"""The 1000 object meshes of KukaDiverseObjectEnv and its 90/10 train/test split (SPEC §2.6, §3).

The original globs ``random_urdfs/*[1-9]/*.urdf`` for training and ``random_urdfs/*0/*.urdf``
(folders whose name ends in 0, the held-out tenth) for testing. Here the same patterns are used
and the result is sorted, so that an index drawn from a seeded generator names the same file on
every machine (the original used the unsorted ``glob`` order).

>>> len(object_files(test=False)), len(object_files(test=True))
(900, 100)
"""

from __future__ import annotations

import functools
import glob
import os

import pybullet_data

__all__ = ["TRAIN_PATTERN", "TEST_PATTERN", "object_files", "is_test_object"]

#: Glob (relative to ``pybullet_data``) of the training objects, exactly as in the original.
TRAIN_PATTERN = "random_urdfs/*[1-9]/*.urdf"
#: Glob (relative to ``pybullet_data``) of the held-out test objects, exactly as in the original.
TEST_PATTERN = "random_urdfs/*0/*.urdf"


@functools.lru_cache(maxsize=8)
def object_files(test: bool = False, urdf_root: str | None = None) -> tuple[str, ...]:
    """Sorted absolute paths of the training (``test=False``) or test object URDFs.

    Args:
        test: Held-out objects (``isTest=True`` in the original) instead of training ones.
        urdf_root: Folder of ``pybullet_data``; the installed one by default.
    """
    root = urdf_root if urdf_root is not None else pybullet_data.getDataPath()
    return tuple(sorted(glob.glob(os.path.join(root, TEST_PATTERN if test else TRAIN_PATTERN))))


def is_test_object(path: str) -> bool:
    """Whether an object URDF belongs to the held-out tenth (its folder name ends in 0)."""
    return os.path.basename(os.path.dirname(path)).endswith("0")
