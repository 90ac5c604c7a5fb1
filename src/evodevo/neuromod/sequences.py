"""Named task sequences: YAML presets of related tasks (SPEC §1, §6).

A named sequence is a preset ``evodevo/presets/biarm_sequences/NAME.yaml`` holding a ``tasks:`` list
(each entry an ``env_id``, optionally with parameters ``ID[key=value,...]``, its episodes and
step limit). ``evodevo biarm train|compare --sequence NAME`` runs it; ``--tasks`` takes the
same ids on the command line.

>>> "cartpole-dynamics" in sequence_names()
True
>>> [t.env_id for t in load_sequence("cartpole-dynamics")][1]
'evodevo/CartPole-v1[length=1.0]'
"""

from __future__ import annotations

from evodevo.config import from_dict
from evodevo.neuromod.config import TaskConfig
from evodevo.presets import load_preset, preset_names

__all__ = ["sequence_names", "load_sequence"]

GROUP = "biarm_sequences"


def sequence_names() -> list[str]:
    """Names of the shipped sequences, sorted."""
    return preset_names(GROUP)


def load_sequence(name: str) -> list[TaskConfig]:
    """The tasks of sequence ``name``; an unknown name lists the known ones."""
    data = load_preset(GROUP, name, what="task sequence")
    return [
        from_dict(TaskConfig, t, f"sequence {name}: tasks[{i}]")
        for i, t in enumerate(data.get("tasks", []))
    ]
