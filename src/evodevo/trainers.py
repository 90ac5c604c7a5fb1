"""Registry of trainers for BIARM variant architectures that the BIARM trainer does not run.

A variant names its ``architecture`` (:mod:`evodevo.neuromod.variants`); ``progressive`` and
``shared`` networks are trained by :func:`evodevo.neuromod.trainer.train` itself. Any other
architecture is trained by a function registered here under its name, with the signature and
run files of ``train``. The baselines package registers ``sb3`` (a Stable-Baselines3 DQN per
task) when it is imported, so the method never imports its baselines: the dependency points
from the baselines to the method, and whoever runs a baseline variant (the CLI, ``reproduce``)
imports :mod:`evodevo.baselines`. A grid resolves the trainer before its worker processes start
and hands them the function itself (:func:`evodevo.neuromod.compare.run_grid`).

>>> register_trainer("noop", lambda *a, **k: {"tasks": []})
>>> get_trainer("noop")()["tasks"]
[]
>>> get_trainer("progressive") is None
True
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from evodevo.errors import EvodevoError

__all__ = ["register_trainer", "get_trainer", "OWN_ARCHITECTURES", "Trainer"]

Trainer = Callable[..., dict[str, Any]]

OWN_ARCHITECTURES = ("progressive", "shared")
"""Architectures that :func:`evodevo.neuromod.trainer.train` trains itself."""

_TRAINERS: dict[str, Trainer] = {}


def register_trainer(architecture: str, trainer: Trainer) -> None:
    """Register ``trainer`` (called like :func:`evodevo.neuromod.trainer.train`) for
    ``architecture``."""
    if architecture in OWN_ARCHITECTURES:
        raise EvodevoError(f"architecture {architecture!r} is trained by the BIARM trainer itself")
    _TRAINERS[architecture] = trainer


def get_trainer(architecture: str) -> Trainer | None:
    """The trainer registered for ``architecture``, or None for the BIARM trainer's own ones.

    Raises:
        EvodevoError: nothing is registered under ``architecture`` (the error says which
            package registers the known ones).
    """
    if architecture in OWN_ARCHITECTURES:
        return None
    try:
        return _TRAINERS[architecture]
    except KeyError:
        raise EvodevoError(
            f"no trainer is registered for architecture {architecture!r} (registered: "
            f"{sorted(_TRAINERS) or 'none'}); the baselines' trainers (sb3) register when "
            "evodevo.baselines is imported: `import evodevo.baselines` first (the CLI does)"
        ) from None
