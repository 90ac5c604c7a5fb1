"""A cheap stand-in with the Kuka env's spaces and infos, for fast GRN tests.

Registered as ``test_grn_fakeenv:GrnFakeKuka-v0`` so worker processes (spawned, with this
folder on ``sys.path``) can build it by id. Its own sanity test keeps the contract honest.
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np

FAKE_ID = "test_grn_fakeenv:GrnFakeKuka-v0"


class GrnFakeKuka(gym.Env[np.ndarray, np.ndarray]):
    """Object at a random (x, y); the gripper succeeds if it ends within 0.35 of it."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(
        self,
        test_objects: bool = False,
        max_steps: int = 8,
        render_mode: str | None = None,
        crash_marker: str | None = None,
    ) -> None:
        self.crash_marker = crash_marker
        self.observation_space = gym.spaces.Box(0, 255, (48, 48, 3), np.uint8)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.test_objects = test_objects
        self.max_steps = max_steps
        self.render_mode = render_mode

    def _obs(self) -> np.ndarray:
        img = self.np_random.integers(0, 30, (48, 48, 3)).astype(np.uint8)
        cx, cy = ((self.obj + 1) * 20 + 4).astype(int)
        img[cy - 3 : cy + 3, cx - 3 : cx + 3, 0] = 250 if not self.test_objects else 180
        return img

    def _info(self) -> dict[str, Any]:
        return {"proprio": np.array([*self.ee, 0.5 - 0.1 * self.t, self.angle], np.float32)[:4]}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if self.crash_marker is not None:
            try:
                os.remove(self.crash_marker)  # only one process wins: it dies like a segfault
            except FileNotFoundError:
                pass
            else:
                os._exit(1)
        self.obj = self.np_random.uniform(-0.8, 0.8, 2)
        self.ee = np.zeros(2)
        self.angle = 0.0
        self.t = 0
        return self._obs(), self._info()

    def step(self, action: np.ndarray):
        a = np.clip(np.asarray(action, float), -1, 1)
        self.ee = np.clip(self.ee + 0.25 * a[:2], -1, 1)
        self.angle = float(np.clip(self.angle + 0.2 * a[2], -1, 1))
        self.t += 1
        done = self.t >= 7
        success = bool(done and np.linalg.norm(self.ee - self.obj) < 0.35)
        info = self._info()
        info["is_success"] = success
        return self._obs(), float(success), done, self.t >= self.max_steps and not done, info

    def render(self) -> np.ndarray:
        return self._obs()


if "GrnFakeKuka-v0" not in gym.registry:
    gym.register("GrnFakeKuka-v0", entry_point=GrnFakeKuka)


def test_fake_env_follows_the_contract():
    env = gym.make(FAKE_ID, test_objects=True, max_steps=8)
    obs, info = env.reset(seed=1)
    assert obs.shape == (48, 48, 3) and obs.dtype == np.uint8
    assert info["proprio"].shape == (4,)
    n = 0
    done = False
    while not done:
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        n += 1
        done = term or trunc
    assert n == 7 and isinstance(info["is_success"], bool) and r in (0.0, 1.0)
