"""Environments: importing this package registers ``evodevo/KukaDiverseObject-v0`` (SPEC §3),
``evodevo/CartPole-v1`` (CartPole with its physical constants as arguments, for related-task
sequences), and ``evodevo/PendulumNoVelocity-v1`` and
``evodevo/MountainCarContinuousNoVelocity-v0`` (the velocity hidden: tasks that need memory,
:mod:`evodevo.envs.hidden_velocity`). PyBullet is imported only when a Kuka name is first used.

>>> import gymnasium as gym, evodevo.envs
>>> "evodevo/KukaDiverseObject-v0" in gym.registry and "evodevo/CartPole-v1" in gym.registry
True
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

import gymnasium as gym

from evodevo.envs.cartpole_dynamics import CARTPOLE_ID
from evodevo.envs.hidden_velocity import MOUNTAIN_CAR_NO_VELOCITY_ID, PENDULUM_NO_VELOCITY_ID

if TYPE_CHECKING:
    from evodevo.envs.kuka_diverse_object import (
        PROPRIO_CENTRE,
        PROPRIO_HALF_RANGE,
        KukaDiverseObjectEnv,
    )
    from evodevo.envs.objects import TEST_PATTERN, TRAIN_PATTERN, is_test_object, object_files

__all__ = [
    "CARTPOLE_ID",
    "ENV_ID",
    "MOUNTAIN_CAR_NO_VELOCITY_ID",
    "PENDULUM_NO_VELOCITY_ID",
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

#: Names of the Kuka modules, imported on first use (they import PyBullet).
_LAZY = {
    "KukaDiverseObjectEnv": "evodevo.envs.kuka_diverse_object",
    "PROPRIO_CENTRE": "evodevo.envs.kuka_diverse_object",
    "PROPRIO_HALF_RANGE": "evodevo.envs.kuka_diverse_object",
    "TEST_PATTERN": "evodevo.envs.objects",
    "TRAIN_PATTERN": "evodevo.envs.objects",
    "is_test_object": "evodevo.envs.objects",
    "object_files": "evodevo.envs.objects",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'evodevo.envs' has no attribute {name!r}")


def register_envs() -> None:
    """Register :data:`ENV_ID`, :data:`CARTPOLE_ID` and the hidden-velocity tasks with
    Gymnasium (once)."""
    if ENV_ID not in gym.registry:
        gym.register(
            id=ENV_ID,
            entry_point="evodevo.envs.kuka_diverse_object:KukaDiverseObjectEnv",
        )
    if CARTPOLE_ID not in gym.registry:
        gym.register(
            id=CARTPOLE_ID,
            entry_point="evodevo.envs.cartpole_dynamics:CartPoleDynamicsEnv",
            max_episode_steps=500,
            reward_threshold=475.0,
        )
    if PENDULUM_NO_VELOCITY_ID not in gym.registry:  # Pendulum-v1's episode length
        gym.register(
            id=PENDULUM_NO_VELOCITY_ID,
            entry_point="evodevo.envs.hidden_velocity:pendulum_no_velocity",
            max_episode_steps=200,
        )
    if MOUNTAIN_CAR_NO_VELOCITY_ID not in gym.registry:  # MountainCarContinuous-v0's
        gym.register(
            id=MOUNTAIN_CAR_NO_VELOCITY_ID,
            entry_point="evodevo.envs.hidden_velocity:mountain_car_no_velocity",
            max_episode_steps=999,
            reward_threshold=90.0,
        )


register_envs()
