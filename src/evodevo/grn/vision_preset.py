"""The vision preset: the default of ``evodevo grn evolve`` (SPEC §2; docs/results/grn.md).

It holds only what differs from the thesis defaults of :class:`~evodevo.grn.config.GrnConfig`
(``configs/grn.yaml``); ``configs/grn_vision.yaml`` spells it out and a test checks both agree.
"""

from __future__ import annotations

import copy
from typing import Any

__all__ = ["VISION_PRESET", "vision_preset"]


VISION_PRESET: dict[str, Any] = {
    "dynamics": {"dt": 0.1, "substeps": 10, "restart": True},
    "sensors": {"encoder": "blob", "feature_dim": 4, "proprio": False},
    "genome": {"ws_std": 1.0, "p_init": "identity"},
    "mutation": {"p_weight": 0.5},
    "evolution": {
        "early_stop": False,
        "early_stop_success": 0.8,
        "retest_success": 0.7,
        "keep": "record",
    },
    "evaluation": {"distance_weight": 1.0},
}
"""The default preset of ``evodevo grn evolve``: what differs from the thesis
defaults (``configs/grn.yaml``). ``configs/grn_vision.yaml`` spells it out; a test checks both
agree. Values chosen by measurement (docs/results/grn.md)."""


def vision_preset() -> dict[str, Any]:
    """A copy of :data:`VISION_PRESET` (overrides of the thesis defaults)."""
    return copy.deepcopy(VISION_PRESET)
