"""Resuming a BIARM run (SPEC §1.6): which saved settings must match, and the keys added to the
config after older runs were saved, filled in as those runs ran.

>>> saved_config({"dqn": {"lr": 0.001}})["dqn"]
{'train_every': 1, 'per_task': {}, 'lr': 0.001}
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from evodevo.config import to_dict
from evodevo.errors import EvodevoError
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.variants import Variant
from evodevo.runs import RunDir

__all__ = ["ADDED_KEYS", "saved_config", "check_resume", "open_run"]


#: keys added to the config after runs were saved without them -> the value those runs ran with
ADDED_KEYS: dict[str, dict[str, Any]] = {
    "dqn": {"train_every": 1, "per_task": {}},
    "network": {"lateral_init": "xavier", "lateral_scale": 1.0, "stale_padding": True},
    "modules": {"lr_relative": False},
}


def saved_config(data: dict[str, Any]) -> dict[str, Any]:
    """A run's saved ``config`` (``config.json``) with the keys added since it was written
    filled in as that run ran (not with today's defaults), so it resumes as it started.

    >>> saved_config({"dqn": {"lr": 0.001}})["dqn"]
    {'train_every': 1, 'per_task': {}, 'lr': 0.001}
    """
    out = dict(data)
    for section, added in ADDED_KEYS.items():
        if isinstance(out.get(section), dict):
            out[section] = {**added, **out[section]}
    return out


def check_resume(run: RunDir, variant: Variant, seed: int, cfg: BiarmConfig) -> None:
    """``--resume`` of a BIARM run (the trainer's and SB3's DQN per task): the saved
    variant, seed, tasks, episodes scale, DQN and network settings (and the modules' for a
    modulated variant) must be this run's; the lateral kernel may differ."""
    saved = run.read_config()
    mine = {"variant": variant.name, "seed": seed, **to_dict(cfg)}
    theirs = saved_config(saved.get("config", {}))
    # network.lateral_kernel picks an implementation, not the experiment: runs may resume
    # across it (and configs written before it existed lack it)
    for part in (theirs, mine):
        if isinstance(part.get("network"), dict):
            part["network"] = {k: v for k, v in part["network"].items() if k != "lateral_kernel"}
    keys = ["variant", "seed", "tasks", "episodes_scale", "dqn", "network"]
    if variant.modulated:  # the modules' settings change nothing in PNN, fine-tuning or EWC
        keys.append("modules")
    run.check_same_config(mine, keys, theirs)


def open_run(
    cfg: BiarmConfig, variant: Variant, seed: int, out: str | Path, resume: bool, started: bool
) -> RunDir:
    """The run folder of a BIARM run (the trainer's and SB3's DQN per task): a new run writes
    its config and refuses a folder that already holds a started run (``started``: it has
    checkpoints); a resumed one must match the saved config (:func:`check_resume`)."""
    run = RunDir(out)
    if started and not resume:
        raise EvodevoError(
            f"{str(run.path)!r} already holds checkpoints of a run; pass --resume to continue "
            "it or choose another --out"
        )
    if resume and (run / "config.json").is_file():
        check_resume(run, variant, seed, cfg)
    else:
        run.write_config({"variant": variant.name, "seed": seed, **to_dict(cfg)}, kind="biarm")
    return run
