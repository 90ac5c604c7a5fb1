"""Named DQN protocols: the details Table 3.1 leaves open, as presets (SPEC §1.6).

A protocol is a preset file ``evodevo/presets/biarm/NAME.yaml``: a set of overrides of :class:`~evodevo.neuromod.config.BiarmConfig`'s defaults
(only keys Table 3.1 and SPEC §1.2 do not fix). ``default`` is the config's defaults, the
protocol the measurements picked (``docs/results/biarm.md``): ε × 0.995 per environment step,
a soft target (τ 0.005), the best validated network kept, the earlier columns' activations
scaled by ``network.lateral_scale`` = 0.0001 where a new column reads them, a new column's
lateral maps starting at zero (``network.lateral_init``: it starts as an isolated column),
BIARM's Eq. 3.7 taken relative to the modules' resting state (``modules.lr_relative``: η_base
at rest instead of η_base / 2; PNN is unaffected), 20 greedy validation episodes per check
(``eval.validation_episodes``), and CartPole's gradient norm clipped at 1 instead of 10
(``dqn.per_task``: its column no longer collapses; MountainCar needs the looser clip to carry
its rare flag back). ``v3`` is the previous default, without the per-task clip
(``docs/results/thesis/biarm_v3``); ``scaled`` is ``v3`` with 10 validation episodes, as
its first full runs (``docs/results/thesis/biarm_scaled``) were made.
``v2`` is the default of 2026-12-04 (``docs/results/thesis/biarm_default``): the same DQN
details with unscaled, Xavier-initialised laterals, Eq. 3.7 as written and 10 validation
episodes. ``v1`` is the first protocol, under which the committed first results
(``docs/results/thesis/biarm``) were measured: ε × 0.995 per *episode*, a hard target copy
every 500 gradient steps, no double Q, the last network kept, unscaled laterals, and the
padding bug (``network.stale_padding``). ``configs/biarm.yaml``, ``configs/biarm_v2.yaml`` and
``configs/biarm_spec_v1.yaml`` hold the default, ``v2`` and ``v1`` as files (``v3`` and
``scaled`` are ``--protocol`` only).

>>> protocol_config("v1").dqn.eps_unit
'episode'
>>> protocol_config("default").dqn.eps_unit
'step'
>>> protocol_config("default").network.lateral_scale
0.0001
>>> protocol_config("v2").network.lateral_init
'xavier'
>>> protocol_config("default").dqn.for_task("CartPole-v1").grad_clip
1.0
>>> protocol_config("v3").dqn.for_task("CartPole-v1").grad_clip
10.0
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from evodevo.config import from_dict, merge, to_dict
from evodevo.errors import ConfigError
from evodevo.neuromod.config import BiarmConfig
from evodevo.presets import load_preset

__all__ = ["PROTOCOL_NAMES", "PROTOCOLS", "protocol_config", "apply_protocol"]

#: The protocols in the order of the help text, newest first.
PROTOCOL_NAMES: tuple[str, ...] = ("default", "v3", "scaled", "v2", "v1")

#: name -> overrides of the config defaults, read from ``evodevo/presets/biarm/NAME.yaml``.
PROTOCOLS: dict[str, dict[str, Any]] = {n: load_preset("biarm", n) for n in PROTOCOL_NAMES}


def apply_protocol(data: Mapping[str, Any], name: str) -> dict[str, Any]:
    """Overrides ``data`` (nested dict, e.g. from ``--set``) on top of protocol ``name``'s
    keys: the CLI applies the result over the config file, so the order is defaults, config
    file, protocol, ``--set``."""
    if name not in PROTOCOLS:
        raise ConfigError(
            f"protocol {name!r} is not one of {', '.join(PROTOCOLS)}; see docs/results/biarm.md"
        )
    return merge(PROTOCOLS[name], data)


def protocol_config(name: str) -> BiarmConfig:
    """The full config of protocol ``name``."""
    return from_dict(BiarmConfig, merge(to_dict(BiarmConfig()), apply_protocol({}, name)))
