"""Controllers: encoder features + a batch of genomes + dynamics → one action per env (SPEC §2.1–2.2).

A *controller kind* is a pluggable piece with one interface (:class:`ControllerKind`):
``init_genome`` / ``mutate`` / ``load_genome`` for the optimiser, and the vectorised runtime
``reset_state`` / ``step`` for the evaluator, which calls ``step`` once per env step for all
the episodes it runs in lockstep. Kinds are looked up by name in a registry
(:func:`register_controller`, :func:`make_controller`); ``config.controller`` may also be a
``"module:attr"`` path, so a new kind (e.g. a neuromodulated GRN, SPEC §5) plugs in without
editing this package. The trivial policies of SPEC §2.5 (all-zero, uniform-random and constant-turn actions)
share the runtime interface (:data:`BASELINES`).

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> ctrl = make_controller(GrnConfig(), n_actions=3)
>>> g = ctrl.init_genome(np.random.default_rng(0))
>>> state = ctrl.reset_state([g, g])
>>> a = ctrl.step(state, np.arange(2), np.zeros((2, 128)), np.zeros((2, 4)),
...               [np.random.default_rng(1), np.random.default_rng(2)], np.array([False, True]))
>>> a.shape
(2, 3)
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from evodevo.errors import CheckpointError, ConfigError, EvodevoError
from evodevo.grn.config import GENOME_BLOCKS, GrnConfig
from evodevo.grn.dynamics import expression_step, motor_output
from evodevo.grn.encoder import sensor_vector
from evodevo.grn.genome import GrnGenome, init_genome, stack_genomes
from evodevo.grn.mutation import clip_to_bounds, mutate_genome
from evodevo.safe_io import check_import

__all__ = [
    "Policy",
    "ControllerKind",
    "VectorSearchable",
    "GrnState",
    "PlainGrnController",
    "ZeroPolicy",
    "RandomPolicy",
    "TurnPolicy",
    "BASELINES",
    "register_controller",
    "check_controller",
    "controller_names",
    "make_controller",
]


@runtime_checkable
class Policy(Protocol):
    """What the evaluator needs: a batched state and one vectorised step per env step."""

    uses_encoder: bool

    def reset_state(self, genomes: Sequence[Any]) -> Any:
        """State for a batch of episodes, one genome per slot (same-shaped genomes)."""
        ...

    def step(
        self,
        state: Any,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        """Advance slots ``idx`` (still running) by one step and return their actions (len(idx), A).

        Args:
            state: from :meth:`reset_state`; updated in place.
            idx: indices of the slots to advance.
            features: encoder features (len(idx), 128), or None if ``uses_encoder`` is False.
            proprio: proprioceptive values (len(idx), 4).
            rngs: one generator per slot in ``idx`` (per genome and episode).
            noisy: per slot in ``idx``, whether the visual features get noise.
        """
        ...


@runtime_checkable
class ControllerKind(Policy, Protocol):
    """A policy the optimiser can evolve."""

    name: str

    def init_genome(self, rng: np.random.Generator) -> Any:
        """A random genome."""
        ...

    def mutate(self, genome: Any, rng: np.random.Generator) -> Any:
        """A mutated copy."""
        ...

    def load_genome(self, path: str | Path) -> Any:
        """A genome saved with ``genome.save(path, config)``, checked against this controller."""
        ...

    def connections(self, genome: Any) -> int:
        """Structural size reported per generation (regulatory connections)."""
        ...

    def genome_from_arrays(self, arrays: dict[str, np.ndarray]) -> Any:
        """Rebuild a genome from its ``arrays()`` (checkpoints)."""
        ...


@runtime_checkable
class VectorSearchable(Protocol):
    """A controller kind whose genome an optimiser over R^N can search (CMA-ES)."""

    def evolvable(self, genome: Any) -> dict[str, tuple[np.ndarray, float]]:
        """Per array of ``genome.arrays()`` that evolves: (boolean mask of the entries that
        evolve, the scale of one step); arrays left out keep their value."""
        ...

    def repair(self, genome: Any) -> Any:
        """``genome`` brought into its bounds (in place); returns it."""
        ...


@dataclass
class GrnState:
    """Batched runtime state of the plain GRN: stacked genomes and expression x (B, n)."""

    genome: GrnGenome
    x: np.ndarray


class PlainGrnController:
    """The GRN controller of SPEC §2 (Algorithm 2, vectorised).

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig`.
        n_actions: action dimensions of the environment.
    """

    name = "plain"
    uses_encoder = True

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        self.config = config
        self.n_actions = int(n_actions)
        self.dyn = config.dynamics
        self.sensors = config.sensors
        self.uses_encoder = not config.sensors.blind

    @property
    def n_sensors(self) -> int:
        return int(self.sensors.n_visual + self.sensors.n_proprio)

    def init_genome(self, rng: np.random.Generator) -> GrnGenome:
        return init_genome(self.config, self.n_actions, rng)

    def mutate(self, genome: GrnGenome, rng: np.random.Generator) -> GrnGenome:
        return mutate_genome(genome, self.config, rng)

    def load_genome(self, path: str | Path) -> GrnGenome:
        g = GrnGenome.load(
            path,
            self.n_sensors,
            self.n_actions,
            self.sensors.n_visual,
            frontend=self.sensors.encoder,
            feature_dim=self.sensors.feature_dim,
        )
        self.check_regulation(g.W_r, str(path))
        return g

    def connections(self, genome: GrnGenome) -> int:
        return genome.connections()

    def genome_from_arrays(self, arrays: dict[str, np.ndarray]) -> GrnGenome:
        g = GrnGenome(**{n: arrays[n] for n in GrnGenome.names()})
        g.check(self.n_sensors, self.n_actions, self.sensors.n_visual)
        self.check_regulation(g.W_r)
        return g

    def check_regulation(self, W_r: np.ndarray, where: str = "genome") -> None:
        """With ``genome.regulation: false`` a genome must have no regulatory connection."""
        if not self.config.genome.regulation and np.any(W_r != 0.0):
            raise CheckpointError(
                f"{where}: W_r has {int(np.count_nonzero(W_r))} regulatory connections but this "
                "config has genome.regulation: false (the no-regulation arm); use a config "
                "with regulation"
            )

    def evolvable(self, genome: GrnGenome) -> dict[str, tuple[np.ndarray, float]]:
        """The entries an optimiser over R^N moves (:class:`VectorSearchable`).

        Every block with a non-zero mutation probability and std (``mutation.block_p``,
        ``block_sigma``), at that std; of W_r only the present connections (its sparsity
        pattern stays the genome's; none with ``genome.regulation: false``); of W_s not the rows
        that always read zeros (the visual rows when ``sensors.blind``, the proprioceptive rows
        when ``sensors.proprio`` is false), and no P when blind.
        """
        m, n_v = self.config.mutation, self.sensors.n_visual
        out: dict[str, tuple[np.ndarray, float]] = {}
        arrays = genome.arrays()
        for name in GENOME_BLOCKS:
            if m.p_of(name) <= 0.0 or m.sigma_of(name) <= 0.0:
                continue
            if name == "W_r" and not self.config.genome.regulation:
                continue
            a = np.asarray(arrays[name])
            mask = np.ones(a.shape, dtype=bool)
            if name == "W_r":
                mask = a != 0.0
            elif name == "W_s":
                mask[:n_v] = not self.sensors.blind
                mask[n_v:] = bool(self.sensors.proprio)
            elif name == "P" and self.sensors.blind:
                continue
            out[name] = (mask, m.sigma_of(name))
        return out

    def repair(self, genome: GrnGenome) -> GrnGenome:
        """Clip theta, delta and alpha to their bounds (in place)."""
        return clip_to_bounds(genome, self.config)

    def expression_noise(self, rngs: Sequence[np.random.Generator], n_genes: int) -> np.ndarray:
        """Expression noise eta (len(rngs), n) for one more Euler substep, per slot generator."""
        eta = np.zeros((len(rngs), n_genes))
        if self.dyn.noise_std > 0:
            for b, rng in enumerate(rngs):
                eta[b] = rng.normal(0.0, self.dyn.noise_std, n_genes)
        return eta

    def start_expression(self, x: np.ndarray) -> np.ndarray:
        """The expression a control step starts from: the carried-over ``x`` (thesis), or
        x(0) everywhere with ``dynamics.restart`` (SPEC §2.1 dynamics unchanged; only their
        initial condition).

        Restarting makes the read-out a function of the current input alone, developed for
        ``substeps`` × ``dt``: with the proprioceptive inputs off (``sensors.proprio``), it was
        the change that let mutation-only evolution find an accurate reaching map in the
        kinematic reach surrogate (12 genomes × 10 episodes × 15 generations, 10 seeds: median
        final distance 0.65 cm mean over seeds, against 3.3 cm with neither change;
        docs/results/grn.md, "Why the search stalled").
        """
        return np.full_like(x, self.dyn.x0) if self.dyn.restart else x

    def reset_state(self, genomes: Sequence[GrnGenome]) -> GrnState:
        for g in genomes:
            g.check(self.n_sensors, self.n_actions, self.sensors.n_visual)
        batch = stack_genomes(genomes)
        x = np.full((len(genomes), batch.theta.shape[-1]), self.dyn.x0)
        return GrnState(batch, x)

    def sense(
        self,
        P: np.ndarray,
        n_genes: int,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Sensor vectors (len(idx), n_s) and expression noise eta (len(idx), n) for one step.

        Per slot, the visual noise (noisy episodes only) is drawn before eta, from the slot's
        own generator, so results do not depend on batching. With ``sensors.proprio`` false the
        proprioceptive part of s is zeros (the front-end has already used the gripper pose).
        """
        n_visual = self.sensors.n_visual
        if not self.sensors.proprio:  # the GRN does not read them (sensors.proprio: false)
            proprio = np.zeros_like(proprio)
        vis_noise = np.zeros((len(rngs), n_visual))
        eta = np.zeros((len(rngs), n_genes))
        noise_std = self.config.evaluation.visual_noise
        for b, rng in enumerate(rngs):
            if noisy[b] and not self.sensors.blind:
                vis_noise[b] = rng.normal(0.0, noise_std, n_visual)
            if self.dyn.noise_std > 0:
                eta[b] = rng.normal(0.0, self.dyn.noise_std, n_genes)
        s = sensor_vector(features, P, proprio, vis_noise, blind=self.sensors.blind)
        return s, eta

    def step(
        self,
        state: GrnState,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        g = state.genome
        n_genes = state.x.shape[1]
        s, eta = self.sense(g.P[idx], n_genes, features, proprio, rngs, noisy)
        W_s, W_r, theta, delta, alpha = (
            g.W_s[idx],
            g.W_r[idx],
            g.theta[idx],
            g.delta[idx],
            g.alpha[idx],
        )
        x = self.start_expression(state.x[idx])
        # SPEC §2.1 time scale: ``substeps`` Euler updates on the same input before the read-out;
        # the first uses the eta drawn by sense (so substeps = 1 is the thesis step bit for bit).
        for k in range(self.dyn.substeps):
            if k:
                eta = self.expression_noise(rngs, n_genes)
            x = expression_step(x, s, W_s, W_r, theta, delta, alpha, self.dyn.dt, eta)
        state.x[idx] = x
        return motor_output(x, g.W_m[idx])


class ZeroPolicy:
    """All-zero actions (SPEC §2.5 trivial policy); the base of every constant-action policy."""

    uses_encoder = False

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        self.n_actions = int(n_actions)

    def constant_action(self) -> np.ndarray:
        """The action sent on every step: zeros."""
        return np.zeros(self.n_actions)

    def reset_state(self, genomes: Sequence[Any]) -> None:
        return None

    def step(
        self,
        state: Any,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        return np.tile(self.constant_action(), (len(idx), 1))


class RandomPolicy(ZeroPolicy):
    """Uniform random actions in [-1, 1] (SPEC §2.5 trivial policy), from the per-episode rngs."""

    def step(
        self,
        state: Any,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        return np.stack([rng.uniform(-1.0, 1.0, self.n_actions) for rng in rngs])


class TurnPolicy(ZeroPolicy):
    """One constant action: -1 on the last action dimension, 0 on the others (SPEC §2.5).

    On the Kuka port with the height hack that is dx = dy = 0, d-angle = -1 on every step: the
    arm descends by itself and only the gripper turns. SPEC §2.5 reports that this open-loop
    action grasps 59 % of episodes in the original environment, so it is the bar a controller
    that claims to use vision must clear, not the all-zero policy.
    """

    def constant_action(self) -> np.ndarray:
        """Zeros, and -1 on the last action dimension (the Kuka port's d-angle)."""
        a = np.zeros(self.n_actions)
        a[-1] = -1.0
        return a


Factory = Callable[[Any, int], Any]
"""What builds a controller or a reference policy: ``factory(config, n_actions)``. A class or a
module-level function, so that worker processes receive it pickled by reference (they import
its module themselves)."""

BASELINES: dict[str, Factory] = {
    "zero": ZeroPolicy,
    "random": RandomPolicy,
    "turn": TurnPolicy,
}
"""The reference policies measured beside every result (SPEC §2.5): all-zero, uniform random,
the constant "turn the gripper" action (last action dimension -1), and whatever the baselines
package registers with :func:`register_baseline` when it is imported (the scripted image-only
pipeline, ``scripted``: blob nearest the gripper on the first frame, move over it, turn; and
``scripted_memory``, the same remembering its target when the camera goes dark). This module
never imports the baselines package: the dependency points from the baselines to the method."""


def register_baseline(name: str, factory: Factory) -> None:
    """Register a reference policy measured beside every GRN result (a key of BASELINES)."""
    BASELINES[name] = factory


_REGISTRY: dict[str, Factory] = {
    "plain": PlainGrnController,
    "zero": ZeroPolicy,
    "random": RandomPolicy,
}
"""Controller kinds by name. The package's other kinds register when :mod:`evodevo.grn` is
imported (``neuromodulated``, ``open_loop``, ``linear``, ``mlp``), the Kuka baselines' policies
when :mod:`evodevo.baselines` is (``sb3``, ``neat``, ``recurrent_ppo``)."""


def register_controller(name: str, factory: Factory) -> None:
    """Register a controller kind: ``factory(config, n_actions)`` (a class or a module-level
    function, so that worker processes can receive it)."""
    if isinstance(factory, str):
        raise ConfigError(
            f"register_controller({name!r}, {factory!r}): give the class itself (import it), "
            "not its module path"
        )
    _REGISTRY[name] = factory


def controller_names() -> list[str]:
    """Registered controller names."""
    return sorted(_REGISTRY)


def check_controller(config: GrnConfig) -> None:
    """Refuse a ``config.controller`` that is neither a registered kind nor ``"module:attr"``,
    with one error naming it (before any work starts)."""
    policy_factory(config)


def _unknown(name: str) -> ConfigError:
    return ConfigError(
        f"controller={name!r} is not known; choose one of {controller_names()} or give "
        "'module:attr' (the Kuka baselines' controllers sb3, neat and recurrent_ppo register "
        "when evodevo.baselines is imported)"
    )


def _import_path(target: str) -> Factory:
    check_import(target, "controller")
    module, _, attr = target.partition(":")
    try:
        return getattr(importlib.import_module(module), attr)  # type: ignore[no-any-return]
    except (ImportError, AttributeError) as exc:
        raise EvodevoError(f"controller {target!r} cannot be imported ({exc})") from None


def policy_factory(config: GrnConfig, baseline: str | None = None) -> Factory:
    """The factory of ``config.controller`` (a registered name or a user's ``"module:attr"``
    path, imported here), or of the reference policy ``baseline`` (a key of BASELINES)."""
    if baseline is not None:
        if baseline not in BASELINES:
            raise EvodevoError(f"unknown baseline {baseline!r}; choose one of {sorted(BASELINES)}")
        return BASELINES[baseline]
    name = config.controller
    if name in _REGISTRY:
        return _REGISTRY[name]
    if ":" in name:
        return _import_path(name)
    raise _unknown(name)


def make_controller(config: GrnConfig, n_actions: int) -> Any:
    """Build ``config.controller`` (a registered name or ``"module:attr"``) for ``n_actions``."""
    return policy_factory(config)(config, n_actions)


def make_policy(config: GrnConfig, n_actions: int, baseline: str | None = None) -> Any:
    """The controller of ``config``, or the trivial policy ``baseline`` (a key of BASELINES)."""
    return policy_factory(config, baseline)(config, n_actions)


__all__ += ["make_policy", "register_baseline", "policy_factory", "Factory"]
