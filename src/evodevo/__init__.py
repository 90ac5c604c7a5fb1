"""evodevo: evolutionary developmental robotics.

Two methods from the thesis (``../shared/reference/thesis.txt``), specified in SPEC.md:

* :mod:`evodevo.neuromod` -- BIARM, a neuromodulated Progressive Neural Network (SPEC §1).
* :mod:`evodevo.grn` -- gene-regulatory-network controllers evolved for Kuka grasping (SPEC §2, §5).

Shared pieces: :mod:`evodevo.config` (typed YAML configs), :mod:`evodevo.runs` (run directories),
:mod:`evodevo.stats` (intervals and tests), :mod:`evodevo.parallel` (worker pools),
:mod:`evodevo.envs` (the Gymnasium port of KukaDiverseObjectEnv, SPEC §3).

Acting with a trained run (:mod:`evodevo.policy`)::

    policy = evodevo.load("runs/quick/grn/plain_s0")
    policy.reset()
    action = policy.predict(obs, info)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from evodevo.errors import EvodevoError

if TYPE_CHECKING:
    from collections.abc import Mapping
    from pathlib import Path

    from evodevo.policy import Policy

__all__ = ["EvodevoError", "__version__", "load"]
__version__ = "0.1.0"


def load(
    run_dir: str | Path,
    task: int | str | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Policy:
    """The trained policy of a run directory: ``policy.reset()``, ``policy.predict(obs, info)``.

    GRN, neuromodulated GRN and Kuka baseline runs (``overrides``: ``evaluation.*`` and
    ``env.*`` keys of what it is run on); for a BIARM run, ``task`` picks the column (index or
    Gymnasium id). See :mod:`evodevo.policy`.
    """
    # imported here to keep `import evodevo` light: evodevo.policy brings torch, gymnasium
    # and both methods' modules
    from evodevo.policy import load as _load

    return _load(run_dir, task, overrides)
