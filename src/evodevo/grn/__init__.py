"""The GRN controller of Chapter 4 (SPEC §2): genome, dynamics, encoder, evolution, evaluation.

One idea per module: :mod:`~evodevo.grn.config` (settings), :mod:`~evodevo.grn.genome` (Eq. 4.5),
:mod:`~evodevo.grn.dynamics` (Eq. 4.1–4.4), :mod:`~evodevo.grn.encoder` (§2.2 sensors),
:mod:`~evodevo.grn.controller` (pluggable controller kinds), :mod:`~evodevo.grn.mutation`,
:mod:`~evodevo.grn.selection`, :mod:`~evodevo.grn.fitness` (Eq. 4.6),
:mod:`~evodevo.grn.evaluator` (the problem), :mod:`~evodevo.grn.evolution` (Algorithm 3),
:mod:`~evodevo.grn.open_loop` (§2.5 control), :mod:`~evodevo.grn.evaluation` (§2.5 test),
:mod:`~evodevo.grn.ablations` (§2.5 / Section 4.7), :mod:`~evodevo.grn.figures`.
"""

from evodevo.grn.config import GrnConfig
from evodevo.grn.genome import GrnGenome

__all__ = ["GrnConfig", "GrnGenome"]
