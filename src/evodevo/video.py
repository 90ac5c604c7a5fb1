"""Film one episode of a trained policy: a GIF (or MP4) at a real frame rate, with the step, the
action, the reward and the outcome drawn on every frame.

The episode is acted through :func:`evodevo.load`'s :class:`~evodevo.policy.Policy`, the same
path that reproduces ``grn evaluate``'s episodes, so the film shows what the test measured.
GIFs are written with Pillow, whose frame duration is in milliseconds (``1000 / fps`` per
frame); MP4 needs ``imageio-ffmpeg``.

>>> frame = annotate(np.zeros((48, 48, 3), np.uint8), ["step 1"])
>>> frame.shape[0] >= 240 and frame.dtype == np.uint8
True
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageSequence

from evodevo.errors import EvodevoError

__all__ = ["annotate", "save_frames", "film_episode", "frame_durations", "MIN_SIDE"]

#: Frames are enlarged (nearest neighbour, integer factor) until their smaller side is this
#: many pixels, so the 48x48 camera view and the text stay readable.
MIN_SIDE = 240
#: Height in pixels of one caption line.
LINE_PX = 14


def annotate(frame: np.ndarray, lines: list[str]) -> np.ndarray:
    """``frame`` (H, W, 3) enlarged to at least :data:`MIN_SIDE` with ``lines`` on a band below."""
    img = np.asarray(frame, dtype=np.uint8)[..., :3]
    k = max(1, -(-MIN_SIDE // min(img.shape[:2])))  # ceil
    big = np.repeat(np.repeat(img, k, axis=0), k, axis=1)
    band = np.zeros((LINE_PX * len(lines) + 6, big.shape[1], 3), dtype=np.uint8)
    out = Image.fromarray(np.concatenate([big, band], axis=0))
    draw = ImageDraw.Draw(out)
    for i, line in enumerate(lines):
        draw.text((4, big.shape[0] + 3 + LINE_PX * i), line, fill=(255, 255, 255))
    return np.asarray(out)


def save_frames(frames: list[np.ndarray], out: str | Path, fps: float) -> Path:
    """Write ``frames`` as a looping GIF (``.gif``) or an MP4 (``.mp4``) at ``fps``."""
    if not fps > 0:
        raise EvodevoError(f"--fps {fps} must be > 0")
    if not frames:
        raise EvodevoError("no frames to write")
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise EvodevoError(f"--out {str(out)!r}: write a .gif or an .mp4 file")
    out.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
        ms = max(20, int(round(1000.0 / fps)))  # GIF viewers clamp shorter delays
        images[0].save(
            out, save_all=True, append_images=images[1:], duration=ms, loop=0, optimize=False
        )
        return out
    try:
        import imageio.v2 as imageio  # optional dependency: imageio

        imageio.mimsave(out, [np.asarray(f, dtype=np.uint8) for f in frames], fps=fps)
    except (ImportError, ValueError, RuntimeError) as exc:
        raise EvodevoError(
            f"cannot write {str(out)!r} ({str(exc).splitlines()[0]}); MP4 needs "
            "pip install imageio-ffmpeg, or write a .gif"
        ) from None
    return out


def frame_durations(gif: str | Path) -> list[int]:
    """The duration (ms) of every frame of a GIF (what a viewer shows)."""
    with Image.open(gif) as im:
        return [int(f.info.get("duration", 0)) for f in ImageSequence.Iterator(im)]


def _fmt_action(action: Any) -> str:
    a = np.asarray(action)
    if a.ndim == 0:
        return str(a.item())
    return "[" + ", ".join(f"{v:+.2f}" for v in a.reshape(-1)) + "]"


def film_episode(
    policy: Any, env: Any, seed: int, title: str = "", max_steps: int | None = None
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Act one episode with ``policy`` in ``env`` (``render_mode="rgb_array"``), one frame per step.

    Returns:
        The annotated frames and ``{"return", "steps", "success"}`` (``success`` is None when
        the environment reports no ``is_success``).
    """
    obs, info = env.reset(seed=int(seed))
    policy.reset(seed=int(seed))
    head = f"{title}  seed {seed}".strip()
    frames = [annotate(_render(env), [head, "step 0", ""])]
    total, steps, reward = 0.0, 0, None
    success: bool | None = None
    while True:
        action = policy.predict(obs, info, reward)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
        done = bool(terminated or truncated)
        if "is_success" in info:
            success = bool(info["is_success"])
        outcome = ""
        if done:
            outcome = "end: " + (
                f"return {total:.2f}" if success is None else ("SUCCESS" if success else "failure")
            )
        lines = [
            head,
            f"step {steps}  action {_fmt_action(action)}",
            f"reward {float(reward):+.2f}  return {total:.2f}  {outcome}".rstrip(),
        ]
        frames.append(annotate(_render(env), lines))
        if done or (max_steps is not None and steps >= max_steps):
            break
    return frames, {"return": total, "steps": steps, "success": success}


def _render(env: Any) -> np.ndarray:
    frame = env.render()
    if frame is None:
        raise EvodevoError(
            f"environment {env.spec.id if env.spec else env!r} rendered no frame; "
            "make it with render_mode='rgb_array'"
        )
    return np.asarray(frame)
