"""CMA-ES on the genome as a vector: ``evolution.optimizer: cmaes``.

The search runs in the coordinates of :class:`~evodevo.grn.optimizers.vector.GenomeVector`:
the entries the controller kind evolves, each divided by its block's mutation scale (for the
GRN, ``mutation.block_sigma`` or ``mutation.sigma``), so ``cmaes.sigma0 = 1`` starts with the
GA's per-entry mutation step on every coordinate. The initial mean is one genome drawn by the
kind (W_r's sparsity pattern is that genome's and stays fixed; absent connections are not
coordinates). ``cma``'s ``CMAEvolutionStrategy`` does the rest with its recommended parameters:
lambda = ``evolution.population``, mu = lambda / 2 with its log-rank weights (negative weights
for active CMA), cumulative step-size adaptation; ``cmaes.diagonal`` chooses the separable
variant (a diagonal covariance, learning rates scaled up accordingly; linear time and memory),
the default because the GRN has about 1,000 coordinates (1,038 for the vision preset's seed 0):
full covariance learns at c1 ≈ 2 / N² per generation, nothing within a 15-generation budget,
and costs an N × N matrix and its eigen-decomposition. ``cma``'s own rule of thumb keeps the covariance diagonal for the
first 100 N / sqrt(lambda) iterations (its option ``CMA_diagonal``), far beyond this budget.

Everything else is the shared loop's (:class:`~evodevo.grn.evolution.Evolution`): the same
evaluator, the same common episodes for every candidate of a generation, the same fitness, early
stop and ``keep`` rule. Candidates are ranked by the loop's fitness (CMA-ES minimises its
negative). All normal draws come from the optimiser's generator (``cma``'s ``randn`` option),
never from NumPy's global state.

The checkpoint holds the strategy as data (:mod:`~evodevo.grn.optimizers.cma_state`: mean,
step size, covariance and its eigen-decomposition, evolution paths, iteration counters, the
recombination weights), the template genome, the asked candidates as vectors (bounded
parameters are clipped in the genomes, not in the vectors), the last generation's candidates
ranked, the generator's state and the ``cma`` version; never a pickle.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> from evodevo.grn.controller import make_controller
>>> cfg = GrnConfig(); cfg.evolution.optimizer = "cmaes"
>>> opt = CmaEsOptimizer(cfg, make_controller(cfg, 3), np.random.default_rng(0))
>>> len(opt.ask()), opt.space.dim == opt.asked.shape[1]
(12, True)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.evaluator import genome_key
from evodevo.grn.optimizers.cma_state import dump_state, restore_state
from evodevo.grn.optimizers.vector import GenomeVector

__all__ = ["CmaEsOptimizer", "TEMPLATE_PREFIX"]

TEMPLATE_PREFIX = "template__"
"""Checkpoint arrays of the template genome (the non-evolving entries and the initial mean)."""


def _cma() -> Any:
    """The ``cma`` module, imported on first use: it imports scipy.stats (0.4 s), which every
    evodevo process (CLI call, worker) would pay otherwise, CMA-ES run or not."""
    import cma

    return cma


class CmaEsOptimizer:
    """(mu/mu_w, lambda)-CMA-ES from ``cma`` over a :class:`GenomeVector`.

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig` (``evolution.population``, ``cmaes``).
        controller: the controller kind (``init_genome``, ``evolvable``, ``repair``,
            ``genome_from_arrays``).
        rng: the optimiser's generator (the template genome, then every sample).
    """

    name = "cmaes"

    def __init__(self, config: GrnConfig, controller: Any, rng: np.random.Generator) -> None:
        self.config = config
        self.controller = controller
        self.rng = rng
        self.space = GenomeVector(controller, controller.init_genome(rng))
        self.es = self._strategy()
        self.last_ranked: np.ndarray | None = None
        """The last generation's candidates (vectors), best first (for :meth:`finalists`)."""
        self.asked = np.zeros((0, self.space.dim))
        self.population: list[Any] = []
        self._ask()

    def _randn(self, *shape: int) -> np.ndarray:
        """``cma``'s normal draws, from the optimiser's generator."""
        return self.rng.standard_normal(shape)

    def _strategy(self) -> Any:
        """A fresh strategy around the template genome (no random draw)."""
        c = self.config.cmaes
        opts = {
            "popsize": self.config.evolution.population,
            "CMA_diagonal": bool(c.diagonal),
            "randn": self._randn,
            "seed": np.nan,  # never seed NumPy's global generator
            "verbose": -9,
            "verb_disp": 0,
            "verb_log": 0,
        }
        mean = self.space.encode(self._template())
        return _cma().CMAEvolutionStrategy(mean, float(c.sigma0), opts)

    def _template(self) -> Any:
        return self.controller.genome_from_arrays(
            {k: v.copy() for k, v in self.space.template.items()}
        )

    def _ask(self) -> None:
        self.asked = np.array(self.es.ask(), dtype=np.float64)
        self.population = [self.space.decode(z) for z in self.asked]

    def ask(self) -> list[Any]:
        """The candidates to evaluate next (lambda samples of the current distribution)."""
        return list(self.population)

    def tell(self, population: Sequence[Any], fitness: np.ndarray, order: np.ndarray) -> None:
        """Update the distribution from the candidates' fitness, then sample the next ones.

        Args:
            population: the genomes :meth:`ask` returned, evaluated.
            fitness: their fitness, higher is better.
            order: their indices, best first.

        Raises:
            EvodevoError: if ``population`` is not the one asked for.
        """
        if len(population) != len(self.population) or any(
            a is not b for a, b in zip(population, self.population, strict=False)
        ):
            raise EvodevoError(
                "CMA-ES can only be told the candidates it sampled; the population was replaced"
            )
        f = np.asarray(fitness, dtype=np.float64)
        self.es.tell(list(self.asked), [-float(v) for v in f], check_points=False)
        self.last_ranked = self.asked[np.asarray(order, dtype=int)].copy()
        self._ask()

    def mean_genome(self) -> Any:
        """The genome at the distribution's mean (never evaluated by the loop itself)."""
        return self.space.decode(np.asarray(self.es.mean, dtype=np.float64))

    def finalists(self, k: int) -> list[Any]:
        """For the final pick: the mean's genome, then the last generation's k - 1 best."""
        if self.last_ranked is None:
            return self.population[:k]
        return [self.mean_genome()] + [self.space.decode(z) for z in self.last_ranked[: k - 1]]

    def state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """(arrays, JSON) to checkpoint beside the population (see the module docstring)."""
        tree, es_arrays = dump_state(self.es)
        arrays = {f"{TEMPLATE_PREFIX}{k}": v for k, v in self.space.template.items()}
        arrays.update(es_arrays)  # keys are attribute paths, "es.…"
        arrays["asked"] = self.asked
        if self.last_ranked is not None:
            arrays["last_ranked"] = self.last_ranked
        meta = {
            "rng_state": self.rng.bit_generator.state,
            "cmaes": {
                "cma_version": _cma().__version__,
                "dim": self.space.dim,
                "blocks": self.space.names(),
                "tree": tree,
            },
        }
        return arrays, meta

    def load_state(
        self, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any], population: list[Any]
    ) -> None:
        """Continue from :meth:`state` and the checkpointed population.

        Raises:
            CheckpointError: if the state is missing, was written by another ``cma`` version,
                does not fit this config, or does not match the population.
        """
        info = meta.get("cmaes")
        if not isinstance(info, dict):
            raise CheckpointError(
                "the checkpoint holds no CMA-ES state (it was written with evolution.optimizer: "
                "ga); resume it with the optimizer it was started with"
            )
        if info.get("cma_version") != _cma().__version__:
            raise CheckpointError(
                f"the CMA-ES state was written with cma {info.get('cma_version')!r}; this "
                f"environment has cma {_cma().__version__}. Resume with that cma version "
                "(pip install cma==VERSION) or start a new run"
            )
        template = {
            k[len(TEMPLATE_PREFIX) :]: np.array(v)
            for k, v in arrays.items()
            if k.startswith(TEMPLATE_PREFIX)
        }
        try:
            space = GenomeVector(self.controller, self.controller.genome_from_arrays(template))
        except (KeyError, ValueError) as exc:
            raise CheckpointError(f"the CMA-ES template genome is damaged ({exc})") from None
        if space.dim != info.get("dim") or space.names() != info.get("blocks"):
            raise CheckpointError(
                f"the CMA-ES state has {info.get('dim')} coordinates in {info.get('blocks')}, "
                f"this config evolves {space.dim} in {space.names()}"
            )
        asked = np.asarray(arrays.get("asked", np.zeros((0, 0))), dtype=np.float64)
        if asked.shape != (len(population), space.dim):
            raise CheckpointError(
                f"the CMA-ES candidates have shape {asked.shape}, expected "
                f"({len(population)}, {space.dim})"
            )
        if [genome_key(space.decode(z)) for z in asked] != [genome_key(g) for g in population]:
            raise CheckpointError("the CMA-ES candidates do not match the checkpoint's population")
        self.space = space
        self.es = self._strategy()
        restore_state(
            self.es, info.get("tree"), {k: v for k, v in arrays.items() if k[:3] == "es."}
        )
        self.asked = asked
        self.population = list(population)
        ranked = arrays.get("last_ranked")
        self.last_ranked = None if ranked is None else np.asarray(ranked, dtype=np.float64)
        self.rng.bit_generator.state = meta["rng_state"]
