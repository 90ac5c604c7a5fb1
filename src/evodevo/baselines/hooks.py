"""Hooks of a Kuka baseline's training (progress bars, TensorBoard), like neat-python's reporters.

The training code (:mod:`evodevo.baselines.sb3_kuka`, :mod:`evodevo.baselines.neat_kuka`) calls
a :class:`TrainingHooks` at three points; a hook implements the ones it needs (the others are
empty). The run directory's CSV files are written before any hook is called and stay the source
of truth.

>>> seen = []
>>> class Steps(TrainingHook):
...     def on_steps(self, env_steps: int) -> None:
...         seen.append(env_steps)
>>> TrainingHooks([Steps(), TrainingHook()]).on_steps(64)
>>> seen
[64]
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

__all__ = ["TrainingHook", "TrainingHooks"]


class TrainingHook:
    """Callbacks of a baseline's training loop; override what you need."""

    def on_steps(self, env_steps: int) -> None:
        """Training env steps so far (SB3: every step; NEAT: after every generation)."""

    def on_curve_row(self, row: dict[str, Any]) -> None:
        """A new row of ``learning_curve.csv`` (env_steps, train_s, success, mean_reward, ...)."""

    def on_generation(self, row: dict[str, Any]) -> None:
        """NEAT only: a new row of ``history.csv`` (generation, best_fitness, ...)."""


class TrainingHooks(TrainingHook):
    """Several hooks called in order (what the training code holds)."""

    def __init__(self, hooks: Iterable[Any] = ()) -> None:
        self.hooks = list(hooks)

    def on_steps(self, env_steps: int) -> None:
        for h in self.hooks:
            h.on_steps(env_steps)

    def on_curve_row(self, row: dict[str, Any]) -> None:
        for h in self.hooks:
            h.on_curve_row(row)

    def on_generation(self, row: dict[str, Any]) -> None:
        for h in self.hooks:
            h.on_generation(row)
