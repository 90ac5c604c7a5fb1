"""Environment ids with parameters: ``ENV_ID[key=value,...]`` (SPEC §1, §6).

A task of a sequence names a Gymnasium id and, in brackets, keyword arguments of ``gym.make``:
the environment's own parameters, such as LunarLander's ``gravity`` or ``enable_wind``, or
the physical constants of ``evodevo/CartPole-v1``. Values are read as YAML scalars (numbers,
``true``/``false``, strings). The whole text stays the task's name in every table, so two tasks
of one environment with different parameters are two tasks.

>>> parse_env_id("LunarLander-v3[gravity=-5, enable_wind=true]")
('LunarLander-v3', {'gravity': -5, 'enable_wind': True})
>>> parse_env_id("CartPole-v1")
('CartPole-v1', {})
>>> split_env_ids("evodevo/CartPole-v1[length=1.0,masspole=0.2],Acrobot-v1")
['evodevo/CartPole-v1[length=1.0,masspole=0.2]', 'Acrobot-v1']
"""

from __future__ import annotations

from typing import Any

import yaml

from evodevo.errors import ConfigError

__all__ = ["parse_env_id", "split_env_ids"]


def parse_env_id(text: str) -> tuple[str, dict[str, Any]]:
    """``(gymnasium id, keyword arguments)`` of ``ID`` or ``ID[key=value,...]``."""
    text = text.strip()
    if "[" not in text and "]" not in text:
        return text, {}
    base, sep, rest = text.partition("[")
    if not sep or not rest.endswith("]") or "[" in rest or not base.strip():
        raise ConfigError(
            f"environment {text!r} must look like ID or ID[key=value,...], e.g. "
            "LunarLander-v3[gravity=-5]"
        )
    kwargs: dict[str, Any] = {}
    for item in rest[:-1].split(","):
        if not item.strip():
            continue
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key.isidentifier():
            raise ConfigError(
                f"environment {text!r}: {item.strip()!r} must look like key=value, e.g. gravity=-5"
            )
        if key in kwargs:
            raise ConfigError(f"environment {text!r} sets {key!r} twice")
        try:
            kwargs[key] = yaml.safe_load(value.strip())
        except yaml.YAMLError:
            raise ConfigError(
                f"environment {text!r}: the value of {key!r} ({value.strip()!r}) is not a "
                "number, true/false or a plain string"
            ) from None
    return base.strip(), kwargs


def split_env_ids(text: str) -> list[str]:
    """Split a comma-separated list of ids, keeping the commas inside brackets."""
    out: list[str] = []
    depth, start = 0, 0
    for i, ch in enumerate(text):
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
            if depth < 0:
                raise ConfigError(f"{text!r} closes a bracket it never opened")
        elif ch == "," and depth == 0:
            out.append(text[start:i].strip())
            start = i + 1
    if depth:
        raise ConfigError(f"{text!r} opens a bracket it never closes")
    out.append(text[start:].strip())
    return [t for t in out if t]
