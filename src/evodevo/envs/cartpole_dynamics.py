"""Gymnasium's CartPole with its physical constants as arguments: related tasks (SPEC §6).

``evodevo/CartPole-v1`` is Gymnasium's ``CartPole-v1`` (same observation, actions, reward,
termination, 500-step limit and solved threshold 475) whose gravity, cart and pole masses,
pole half-length and push force are constructor arguments, so that a task sequence can hold
tasks that share the observation and action spaces and differ only in their dynamics. With the
defaults it steps exactly as ``CartPole-v1``.

>>> import gymnasium as gym, evodevo.envs
>>> env = gym.make("evodevo/CartPole-v1", length=1.0)
>>> env.unwrapped.polemass_length
0.1
"""

from __future__ import annotations

import math

from gymnasium.envs.classic_control.cartpole import CartPoleEnv

from evodevo.errors import ConfigError

__all__ = ["CartPoleDynamicsEnv", "CARTPOLE_ID"]

#: Gymnasium id of the parametrised CartPole.
CARTPOLE_ID = "evodevo/CartPole-v1"


class CartPoleDynamicsEnv(CartPoleEnv):
    """CartPole-v1 with ``gravity``, ``masscart``, ``masspole``, ``length`` (half the pole's
    length, m) and ``force_mag`` as arguments; Gymnasium's values are the defaults."""

    def __init__(
        self,
        gravity: float = 9.8,
        masscart: float = 1.0,
        masspole: float = 0.1,
        length: float = 0.5,
        force_mag: float = 10.0,
        render_mode: str | None = None,
    ) -> None:
        super().__init__(render_mode=render_mode)
        for name, value in (
            ("gravity", gravity),
            ("masscart", masscart),
            ("masspole", masspole),
            ("length", length),
            ("force_mag", force_mag),
        ):
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(
                    f"{CARTPOLE_ID} {name}={value!r} must be a finite number > 0 "
                    "(e.g. evodevo/CartPole-v1[length=1.0])"
                )
        self.gravity = float(gravity)
        self.masscart = float(masscart)
        self.masspole = float(masspole)
        self.total_mass = self.masspole + self.masscart
        self.length = float(length)
        self.polemass_length = self.masspole * self.length
        self.force_mag = float(force_mag)
