"""``evodevo reproduce``: rerun both methods at a budget and write one report.

* :mod:`evodevo.reproduce.budget` -- the typed budget config (``quick`` and ``thesis`` presets).
* :mod:`evodevo.reproduce.pipeline` -- the resumable list of CLI steps.
* :mod:`evodevo.reproduce.report` -- ``report.md`` / ``report.html`` from the saved run files.
"""

from evodevo.reproduce.budget import ReproduceConfig, preset
from evodevo.reproduce.pipeline import run_reproduce

__all__ = ["ReproduceConfig", "preset", "run_reproduce"]
