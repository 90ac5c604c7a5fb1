"""Registry of trainers for BIARM variant architectures that the BIARM trainer does not run.

A variant names its ``architecture`` (:mod:`evodevo.neuromod.variants`); ``progressive`` and
``shared`` networks are trained by :func:`evodevo.neuromod.trainer.train` itself. Any other
architecture is trained by a function registered here under its name, with the signature and
run files of ``train``. The baselines package registers ``sb3`` (a Stable-Baselines3 DQN per
task) when it is imported, so the method does not import its baselines: the dependency points
from the baselines to the method. Packages in :data:`PROVIDERS` are imported on the first
look-up of an unknown architecture, which is when they register.

>>> register_trainer("noop", lambda *a, **k: {"tasks": []})
>>> get_trainer("noop")()["tasks"]
[]
>>> get_trainer("progressive") is None
True
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from evodevo.errors import EvodevoError

__all__ = ["register_trainer", "get_trainer", "PROVIDERS"]

Trainer = Callable[..., dict[str, Any]]

#: Packages that register trainers when imported (imported lazily, on a look-up miss).
PROVIDERS: list[str] = ["evodevo.baselines"]

_TRAINERS: dict[str, Trainer | str] = {}


def register_trainer(architecture: str, trainer: Trainer | str) -> None:
    """Register ``trainer`` (a function or a lazy ``"module:function"``) for ``architecture``."""
    _TRAINERS[architecture] = trainer


def get_trainer(architecture: str) -> Trainer | None:
    """The trainer registered for ``architecture``, or None (the BIARM trainer's own ones)."""
    if architecture not in _TRAINERS:
        for name in PROVIDERS:
            importlib.import_module(name)
    trainer = _TRAINERS.get(architecture)
    if isinstance(trainer, str):
        module, _, attr = trainer.partition(":")
        try:
            trainer = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError) as exc:
            raise EvodevoError(
                f"the trainer of architecture {architecture!r} ({_TRAINERS[architecture]}) cannot "
                f"be loaded: {exc}"
            ) from None
        _TRAINERS[architecture] = trainer  # type: ignore[assignment]
    return trainer
