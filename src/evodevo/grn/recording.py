"""Record one test episode of a run: the gene-expression trace (for figures) or a GIF.

Both run in this process with the run's saved encoder and best genome, on test episode
``index`` of the fixed test seeds (SPEC §2.5), and save files that the figures read back.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.errors import EvodevoError
from evodevo.grn.controller import make_controller
from evodevo.grn.evaluation import LoadedRun, load_run, test_episodes
from evodevo.grn.evaluator import Episode, action_dims, make_env, run_episodes
from evodevo.grn.genome import save_arrays
from evodevo.video import save_frames

__all__ = ["record_episode", "episode_meta", "record_trace", "record_video", "TRACE_FILE"]

TRACE_FILE = "trace.npz"


def record_episode(
    loaded: LoadedRun, index: int = 0, objects: str = "test"
) -> tuple[Episode, dict[str, Any]]:
    """Run test episode ``index`` of a loaded run in this process with its controller (plain,
    neuromodulated, ...), recording the expression (and modulator states) and actions of every
    step: ``(episode, run_episodes result)``."""
    cfg = loaded.config
    ep = test_episodes(cfg.evaluation.test_seed, index + 1, objects == "test")[index]
    env = make_env(cfg.env.id, cfg.env.kwargs, test_objects=ep.test_objects)
    try:
        ctrl = make_controller(cfg, action_dims(env.action_space))
        res = run_episodes(
            [env],
            loaded.encoder,
            ctrl,
            [loaded.genome],
            [ep],
            n_proprio=cfg.sensors.n_proprio,
            record=True,
        )
    finally:
        env.close()
    return ep, res


def episode_meta(ep: Episode, res: Mapping[str, Any], objects: str, index: int) -> dict[str, Any]:
    """The JSON header of a recorded episode's file: seed, objects, index, reward, success."""
    return {
        "seed": ep.seed,
        "objects": objects,
        "index": index,
        "reward": float(res["reward"][0]),
        "success": bool(res["success"][0]),
    }


def record_trace(path: str | Path, index: int = 0, objects: str = "test") -> Path:
    """Run test episode ``index`` and save ``trace.npz`` (expression x per step, actions)."""
    loaded = load_run(path)
    ep, res = record_episode(loaded, index, objects)
    x = np.stack([a[0] for a in res["x"]]) if res["x"] else np.zeros((0, 0))
    actions = np.stack([a[0] for a in res["actions"]])
    out = loaded.run / TRACE_FILE
    save_arrays(
        out, "grn_trace", {"x": x, "actions": actions}, episode_meta(ep, res, objects, index)
    )
    return out


def record_video(path: str | Path, out: str | Path, index: int = 0, objects: str = "test") -> Path:
    """Save a GIF of test episode ``index`` (env ``render_mode="rgb_array"``)."""
    loaded = load_run(path)
    cfg = loaded.config
    ep = test_episodes(cfg.evaluation.test_seed, index + 1, objects == "test")[index]
    env = make_env(
        cfg.env.id, cfg.env.kwargs, test_objects=ep.test_objects, render_mode="rgb_array"
    )
    frames: list[Any] = []

    class _Recording:
        """Env proxy rendering a frame after reset and after every step."""

        def __init__(self, inner: Any) -> None:
            self.inner = inner
            self.action_space = inner.action_space

        def reset(self, **kw: Any) -> Any:
            r = self.inner.reset(**kw)
            frames.append(self.inner.render())
            return r

        def step(self, a: Any) -> Any:
            r = self.inner.step(a)
            frames.append(self.inner.render())
            return r

    try:
        ctrl = make_controller(cfg, action_dims(env.action_space))
        run_episodes(
            [_Recording(env)],  # type: ignore[list-item]
            loaded.encoder,
            ctrl,
            [loaded.genome],
            [ep],  # type: ignore[list-item]
            n_proprio=cfg.sensors.n_proprio,
        )
    finally:
        env.close()
    frames = [f for f in frames if f is not None]
    if not frames:
        raise EvodevoError(f"environment {cfg.env.id!r} rendered no frames in rgb_array mode")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    # Pillow GIF: 400 ms per frame (imageio >= 2.28 read duration=0.4 as 0.4 ms); `evodevo grn
    # video` films with captions through evodevo.video
    return save_frames([np.asarray(f, dtype=np.uint8) for f in frames], out, fps=2.5)
