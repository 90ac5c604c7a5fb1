"""Optimisers of a controller's genome (the *searcher*; SPEC §2.4), chosen by ``evolution.optimizer``.

An optimiser proposes the genomes of a generation (:meth:`Optimizer.ask`) and learns from their
fitness (:meth:`Optimizer.tell`); the loop that evaluates them on common episodes, scores them,
checks the early stop, keeps the returned genome and checkpoints is shared
(:class:`~evodevo.grn.evolution.Evolution`), and so is the evaluator (the *problem*).

* ``ga`` (:mod:`.genetic`): the thesis' Algorithm 3, the default;
* ``cmaes`` (:mod:`.cmaes`): CMA-ES from the ``cma`` library on the genome as a vector
  (:mod:`.vector`), its state checkpointed as data (:mod:`.cma_state`).

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> from evodevo.grn.controller import make_controller
>>> cfg = GrnConfig()
>>> make_optimizer(cfg, make_controller(cfg, 3), np.random.default_rng(0)).name
'ga'
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from evodevo.errors import ConfigError
from evodevo.grn.config import GrnConfig
from evodevo.grn.optimizers.cmaes import CmaEsOptimizer
from evodevo.grn.optimizers.genetic import GeneticOptimizer

__all__ = ["Optimizer", "OPTIMIZER_CLASSES", "make_optimizer", "GeneticOptimizer", "CmaEsOptimizer"]


class Optimizer(Protocol):
    """What the shared loop needs from a searcher."""

    name: str

    def ask(self) -> list[Any]:
        """The genomes to evaluate next (the same list until :meth:`tell`)."""
        ...

    def tell(self, population: Sequence[Any], fitness: np.ndarray, order: np.ndarray) -> None:
        """Learn from the evaluated population (fitness: higher is better; order: best first)."""
        ...

    def finalists(self, k: int) -> list[Any]:
        """Up to ``k`` genomes for the final re-selection (``evolution.final_pick_episodes``)."""
        ...

    def state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Arrays and JSON that, with the population, continue the search exactly."""
        ...

    def load_state(
        self, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any], population: list[Any]
    ) -> None:
        """Continue from :meth:`state` and the checkpointed population."""
        ...


OPTIMIZER_CLASSES: dict[str, Callable[[Any, Any, np.random.Generator], Optimizer]] = {
    "ga": GeneticOptimizer,
    "cmaes": CmaEsOptimizer,
}
"""Optimiser by ``evolution.optimizer`` name."""


def make_optimizer(config: GrnConfig, controller: Any, rng: np.random.Generator) -> Optimizer:
    """The optimiser ``config.evolution.optimizer`` for ``controller``, drawing from ``rng``."""
    name = config.evolution.optimizer
    if name not in OPTIMIZER_CLASSES:
        raise ConfigError(
            f"evolution.optimizer={name!r} is not known; choose one of {sorted(OPTIMIZER_CLASSES)}"
        )
    return OPTIMIZER_CLASSES[name](config, controller, rng)
