"""Environments (SPEC §3): importing this package registers ``evodevo/KukaDiverseObject-v0``.

>>> import gymnasium as gym, evodevo.envs
>>> "evodevo/KukaDiverseObject-v0" in gym.registry
True
"""

from __future__ import annotations

import gymnasium as gym

from evodevo.envs.kuka_diverse_object import (
    PROPRIO_CENTRE,
    PROPRIO_HALF_RANGE,
    KukaDiverseObjectEnv,
)
from evodevo.envs.objects import TEST_PATTERN, TRAIN_PATTERN, is_test_object, object_files

__all__ = [
    "ENV_ID",
    "KukaDiverseObjectEnv",
    "PROPRIO_CENTRE",
    "PROPRIO_HALF_RANGE",
    "TEST_PATTERN",
    "TRAIN_PATTERN",
    "is_test_object",
    "object_files",
    "register_envs",
]

#: Gymnasium id of the port.
ENV_ID = "evodevo/KukaDiverseObject-v0"


def register_envs() -> None:
    """Register :data:`ENV_ID` with Gymnasium (does nothing if it is already registered)."""
    if ENV_ID not in gym.registry:
        gym.register(
            id=ENV_ID,
            entry_point="evodevo.envs.kuka_diverse_object:KukaDiverseObjectEnv",
        )


register_envs()
