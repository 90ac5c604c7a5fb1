"""BIARM: neuromodulated Progressive Neural Networks for sequential multi-task RL (SPEC §1).

One idea per file: :mod:`~.config` (settings), :mod:`~.variants` (biarm, pnn, ablations),
:mod:`~.padding` (Eq. 3.10), :mod:`~.columns` (Eq. 3.8-3.9), :mod:`~.modules` (Eq. 3.1-3.6),
:mod:`~.lr_modulation` (Eq. 3.7), :mod:`~.replay`, :mod:`~.agent` (DQN update),
:mod:`~.trainer` (Algorithm 1), :mod:`~.evaluation` (§1.7), :mod:`~.checkpoint`,
:mod:`~.compare` (grid and tables), :mod:`~.figures` (Fig. 3.3-3.5),
:mod:`~.thesis_numbers` (Tables 3.2-3.5 of the thesis).

>>> from evodevo.neuromod import BiarmConfig, train
>>> BiarmConfig().network.adapter_dim
32
"""

from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.trainer import load_agent, train
from evodevo.neuromod.variants import VARIANTS, get_variant

__all__ = ["BiarmConfig", "train", "load_agent", "VARIANTS", "get_variant"]
