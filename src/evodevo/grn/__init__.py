"""The GRN controller of Chapter 4 (SPEC §2): genome, dynamics, encoder, evolution, evaluation.

One idea per module: :mod:`~evodevo.grn.config` (settings), :mod:`~evodevo.grn.genome` (Eq. 4.5),
:mod:`~evodevo.grn.dynamics` (Eq. 4.1–4.4), :mod:`~evodevo.grn.encoder` (§2.2 sensors),
:mod:`~evodevo.grn.controller` (pluggable controller kinds; the package registers its
kinds here), :mod:`~evodevo.grn.mutation`,
:mod:`~evodevo.grn.selection`, :mod:`~evodevo.grn.fitness` (Eq. 4.6),
:mod:`~evodevo.grn.evaluator` (the problem), :mod:`~evodevo.grn.evolution` (Algorithm 3),
:mod:`~evodevo.grn.open_loop` (§2.5 control), :mod:`~evodevo.grn.evaluation` (§2.5 test),
:mod:`~evodevo.grn.ablations` (§2.5 / Section 4.7), :mod:`~evodevo.grn.figures`.
"""

from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import register_controller
from evodevo.grn.feedforward import LinearController, MlpController
from evodevo.grn.genome import GrnGenome
from evodevo.grn.neuromodulated import NeuromodGrnController
from evodevo.grn.open_loop import OpenLoopController

__all__ = ["GrnConfig", "GrnGenome"]

# The package's controller kinds besides the plain GRN (grn.controller), registered by name
# whenever anything of evodevo.grn is imported (the package is imported first).
register_controller("neuromodulated", NeuromodGrnController)
register_controller("open_loop", OpenLoopController)
register_controller("linear", LinearController)
register_controller("mlp", MlpController)
