"""A genome as a flat vector, for optimisers that search R^N (CMA-ES).

A controller kind says which entries of its genome evolve and at what scale
(``evolvable(genome) -> {array name: (mask, scale)}``) and how to bring a genome back into its
bounds (``repair(genome)``). :class:`GenomeVector` takes one *template* genome (the initial
mean): the entries the masks select, divided by their block's scale, are the coordinates; every
other entry keeps the template's value. For the plain GRN that fixes W_r's sparsity pattern as
sampled at initialisation (only present connections are coordinates, ``connections`` never
changes) and leaves out what the config freezes; bounded parameters (theta, delta, alpha) are
clipped when a vector is decoded, the vector itself is not.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> from evodevo.grn.controller import make_controller
>>> ctrl = make_controller(GrnConfig(), n_actions=3)
>>> g = ctrl.init_genome(np.random.default_rng(0))
>>> space = GenomeVector(ctrl, g)
>>> bool(np.array_equal(space.decode(space.encode(g)).W_r, g.W_r))
True
"""

from __future__ import annotations

from typing import Any

import numpy as np

from evodevo.errors import ConfigError

__all__ = ["GenomeVector", "Block"]

Block = tuple[str, np.ndarray, float]
"""(array name, flat indices of its coordinates, scale)."""


class GenomeVector:
    """Encode and decode genomes of one controller kind around a template genome.

    Args:
        controller: a controller kind with ``evolvable``, ``repair`` and ``genome_from_arrays``.
        template: the genome whose non-evolving entries every decoded genome shares.

    Raises:
        ConfigError: if the controller kind cannot be searched as a vector, or nothing evolves.
    """

    def __init__(self, controller: Any, template: Any) -> None:
        if not (hasattr(controller, "evolvable") and hasattr(controller, "repair")):
            raise ConfigError(
                f"controller {getattr(controller, 'name', type(controller).__name__)!r} does not "
                "say which genome entries evolve (evolvable, repair); use evolution.optimizer: ga"
            )
        self.controller = controller
        self.template = {k: np.array(v, copy=True) for k, v in template.arrays().items()}
        self.blocks: list[Block] = []
        for name, (mask, scale) in controller.evolvable(template).items():
            idx = np.flatnonzero(np.asarray(mask, dtype=bool).ravel())
            if idx.size and scale > 0:
                self.blocks.append((name, idx, float(scale)))
        if not self.blocks:
            raise ConfigError("no genome entry evolves (every block is frozen or empty)")
        self.scale = np.concatenate([np.full(idx.size, s) for _, idx, s in self.blocks])

    @property
    def dim(self) -> int:
        """Number of coordinates N."""
        return int(self.scale.size)

    def names(self) -> list[str]:
        """The evolving arrays, in vector order."""
        return [name for name, _, _ in self.blocks]

    def encode(self, genome: Any) -> np.ndarray:
        """The coordinates of ``genome`` (its entries at the template's positions / scale)."""
        arrays = genome.arrays()
        parts = [np.asarray(arrays[name]).ravel()[idx] for name, idx, _ in self.blocks]
        return np.concatenate(parts) / self.scale

    def decode(self, z: np.ndarray) -> Any:
        """The genome at coordinates ``z``: the template with those entries, repaired."""
        z = np.asarray(z, dtype=np.float64)
        if z.shape != (self.dim,):
            raise ValueError(f"a vector of {self.dim} coordinates is needed, got {z.shape}")
        x = z * self.scale
        arrays = {k: v.copy() for k, v in self.template.items()}
        start = 0
        for name, idx, _ in self.blocks:
            flat = arrays[name].reshape(-1)
            flat[idx] = x[start : start + idx.size]
            start += idx.size
        return self.controller.repair(self.controller.genome_from_arrays(arrays))
