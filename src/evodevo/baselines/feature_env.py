"""A camera env seen through a visual front-end: observations are the front-end's features.

The same front-end for the baselines: PPO on the vision preset's inputs
reads what the GRN reads — the blob localiser's 4 features ``[dx, dy, size, found]``
(:mod:`evodevo.grn.frontends`, SPEC §2.2) — instead of the raw 48×48 image. The wrapper keeps
the front-end's per-episode state (the target found on the first frame), resets it with the
env and encodes every frame with the robot's own pose (``info["proprio"]``), exactly as the GRN
evaluator does. Reward, termination and ``info`` pass through unchanged.

>>> import numpy as np
>>> from evodevo.grn.frontends import BlobLocaliser
>>> fe = BlobLocaliser(background=np.zeros((48, 48, 3), np.uint8))
>>> FeatureObservation.space(fe).shape
(4,)
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from evodevo.errors import EvodevoError
from evodevo.grn.frontends import DXY_CLIP

__all__ = ["FeatureObservation"]


class FeatureObservation(gym.Wrapper[np.ndarray, Any, Any, Any]):
    """Observations = ``frontend.encode(image, proprio)`` (float32, one row per step).

    Args:
        env: an env whose observations are the images the front-end reads and whose ``info``
            carries ``"proprio"`` (the Kuka port).
        frontend: a stateful front-end with ``reset(n)`` and ``encode(images, proprio, state,
            idx)`` (the blob localiser).
    """

    def __init__(self, env: gym.Env[Any, Any], frontend: Any) -> None:
        super().__init__(env)
        if not hasattr(frontend, "reset") or not hasattr(frontend, "encode"):
            raise EvodevoError(
                f"{type(frontend).__name__} is not a stateful front-end (reset/encode); "
                "use sensors.encoder: blob"
            )
        self.frontend = frontend
        self.observation_space = self.space(frontend)
        self._state: Any = None

    @staticmethod
    def space(frontend: Any) -> gym.spaces.Box:
        """The features' box: (dx, dy) in ±DXY_CLIP action units, size in [0, 2], found 0/1."""
        dim = int(getattr(frontend, "dim", 4))
        low = np.array([-DXY_CLIP, -DXY_CLIP, 0.0, 0.0][:dim], np.float32)
        high = np.array([DXY_CLIP, DXY_CLIP, 2.0, 1.0][:dim], np.float32)
        return gym.spaces.Box(low, high, dtype=np.float32)

    def _encode(self, obs: Any, info: dict[str, Any]) -> np.ndarray:
        proprio = info.get("proprio")
        if proprio is None:
            raise EvodevoError(
                "the front-end needs the gripper pose in info['proprio']; this env gives none"
            )
        feats = self.frontend.encode(
            np.asarray(obs)[None], np.asarray(proprio, np.float64)[None], self._state, np.arange(1)
        )
        return np.asarray(feats[0], dtype=np.float32)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._state = self.frontend.reset(1)
        return self._encode(obs, info), info

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, term, trunc, info = self.env.step(action)
        return self._encode(obs, info), reward, term, trunc, info
