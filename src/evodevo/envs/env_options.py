"""Checks of the options of ``evodevo/KukaDiverseObject-v0`` (SPEC §3): one
:class:`~evodevo.errors.ConfigError` naming the option and the value.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from evodevo.errors import ConfigError

__all__ = ["check_int", "positive", "check_unit"]


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
