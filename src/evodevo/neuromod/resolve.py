"""The config a BIARM command runs with (SPEC §1, §1.6): one resolver for every command.

Order (:func:`evodevo.config.resolve`): the :class:`~evodevo.neuromod.config.BiarmConfig`
defaults, the protocol preset (``evodevo/presets/biarm/NAME.yaml``), the ``--config`` file,
``--set key=value``, the command's flags (``--episodes-scale``), then the tasks of ``--tasks``
or ``--sequence``. Every input error is raised here, before any training.

>>> cfg = resolve_biarm(protocol="v1", sets=["eval.episodes=5"], tasks="CartPole-v1")
>>> cfg.dqn.eps_unit, cfg.eval.episodes, [t.env_id for t in cfg.tasks]
('episode', 5, ['CartPole-v1'])
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from evodevo.config import replace, resolve
from evodevo.envs.env_ids import split_env_ids
from evodevo.errors import ConfigError
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.protocols import PROTOCOLS, apply_protocol
from evodevo.neuromod.sequences import load_sequence
from evodevo.neuromod.tasks import tasks_from_ids

__all__ = ["resolve_biarm"]


def resolve_biarm(
    protocol: str | None = None,
    config: str | Path | None = None,
    sets: Sequence[str] | None = None,
    episodes_scale: float | None = None,
    tasks: str | None = None,
    sequence: str | None = None,
) -> BiarmConfig:
    """The resolved, validated config (see the module docstring for the order).

    Args:
        protocol: a DQN protocol preset (``default``, ``v3``, ``scaled``, ``v2``, ``v1``).
        config: a YAML file of config keys.
        sets: ``key.sub=value`` overrides.
        episodes_scale: multiplies every task's episodes.
        tasks: comma-separated ids, each optionally ``ID[key=value,...]``.
        sequence: a named task sequence (instead of ``tasks``).
    """
    if episodes_scale is not None and not episodes_scale > 0:
        raise ConfigError(
            f"--episodes-scale {episodes_scale} must be a positive number (e.g. 0.25)"
        )
    if tasks is not None and sequence is not None:
        raise ConfigError("--tasks and --sequence both name the tasks; give one of them")
    ids = split_env_ids(tasks) if tasks is not None else None
    if tasks is not None and not ids:
        raise ConfigError(f"--tasks {tasks!r} names nothing; give ids or leave --tasks out")
    preset = apply_protocol({}, protocol) if protocol is not None else PROTOCOLS["default"]
    cfg = resolve(BiarmConfig, preset, config, sets, {"episodes_scale": episodes_scale})
    if ids:
        cfg = replace(cfg, tasks=tasks_from_ids(cfg, ids))
    if sequence is not None:
        cfg = replace(cfg, tasks=load_sequence(sequence))
    return cfg
