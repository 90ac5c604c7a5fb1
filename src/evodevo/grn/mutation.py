"""The three mutation kinds of SPEC §2.4 (Section 4.4.5), each decided independently.

* structural, ``p_struct``: toggle one random regulatory connection (absent → N(0, struct_std²),
  present → 0);
* weight, ``p_weight`` per matrix (W_s, W_r, W_m, P): add N(0, sigma²) to its entries — for W_r
  only to the present entries, so sparsity changes only through structural mutation, unless
  ``dense_regulatory_noise`` reproduces the thesis' dense noise;
* parameter, ``p_param`` per vector (theta, delta, alpha): add N(0, sigma²), clip to the bounds.

``block_sigma`` and ``block_p`` override sigma and the probabilities for named blocks (ours, not
the thesis'; empty by default, which draws the same numbers as before). With
``genome.regulation: false`` (the no-regulation arm) W_r is all zeros and neither structural nor
W_r weight mutation happens (no draw is made for them), so it stays zero.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> from evodevo.grn.genome import init_genome
>>> cfg = GrnConfig(); rng = np.random.default_rng(0)
>>> child = mutate_genome(init_genome(cfg, 3, rng), cfg, rng)
>>> bool(child.theta.min() >= 0.1)
True
"""

from __future__ import annotations

import numpy as np

from evodevo.grn.config import PARAMETER_BLOCKS, WEIGHT_BLOCKS, GrnConfig
from evodevo.grn.genome import GrnGenome

__all__ = ["mutate_genome", "clip_to_bounds"]


def clip_to_bounds(genome: GrnGenome, config: GrnConfig) -> GrnGenome:
    """Clip theta, delta and alpha to their bounds (in place); returns ``genome``."""
    for name in PARAMETER_BLOCKS:
        lo, hi = getattr(config.genome, f"{name}_bounds")
        np.clip(getattr(genome, name), lo, hi, out=getattr(genome, name))
    return genome


def mutate_genome(parent: GrnGenome, config: GrnConfig, rng: np.random.Generator) -> GrnGenome:
    """A mutated copy of ``parent`` (the parent is left untouched).

    Args:
        parent: the genome to copy.
        config: a :class:`~evodevo.grn.config.GrnConfig` (its ``mutation`` and ``genome`` sections).
        rng: the evolution's generator; every decision and draw comes from it.
    """
    m = config.mutation
    regulation = bool(config.genome.regulation)
    child = parent.copy()
    if regulation and rng.random() < m.p_struct:
        n = child.W_r.shape[0]
        k, i = int(rng.integers(n)), int(rng.integers(n))
        if child.W_r[k, i] != 0.0:
            child.W_r[k, i] = 0.0
        else:
            value = 0.0
            while value == 0.0:  # a new connection must exist (N(0, s²) is 0 with probability 0)
                value = float(rng.normal(0.0, m.struct_std)) if m.struct_std > 0 else 1e-3
            child.W_r[k, i] = value
    for name in WEIGHT_BLOCKS:
        if name == "W_r" and not regulation:
            continue
        if rng.random() < m.p_of(name):
            w = getattr(child, name)
            noise = rng.normal(0.0, m.sigma_of(name), w.shape)
            if name == "W_r" and not m.dense_regulatory_noise:
                present = w != 0.0
                w[present] += noise[present]
                # an existing connection that lands exactly on 0 stays present
                w[present & (w == 0.0)] = np.finfo(float).tiny
            else:
                w += noise
    for name in PARAMETER_BLOCKS:
        if rng.random() < m.p_of(name):
            v = getattr(child, name)
            v += rng.normal(0.0, m.sigma_of(name), v.shape)
    return clip_to_bounds(child, config)
