"""Presets: named YAML files of config overrides, shipped inside the package (SPEC §1.6, §2.4).

``presets/<group>/<name>.yaml`` holds only the keys a preset changes from the dataclass
defaults; the config resolver (:func:`evodevo.config.resolve`) applies it right after the
defaults, before a ``--config`` file, ``--set`` and the command's flags. Groups: ``biarm``
(the DQN protocols of SPEC §1.6: ``default``, ``v3``, ``scaled``, ``v2``, ``v1``) and
``biarm_sequences`` (named task sequences).

>>> preset_names("biarm")
['default', 'scaled', 'v1', 'v2', 'v3']
>>> load_preset("biarm", "v1")["dqn"]["eps_unit"]
'episode'
"""

from __future__ import annotations

from importlib import resources
from importlib.resources.abc import Traversable
from typing import Any

import yaml

from evodevo.errors import ConfigError

__all__ = ["preset_names", "load_preset"]


def _folder(group: str) -> Traversable:
    folder = resources.files(__name__).joinpath(group)
    if not folder.is_dir():
        raise ConfigError(f"no preset group {group!r} in evodevo/presets")
    return folder


def preset_names(group: str) -> list[str]:
    """The names of a group's presets, sorted."""
    return sorted(
        p.name[: -len(".yaml")] for p in _folder(group).iterdir() if p.name.endswith(".yaml")
    )


def load_preset(group: str, name: str, what: str = "preset") -> dict[str, Any]:
    """The overrides of preset ``name``; an unknown name lists the known ones."""
    path = _folder(group).joinpath(f"{name}.yaml")
    if not path.is_file():
        raise ConfigError(
            f"{what} {name!r} is not one of {', '.join(preset_names(group))} "
            f"(evodevo/presets/{group}/)"
        )
    data = yaml.safe_load(path.read_text()) or {}
    if not isinstance(data, dict):
        raise ConfigError(f"preset evodevo/presets/{group}/{name}.yaml must hold a mapping")
    return data
