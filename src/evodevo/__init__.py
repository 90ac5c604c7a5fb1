"""evodevo: evolutionary developmental robotics.

Two methods from the thesis (``../shared/reference/thesis.txt``), specified in SPEC.md:

* :mod:`evodevo.neuromod` -- BIARM, a neuromodulated Progressive Neural Network (SPEC §1).
* :mod:`evodevo.grn` -- gene-regulatory-network controllers evolved for Kuka grasping (SPEC §2, §5).

Shared pieces: :mod:`evodevo.config` (typed YAML configs), :mod:`evodevo.runs` (run directories),
:mod:`evodevo.stats` (intervals and tests), :mod:`evodevo.parallel` (worker pools),
:mod:`evodevo.envs` (the Gymnasium port of KukaDiverseObjectEnv, SPEC §3).
"""

from evodevo.errors import EvodevoError

__all__ = ["EvodevoError", "__version__"]
__version__ = "0.1.0"
