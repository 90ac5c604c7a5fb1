"""Named task sequences: YAML presets of related tasks (SPEC §1, §6).

A named sequence is a file ``evodevo/presets/sequences/NAME.yaml`` holding a ``tasks:`` list
(each entry an ``env_id``, optionally with parameters ``ID[key=value,...]``, its episodes and
step limit). ``evodevo biarm train|compare --sequence NAME`` runs it; ``--tasks`` takes the
same ids on the command line.

>>> "cartpole-dynamics" in sequence_names()
True
>>> [t.env_id for t in load_sequence("cartpole-dynamics")][1]
'evodevo/CartPole-v1[length=1.0]'
"""

from __future__ import annotations

from importlib import resources

import yaml

from evodevo.config import from_dict
from evodevo.errors import ConfigError
from evodevo.neuromod.config import TaskConfig

__all__ = ["sequence_names", "load_sequence"]


def _folder() -> resources.abc.Traversable:
    return resources.files("evodevo").joinpath("presets", "sequences")


def sequence_names() -> list[str]:
    """Names of the shipped sequences, sorted."""
    return sorted(p.name[: -len(".yaml")] for p in _folder().iterdir() if p.name.endswith(".yaml"))


def load_sequence(name: str) -> list[TaskConfig]:
    """The tasks of sequence ``name``; an unknown name lists the known ones."""
    path = _folder().joinpath(f"{name}.yaml")
    if not path.is_file():
        raise ConfigError(
            f"unknown task sequence {name!r}; choose one of {', '.join(sequence_names())} "
            "(or give the ids with --tasks)"
        )
    data = yaml.safe_load(path.read_text())
    return [
        from_dict(TaskConfig, t, f"sequence {name}: tasks[{i}]")
        for i, t in enumerate(data["tasks"])
    ]
