"""The wall and CPU time of a resumable run, summed over the sessions that resumed it.

Used by the BIARM trainer (:mod:`evodevo.neuromod.trainer`) and the SB3 DQN baseline
(:mod:`evodevo.baselines.sb3_dqn_tasks`) for the ``wall_seconds`` / ``cpu_seconds`` /
``timing_complete`` keys of their ``summary.json``: the cost of a run, reported beside its
returns (the cost per full run that docs/results/biarm.md states).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any


class RunClock:
    """Wall and CPU seconds of a run so far, summed over the sessions that resumed it.

    ``before`` is the previous sessions' total, as a checkpoint saved it (``None``: a fresh
    run; :attr:`UNKNOWN`: resumed from a checkpoint that does not carry it, so only the time
    since is counted and ``timing_complete`` is false). The work after the newest checkpoint of
    a killed session is not counted: it is redone. CPU time is this process's own
    (:func:`time.process_time`), robust to other jobs sharing the cores. Calling the clock
    returns the ``wall_seconds`` / ``cpu_seconds`` / ``timing_complete`` keys of a summary.
    """

    UNKNOWN: Mapping[str, Any] = {"wall_seconds": 0.0, "cpu_seconds": 0.0, "timing_complete": False}

    def __init__(self, before: Mapping[str, Any] | None = None) -> None:
        self.before = {"wall_seconds": 0.0, "cpu_seconds": 0.0, "timing_complete": True}
        self.before.update(before or {})
        self._wall = time.perf_counter()
        self._cpu = time.process_time()

    def __call__(self) -> dict[str, Any]:
        return {
            "wall_seconds": float(self.before["wall_seconds"]) + time.perf_counter() - self._wall,
            "cpu_seconds": float(self.before["cpu_seconds"]) + time.process_time() - self._cpu,
            "timing_complete": bool(self.before["timing_complete"]),
        }
