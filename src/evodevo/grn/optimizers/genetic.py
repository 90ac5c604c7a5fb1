"""The genetic algorithm of Algorithm 3 (SPEC §2.4): ``evolution.optimizer: ga``, the default.

The first population is ``evolution.population`` genomes drawn by the controller kind. After
each generation the best ``elites`` pass unchanged, best first, and the rest of the next
population are mutated copies (the kind's ``mutate``) of parents picked by tournament selection
(size ``evolution.tournament``) over the evaluated population. Every random draw comes from the
one generator it is given, in the order of the thesis' loop, so a seed gives the same run as
before optimisers were pluggable (the thesis preset bit for bit).

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> from evodevo.grn.controller import make_controller
>>> cfg = GrnConfig()
>>> ga = GeneticOptimizer(cfg, make_controller(cfg, 3), np.random.default_rng(0))
>>> pop = ga.ask()
>>> ga.tell(pop, np.arange(12.0), np.arange(12)[::-1])
>>> ga.ask()[0] is pop[11]
True
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from evodevo.grn.config import GrnConfig
from evodevo.grn.selection import tournament

__all__ = ["GeneticOptimizer"]


class GeneticOptimizer:
    """Elitism plus tournament-selected mutants (Algorithm 3).

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig` (its ``evolution`` section).
        controller: the controller kind (``init_genome``, ``mutate``).
        rng: the optimiser's generator (initial genomes, tournaments, mutations).
    """

    name = "ga"

    def __init__(self, config: GrnConfig, controller: Any, rng: np.random.Generator) -> None:
        self.config = config
        self.controller = controller
        self.rng = rng
        self.population: list[Any] = [
            controller.init_genome(rng) for _ in range(config.evolution.population)
        ]

    def ask(self) -> list[Any]:
        """The genomes to evaluate next (elites first, best first, after a :meth:`tell`)."""
        return list(self.population)

    def tell(self, population: Sequence[Any], fitness: np.ndarray, order: np.ndarray) -> None:
        """Breed the next population from the evaluated one.

        Args:
            population: the genomes evaluated (normally what :meth:`ask` returned).
            fitness: their fitness, higher is better.
            order: their indices, best first.
        """
        evo = self.config.evolution
        elites = [population[i] for i in order[: evo.elites]]
        children = [
            self.controller.mutate(
                population[tournament(fitness, evo.tournament, self.rng)], self.rng
            )
            for _ in range(evo.population - len(elites))
        ]
        self.population = elites + children

    def finalists(self, k: int) -> list[Any]:
        """The ``k`` elites bred after the last generation, best first (the final pick)."""
        return self.population[:k]

    def state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """(arrays, JSON) to checkpoint beside the population: the generator's state."""
        return {}, {"rng_state": self.rng.bit_generator.state}

    def load_state(
        self, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any], population: list[Any]
    ) -> None:
        """Continue from :meth:`state` and the checkpointed population."""
        self.rng.bit_generator.state = meta["rng_state"]
        self.population = list(population)
