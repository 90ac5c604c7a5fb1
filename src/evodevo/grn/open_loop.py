"""The best open-loop policy control (SPEC §2.5): a fixed action sequence, evolved directly.

The genome is one (steps, A) array of actions in [-1, 1]; step t of an episode plays row t (the
last row repeats if an episode runs longer). It is evolved by the same optimiser
(:mod:`evodevo.grn.evolution`) with the same budget as the GRN: only the controller kind differs
(``controller: open_loop``). It sees nothing, so it measures what the benchmark gives away.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> ctrl = OpenLoopController(GrnConfig(), n_actions=3)
>>> ctrl.init_genome(np.random.default_rng(0)).actions.shape
(8, 3)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.grn.genome import load_arrays, save_arrays

__all__ = ["OpenLoopGenome", "OpenLoopController", "OpenLoopState"]


@dataclass
class OpenLoopGenome:
    """A fixed action sequence (steps, A) in [-1, 1]."""

    actions: np.ndarray

    KIND = "open_loop"

    def arrays(self) -> dict[str, np.ndarray]:
        return {"actions": self.actions}

    def copy(self) -> OpenLoopGenome:
        return OpenLoopGenome(self.actions.copy())

    def connections(self) -> int:
        """Open-loop genomes have no regulatory connections."""
        return 0

    def save(self, path: str | Path, config: dict[str, Any] | None = None) -> None:
        save_arrays(path, self.KIND, self.arrays(), {"config": dict(config or {})})

    @classmethod
    def load(cls, path: str | Path, n_actions: int | None = None) -> OpenLoopGenome:
        arrays, _ = load_arrays(path, cls.KIND)
        if "actions" not in arrays:
            raise CheckpointError(f"{str(path)!r} lacks the array 'actions'")
        a = arrays["actions"]
        if a.ndim != 2 or (n_actions is not None and a.shape[1] != n_actions):
            raise CheckpointError(
                f"{str(path)!r}: actions have shape {a.shape}, expected (steps, {n_actions})"
            )
        return cls(a)


@dataclass
class OpenLoopState:
    """Stacked sequences (B, steps, A) and the step counter of each slot."""

    actions: np.ndarray
    t: np.ndarray


class OpenLoopController:
    """Controller kind ``open_loop`` (see module docstring)."""

    name = "open_loop"
    uses_encoder = False

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        self.cfg = config.open_loop
        self.n_actions = int(n_actions)

    def init_genome(self, rng: np.random.Generator) -> OpenLoopGenome:
        return OpenLoopGenome(
            rng.uniform(self.cfg.init_low, self.cfg.init_high, (self.cfg.steps, self.n_actions))
        )

    def mutate(self, genome: OpenLoopGenome, rng: np.random.Generator) -> OpenLoopGenome:
        child = genome.copy()
        if rng.random() < self.cfg.p_mutate:
            child.actions += rng.normal(0.0, self.cfg.sigma, child.actions.shape)
        np.clip(child.actions, -1.0, 1.0, out=child.actions)
        return child

    def load_genome(self, path: str | Path) -> OpenLoopGenome:
        return OpenLoopGenome.load(path, self.n_actions)

    def connections(self, genome: OpenLoopGenome) -> int:
        return genome.connections()

    def genome_from_arrays(self, arrays: dict[str, np.ndarray]) -> OpenLoopGenome:
        return OpenLoopGenome(np.asarray(arrays["actions"]))

    def evolvable(self, genome: OpenLoopGenome) -> dict[str, tuple[np.ndarray, float]]:
        """Every action moves, at the scale ``open_loop.sigma`` (CMA-ES)."""
        return {"actions": (np.ones(genome.actions.shape, dtype=bool), self.cfg.sigma)}

    def repair(self, genome: OpenLoopGenome) -> OpenLoopGenome:
        """Clip the actions to [-1, 1] (in place)."""
        np.clip(genome.actions, -1.0, 1.0, out=genome.actions)
        return genome

    def reset_state(self, genomes: Sequence[OpenLoopGenome]) -> OpenLoopState:
        return OpenLoopState(np.stack([g.actions for g in genomes]), np.zeros(len(genomes), int))

    def step(
        self,
        state: OpenLoopState,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        t = np.minimum(state.t[idx], state.actions.shape[1] - 1)
        state.t[idx] += 1
        return state.actions[idx, t]
