"""Classic-control tasks with hidden state: the velocity is dropped from the observation.

A controller that maps the current observation to an action cannot tell which way the
pendulum swings or the car rolls; one whose state carries over between steps can estimate it
from successive observations. Two ids are registered by :mod:`evodevo.envs`:

* ``evodevo/PendulumNoVelocity-v1``: Pendulum-v1 observing ``[cos θ, sin θ]`` (θ̇ dropped);
* ``evodevo/MountainCarContinuousNoVelocity-v0``: MountainCarContinuous-v0 observing the
  position only (the velocity dropped).

Dynamics, reward, actions, episode length and keyword arguments (e.g. Pendulum's ``g``) are
those of the Gymnasium task; only the observation loses its velocity entries.

>>> import gymnasium as gym, evodevo.envs
>>> env = gym.make(PENDULUM_NO_VELOCITY_ID)
>>> obs, _ = env.reset(seed=0)
>>> obs.shape, env.observation_space.shape
((2,), (2,))
>>> env.close()
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.classic_control.continuous_mountain_car import Continuous_MountainCarEnv
from gymnasium.envs.classic_control.pendulum import PendulumEnv

from evodevo.errors import ConfigError

__all__ = [
    "HideVelocity",
    "PENDULUM_NO_VELOCITY_ID",
    "MOUNTAIN_CAR_NO_VELOCITY_ID",
    "pendulum_no_velocity",
    "mountain_car_no_velocity",
]

#: Pendulum-v1 without θ̇: observation ``[cos θ, sin θ]``.
PENDULUM_NO_VELOCITY_ID = "evodevo/PendulumNoVelocity-v1"
#: MountainCarContinuous-v0 without the velocity: observation ``[position]``.
MOUNTAIN_CAR_NO_VELOCITY_ID = "evodevo/MountainCarContinuousNoVelocity-v0"


class HideVelocity(gym.ObservationWrapper[np.ndarray, Any, np.ndarray]):
    """Keep only the entries ``keep`` of a flat Box observation.

    Args:
        env: an env with a flat (1-d) Box observation.
        keep: indices of the entries the controller observes (in this order).

    Raises:
        ConfigError: the observation is not a flat Box, or ``keep`` is empty, repeats an index
            or names one outside it.
    """

    def __init__(self, env: gym.Env[np.ndarray, Any], keep: Sequence[int]) -> None:
        super().__init__(env)
        space = env.observation_space
        if not isinstance(space, gym.spaces.Box) or len(space.shape) != 1:
            raise ConfigError(f"HideVelocity needs a flat Box observation; {env} observes {space}")
        n = int(space.shape[0])
        idx = [int(i) for i in keep]
        if not idx or len(set(idx)) != len(idx) or not all(0 <= i < n for i in idx):
            raise ConfigError(
                f"keep={list(keep)!r} must name distinct entries of the {n}-value observation "
                f"(0..{n - 1}), at least one"
            )
        self.keep = np.asarray(idx, dtype=np.intp)
        self.observation_space = gym.spaces.Box(
            space.low[self.keep], space.high[self.keep], dtype=space.dtype.type
        )

    def observation(self, observation: np.ndarray) -> np.ndarray:
        """The kept entries of ``observation``."""
        return np.asarray(observation)[self.keep]


def pendulum_no_velocity(**kwargs: Any) -> HideVelocity:
    """Pendulum-v1 (``PendulumEnv(**kwargs)``) observing ``[cos θ, sin θ]``."""
    return HideVelocity(PendulumEnv(**kwargs), keep=(0, 1))


def mountain_car_no_velocity(**kwargs: Any) -> HideVelocity:
    """MountainCarContinuous-v0 (``Continuous_MountainCarEnv(**kwargs)``) observing its position."""
    return HideVelocity(Continuous_MountainCarEnv(**kwargs), keep=(0,))
