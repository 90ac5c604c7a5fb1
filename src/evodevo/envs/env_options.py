"""Checks of the options of ``evodevo/KukaDiverseObject-v0`` (SPEC §3): one
:class:`~evodevo.errors.ConfigError` naming the option and the value.

:func:`check_options` checks the constructor's options together, before anything is built.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from evodevo.envs.scene_cache import SceneCache
from evodevo.errors import ConfigError

__all__ = ["check_int", "positive", "check_unit", "check_options"]


def check_int(name: str, value: Any, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ConfigError(f"{name}={value!r} must be an integer >= {low}")


def positive(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not 0.0 < v < math.inf:
        raise ConfigError(
            f"{name}={value!r} must be a positive number of metres per unit action, or null"
        )
    return v


def check_unit(name: str, value: Any) -> None:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{name}={value!r} must be a number in [0, 1]") from exc
    if not 0.0 <= v <= 1.0:
        raise ConfigError(f"{name}={value!r} must lie in [0, 1]")


def check_options(
    *,
    num_objects: Any,
    max_steps: Any,
    action_repeat: Any,
    width: Any,
    height: Any,
    rebuild_every: Any,
    scene_cache_entries: Any,
    dark_after: Any,
    scene_cache: Any,
    skip_empty_lift: Any,
    camera_random: Any,
    block_random: Any,
    render_mode: Any,
) -> None:
    """The options of :class:`~evodevo.envs.kuka_diverse_object.KukaDiverseObjectEnv` that can
    be checked before anything is built (``lateral_dv`` is checked by :func:`positive`)."""
    check_int("num_objects", num_objects, 1)
    check_int("max_steps", max_steps, 1)
    check_int("action_repeat", action_repeat, 1)
    check_int("width", width, 1)
    check_int("height", height, 1)
    check_int("rebuild_every", rebuild_every, 0)
    check_int("scene_cache_entries", scene_cache_entries, 1)
    if dark_after is not None and (
        isinstance(dark_after, bool)
        or not isinstance(dark_after, (int, np.integer))
        or dark_after < 0
    ):
        raise ConfigError(
            f"dark_after={dark_after!r} must be null (the camera never goes dark) or an "
            "integer >= 0 (the observations seen before the camera goes dark)"
        )
    if not isinstance(scene_cache, (bool, SceneCache)):
        raise ConfigError(
            f"scene_cache={scene_cache!r} must be true, false or a SceneCache instance"
        )
    if not isinstance(skip_empty_lift, (bool, np.bool_)):
        raise ConfigError(f"skip_empty_lift={skip_empty_lift!r} must be true or false")
    check_unit("camera_random", camera_random)
    check_unit("block_random", block_random)
    if render_mode not in (None, "rgb_array"):
        raise ConfigError(f"render_mode={render_mode!r} is not supported; use None or 'rgb_array'")
