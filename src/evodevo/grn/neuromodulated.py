"""The neuromodulated GRN (SPEC §5, thesis Section 5.4.2, Eq. 5.1–5.4): controller kind ``neuromodulated``.

The state of one controller is 50 gene expressions plus 4 modulator states (54-d). Each env step:

1. the sensor vector ``s`` and the expression noise are made exactly as for the plain GRN
   (:meth:`~evodevo.grn.controller.PlainGrnController.sense`);
2. the modulators move towards targets computed by four small evolved networks
   (:func:`~evodevo.grn.modulation.target_network`), Eq. 3.1 with the Chapter 3 rates, in the
   dependency order of Chapter 3: DA reads ``[s, tanh(reward_scale · reward so far)]`` and NE
   ``[s, novelty]`` first; then 5HT reads ``[s, m_DA]`` and ACh ``[s, m_NE]`` with the DA and NE
   states just updated. Novelty starts at 1 each episode and decays ``n ← 0.995 n`` per step
   (Eq. 3.5); the modulators start at 0.5 each episode;
3. decay, thresholds and regulatory weights are modulated (Eq. 5.2–5.4,
   :mod:`evodevo.grn.modulation`) and the plain expression step (Eq. 4.1–4.4,
   :func:`~evodevo.grn.dynamics.expression_step`) runs with them (Eq. 5.1);
4. the action is the plain motor output ``tanh(W_m^T x)``.

The genome is the plain genome (:class:`~evodevo.grn.genome.GrnGenome`, mutated by the plain
operators) plus the target networks and ``gamma = [gamma_DA, gamma_5HT, gamma_NE, gamma_ACh]``,
evolved within the bounds of ``config.neuromod``. With gamma = 0 the controller is the plain GRN
bit for bit (same actions, same expression, same random draws).

:func:`run_modulator_ablations` tests a run's best genome with each gamma set to 0 (and all of
them); :func:`record_modulator_trace` saves the modulator and expression traces of one episode.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> ctrl = NeuromodGrnController(GrnConfig(controller="neuromodulated"), n_actions=3)
>>> g = ctrl.init_genome(np.random.default_rng(0))
>>> g.U1.shape, g.gamma.shape
((4, 9, 8), (4,))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError, EvodevoError
from evodevo.grn.ablations import ablation_row, ablations_markdown, ablations_stem, add_holm
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.dynamics import expression_step, motor_output
from evodevo.grn.evaluation import load_run, test_episodes
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.genome import (
    GrnGenome,
    check_frontend,
    init_genome,
    load_arrays,
    save_arrays,
    stack_genomes,
)
from evodevo.grn.modulation import (
    ACH,
    DA,
    MODULATORS,
    NE,
    SHT,
    modulated_decay,
    modulated_regulation,
    modulated_threshold,
    modulator_update,
    target_network,
)
from evodevo.grn.mutation import mutate_genome
from evodevo.grn.recording import episode_meta, record_episode
from evodevo.runs import atomic_write_text, write_json

__all__ = [
    "NeuromodGrnGenome",
    "NeuromodState",
    "NeuromodGrnController",
    "clip_gamma",
    "MODULATOR_ABLATIONS",
    "run_modulator_ablations",
    "record_modulator_trace",
    "MODULATOR_TRACE_FILE",
]

_FIRST = np.array([DA, NE])
"""Modulators updated first (task signals: reward so far, novelty)."""
_SECOND = np.array([SHT, ACH])
"""Modulators updated second, reading the states of :data:`_FIRST` just updated."""
_EXTRA = ("U1", "c1", "U2", "c2", "gamma")
MODULATOR_TRACE_FILE = "modulator_trace.npz"


@dataclass
class NeuromodGrnGenome:
    """A plain GRN genome plus four modulator target networks and the four gains gamma.

    Attributes:
        base: the plain genome (W_s, W_r, W_m, theta, delta, alpha, P).
        U1: first-layer weights (4, n_sensors + 1, H), modulators in the order DA, 5HT, NE, ACh.
        c1: first-layer biases (4, H).
        U2: output weights (4, H).
        c2: output biases (4,).
        gamma: modulation strengths (4,) of Eq. 5.2–5.4.

    Every array may carry a leading batch axis (see :func:`stack`).
    """

    base: GrnGenome
    U1: np.ndarray
    c1: np.ndarray
    U2: np.ndarray
    c2: np.ndarray
    gamma: np.ndarray

    KIND = "grn_neuromodulated"

    @classmethod
    def names(cls) -> list[str]:
        """Array names in the ``.npz``: the plain genome's, then the modulator part."""
        return [*GrnGenome.names(), *_EXTRA]

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays by name (flat: the plain genome's names plus ``U1 c1 U2 c2 gamma``)."""
        return {**self.base.arrays(), **{k: getattr(self, k) for k in _EXTRA}}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> NeuromodGrnGenome:
        """Inverse of :meth:`arrays`."""
        missing = [n for n in cls.names() if n not in arrays]
        if missing:
            raise CheckpointError(f"neuromodulated genome lacks the arrays {missing}")
        base = GrnGenome(**{n: np.asarray(arrays[n]) for n in GrnGenome.names()})
        return cls(base, *(np.asarray(arrays[k]) for k in _EXTRA))

    def copy(self) -> NeuromodGrnGenome:
        """A deep copy."""
        return NeuromodGrnGenome.from_arrays({k: v.copy() for k, v in self.arrays().items()})

    def connections(self) -> int:
        """Present regulatory connections of the plain part."""
        return self.base.connections()

    def with_gamma(self, gamma: Sequence[float] | np.ndarray) -> NeuromodGrnGenome:
        """A copy with the given gamma (e.g. zeros: the plain GRN; one zero: an ablation)."""
        g = self.copy()
        g.gamma = np.asarray(gamma, dtype=np.float64).copy()
        return g

    def check(
        self,
        n_sensors: int | None = None,
        n_actions: int | None = None,
        n_visual: int | None = None,
        hidden: int | None = None,
        where: str = "genome",
    ) -> None:
        """Raise CheckpointError if shapes are inconsistent or differ from the given sizes."""
        self.base.check(n_sensors, n_actions, n_visual, where)
        d = self.base.W_s.shape[0] + 1
        h = hidden if hidden is not None else (self.c1.shape[-1] if self.c1.ndim == 2 else -1)
        expect = {"U1": (4, d, h), "c1": (4, h), "U2": (4, h), "c2": (4,), "gamma": (4,)}
        for name, shape in expect.items():
            arr = getattr(self, name)
            if tuple(arr.shape) != shape or h < 1:
                raise CheckpointError(
                    f"{where}: {name} has shape {tuple(arr.shape)}, expected {shape}; the "
                    "modulator networks do not match this controller (sensors or neuromod.hidden)"
                )
            if not np.all(np.isfinite(arr)):
                raise CheckpointError(f"{where}: {name} holds non-finite values")

    def save(self, path: str | Path, config: Mapping[str, Any] | None = None) -> None:
        """Write one ``.npz`` (same format as the plain genome, kind ``grn_neuromodulated``)."""
        save_arrays(path, self.KIND, self.arrays(), {"config": dict(config or {})})

    @classmethod
    def load(cls, path: str | Path) -> NeuromodGrnGenome:
        """Load a genome written by :meth:`save` (shapes are checked by the controller)."""
        arrays, _ = load_arrays(path, cls.KIND)
        try:
            return cls.from_arrays(arrays)
        except CheckpointError as exc:
            raise CheckpointError(f"{str(path)!r}: {exc}") from None


def stack(genomes: Sequence[NeuromodGrnGenome]) -> NeuromodGrnGenome:
    """Stack same-shaped genomes (leading batch axis on every array)."""
    base = stack_genomes([g.base for g in genomes])
    extra = [np.stack([getattr(g, k) for g in genomes]) for k in _EXTRA]
    return NeuromodGrnGenome(base, *extra)


def clip_gamma(gamma: np.ndarray, config: GrnConfig) -> np.ndarray:
    """Clip gamma (4,) to ``config.neuromod`` bounds, in place; returns it."""
    for i, (lo, hi) in enumerate(config.neuromod.gamma_bounds):
        gamma[i] = min(max(gamma[i], lo), hi)
    return gamma


@dataclass
class NeuromodState:
    """Batched runtime state: genomes, expression x (B, n), modulators m (B, 4), novelty and
    reward so far (B,)."""

    genome: NeuromodGrnGenome
    x: np.ndarray
    m: np.ndarray
    novelty: np.ndarray
    reward: np.ndarray


class NeuromodGrnController(PlainGrnController):
    """Controller kind ``neuromodulated`` (see the module docstring).

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig` (its ``neuromod`` section).
        n_actions: action dimensions of the environment.
    """

    name = "neuromodulated"

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        super().__init__(config, n_actions)
        self.mod = config.neuromod
        self.tau = np.asarray(self.mod.tau, dtype=np.float64)

    # -- genome -------------------------------------------------------------------------------
    def init_genome(self, rng: np.random.Generator) -> NeuromodGrnGenome:  # type: ignore[override]  # a kind's genome type is its own
        """The plain genome drawn first (SPEC §2.3), then the modulator networks and gamma."""
        base = init_genome(self.config, self.n_actions, rng)
        return self.attach(base, rng)

    def attach(
        self, base: GrnGenome, rng: np.random.Generator, gamma: np.ndarray | None = None
    ) -> NeuromodGrnGenome:
        """Give a plain genome random modulator networks and ``gamma`` (default: drawn).

        ``attach(g, rng, gamma=np.zeros(4))`` behaves exactly like the plain genome ``g``.
        """
        mc, d = self.mod, self.n_sensors + 1
        U1 = rng.normal(0.0, mc.net_init_std, (4, d, mc.hidden))
        c1 = rng.normal(0.0, mc.net_init_std, (4, mc.hidden))
        U2 = rng.normal(0.0, mc.net_init_std, (4, mc.hidden))
        if gamma is None:
            gamma = clip_gamma(rng.normal(0.0, mc.gamma_init_std, 4), self.config)
        return NeuromodGrnGenome(
            base.copy(),
            U1,
            c1,
            U2,
            np.zeros(4),
            np.asarray(gamma, dtype=np.float64).copy(),
        )

    def mutate(self, genome: NeuromodGrnGenome, rng: np.random.Generator) -> NeuromodGrnGenome:  # type: ignore[override]  # a kind's genome type is its own
        """Plain mutations of the base (SPEC §2.4), then, each decided independently: weight
        noise N(0, sigma²) per target network with ``p_net``, and gamma noise with ``p_gamma``
        (clipped to the bounds)."""
        mc = self.mod
        child = genome.copy()
        child.base = mutate_genome(genome.base, self.config, rng)
        for k in range(4):
            if rng.random() < mc.p_net:
                child.U1[k] += rng.normal(0.0, mc.sigma, child.U1[k].shape)
                child.c1[k] += rng.normal(0.0, mc.sigma, child.c1[k].shape)
                child.U2[k] += rng.normal(0.0, mc.sigma, child.U2[k].shape)
                child.c2[k] += rng.normal(0.0, mc.sigma)
        if rng.random() < mc.p_gamma:
            child.gamma += rng.normal(0.0, mc.sigma, 4)
        clip_gamma(child.gamma, self.config)
        return child

    def _check(self, genome: NeuromodGrnGenome, where: str = "genome") -> None:
        if not isinstance(genome, NeuromodGrnGenome):
            raise EvodevoError(
                f"{where}: the neuromodulated controller needs a NeuromodGrnGenome, got "
                f"{type(genome).__name__}; wrap a plain genome with NeuromodGrnController.attach"
            )
        genome.check(self.n_sensors, self.n_actions, self.sensors.n_visual, self.mod.hidden, where)

    def load_genome(self, path: str | Path) -> NeuromodGrnGenome:  # type: ignore[override]  # a kind's genome type is its own
        check_frontend(load_arrays(path, NeuromodGrnGenome.KIND)[1], self.sensors.encoder, path)
        g = NeuromodGrnGenome.load(path)
        self._check(g, str(path))
        return g

    def connections(self, genome: NeuromodGrnGenome) -> int:  # type: ignore[override]  # a kind's genome type is its own
        return genome.connections()

    def genome_from_arrays(self, arrays: dict[str, np.ndarray]) -> NeuromodGrnGenome:  # type: ignore[override]  # a kind's genome type is its own
        g = NeuromodGrnGenome.from_arrays(arrays)
        self._check(g)
        return g

    def evolvable(self, genome: NeuromodGrnGenome) -> dict[str, tuple[np.ndarray, float]]:  # type: ignore[override]  # a kind's genome type is its own
        """The plain blocks as for the plain GRN, and every entry of the modulator networks
        and gamma at the scale ``neuromod.sigma`` (CMA-ES)."""
        out = super().evolvable(genome.base)
        for name in _EXTRA:
            a = getattr(genome, name)
            out[name] = (np.ones(a.shape, dtype=bool), self.mod.sigma)
        return out

    def repair(self, genome: NeuromodGrnGenome) -> NeuromodGrnGenome:  # type: ignore[override]  # a kind's genome type is its own
        """Clip theta, delta, alpha and gamma to their bounds (in place)."""
        super().repair(genome.base)
        clip_gamma(genome.gamma, self.config)
        return genome

    # -- runtime ------------------------------------------------------------------------------
    def reset_state(self, genomes: Sequence[NeuromodGrnGenome]) -> NeuromodState:  # type: ignore[override]
        for g in genomes:
            self._check(g)
        batch = stack(genomes)
        n_b = len(genomes)
        return NeuromodState(
            batch,
            np.full((n_b, batch.base.theta.shape[-1]), self.dyn.x0),
            np.full((n_b, 4), self.mod.m0),
            np.ones(n_b),
            np.zeros(n_b),
        )

    def observe_reward(self, state: NeuromodState, idx: np.ndarray, rewards: np.ndarray) -> None:
        """Add the rewards of the last env step of slots ``idx`` to their reward so far."""
        state.reward[idx] += rewards

    def _targets(
        self,
        g: NeuromodGrnGenome,
        idx: np.ndarray,
        mods: np.ndarray,
        s: np.ndarray,
        sig: np.ndarray,
    ) -> np.ndarray:
        """Targets (len(idx), len(mods)) of modulators ``mods`` from ``[s, sig[:, j]]``."""
        v = np.concatenate(
            [np.broadcast_to(s[:, None, :], (len(idx), len(mods), s.shape[1])), sig[:, :, None]],
            axis=2,
        )
        sub = np.ix_(idx, mods)
        return target_network(v, g.U1[sub], g.c1[sub], g.U2[sub], g.c2[sub])

    def update_modulators(self, state: NeuromodState, idx: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Eq. 3.1 for the four modulators of slots ``idx`` in the Chapter 3 order; returns m."""
        g, mc = state.genome, self.mod
        m = state.m[idx].copy()
        task = np.stack([np.tanh(mc.reward_scale * state.reward[idx]), state.novelty[idx]], 1)
        t1 = self._targets(g, idx, _FIRST, s, task)
        m[:, _FIRST] = modulator_update(m[:, _FIRST], t1, self.tau[_FIRST])
        t2 = self._targets(g, idx, _SECOND, s, m[:, _FIRST])  # 5HT reads DA, ACh reads NE
        m[:, _SECOND] = modulator_update(m[:, _SECOND], t2, self.tau[_SECOND])
        state.m[idx] = m
        return m

    def step(  # type: ignore[override]
        self,
        state: NeuromodState,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        g, base = state.genome, state.genome.base
        s, eta = self.sense(base.P[idx], state.x.shape[1], features, proprio, rngs, noisy)
        m = self.update_modulators(state, idx, s)
        gam = g.gamma[idx]
        W_r = modulated_regulation(base.W_r[idx], m[:, NE], m[:, ACH], gam[:, NE], gam[:, ACH])
        theta = modulated_threshold(base.theta[idx], m[:, SHT], gam[:, SHT])
        delta = modulated_decay(base.delta[idx], m[:, DA], gam[:, DA])
        x = self.start_expression(state.x[idx])
        # SPEC §2.1 substeps: the modulators move once per control step (Eq. 3.1's time scale),
        # the expression ``substeps`` times under them (1 = the plain Eq. 5.x step).
        for k in range(self.dyn.substeps):
            if k:
                eta = self.expression_noise(rngs, state.x.shape[1])
            x = expression_step(
                x, s, base.W_s[idx], W_r, theta, delta, base.alpha[idx], self.dyn.dt, eta
            )
        state.x[idx] = x
        state.novelty[idx] *= self.mod.novelty_decay  # Eq. 3.5, after the step
        return motor_output(x, base.W_m[idx])


# -- evaluation helpers -------------------------------------------------------------------------

MODULATOR_ABLATIONS: dict[str, tuple[int, ...]] = {
    "no_DA": (DA,),
    "no_5HT": (SHT,),
    "no_NE": (NE,),
    "no_ACh": (ACH,),
    "no_modulation": (DA, SHT, NE, ACH),
}
"""Ablation name → modulators whose gamma is set to 0 (all four: the plain GRN dynamics)."""


def _loaded_neuromod(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Any:
    loaded = load_run(path, overrides)
    if not isinstance(loaded.genome, NeuromodGrnGenome):
        raise EvodevoError(
            f"modulator ablations need a neuromodulated run; this run's controller is "
            f"{loaded.kind!r}"
        )
    return loaded


def run_modulator_ablations(
    path: str | Path,
    episodes: int | None = None,
    objects: str = "test",
    seed: int | None = None,
    workers: int = 1,
    overrides: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Test the best genome intact and with each gamma set to 0, on the same test episodes.

    Writes ``modulator_ablations.{csv,json,md}`` into the run directory (change vs intact with a
    Newcombe 95 % interval, Fisher exact p; the layout of :mod:`evodevo.grn.ablations`);
    ``overrides`` change the test as in :func:`evodevo.grn.ablations.run_ablations`.
    """
    if objects not in ("test", "train"):
        raise EvodevoError(f"objects {objects!r} is not accepted; choose test or train")
    loaded = _loaded_neuromod(path, overrides)
    cfg = loaded.config
    n = int(episodes if episodes is not None else cfg.evaluation.test_episodes)
    if n < 1:
        raise EvodevoError(f"episodes {n} must be at least 1")
    test_seed = int(seed if seed is not None else cfg.evaluation.test_seed)
    eps = test_episodes(test_seed, n, objects == "test")
    genome: NeuromodGrnGenome = loaded.genome
    variants = [genome]
    for mods in MODULATOR_ABLATIONS.values():
        gamma = genome.gamma.copy()
        gamma[list(mods)] = 0.0
        variants.append(genome.with_gamma(gamma))
    with Evaluator(cfg, loaded.encoder, workers=workers) as ev:
        res = ev.evaluate(variants, eps)
    k = res.success.sum(axis=1).astype(int)
    s0 = res.success[0]
    rows = [ablation_row("intact", int(k[0]), n, int(k[0]), n, s0, s0)]
    for i, name in enumerate(MODULATOR_ABLATIONS, start=1):
        rows.append(ablation_row(name, int(k[i]), n, int(k[0]), n, res.success[i], s0))
    add_holm(rows)
    for i, row in enumerate(rows):
        row["mean_reward"] = float(res.reward[i].mean())
    rows[0]["gamma"] = [float(v) for v in genome.gamma]
    run = loaded.run
    stem = ablations_stem(overrides, "modulator_ablations")
    run.write_csv(f"{stem}.csv", [{k: v for k, v in r.items() if k != "gamma"} for r in rows])
    meta: dict[str, Any] = {"objects": objects, "test_seed": test_seed, "gamma": rows[0]["gamma"]}
    if overrides:
        meta["overrides"] = dict(overrides)
    write_json(run / f"{stem}.json", {**meta, "rows": rows})
    md = ablations_markdown(rows, objects, test_seed).replace(
        "Ablations of the best genome", "Modulator ablations (gamma_m = 0) of the best genome"
    )
    atomic_write_text(run / f"{stem}.md", md)
    return rows


def record_modulator_trace(path: str | Path, index: int = 0, objects: str = "test") -> Path:
    """Run test episode ``index`` with the best genome; save ``modulator_trace.npz``.

    The file holds the modulator states ``m`` (T, 4), the expression ``x`` (T, n) and the
    actions (T, A) after every step, for :func:`evodevo.grn.figures.plot_modulator_trace`.
    """
    loaded = _loaded_neuromod(path)
    ep, res = record_episode(loaded, index, objects)
    out = loaded.run / MODULATOR_TRACE_FILE
    save_arrays(
        out,
        "grn_modulator_trace",
        {
            "m": np.stack([a[0] for a in res["m"]]),
            "x": np.stack([a[0] for a in res["x"]]),
            "actions": np.stack([a[0] for a in res["actions"]]),
        },
        {
            **episode_meta(ep, res, objects, index),
            "gamma": [float(v) for v in loaded.genome.gamma],
            "modulators": list(MODULATORS),
        },
    )
    return out
