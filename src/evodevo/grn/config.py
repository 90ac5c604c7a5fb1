"""Typed configuration of the GRN method (SPEC §2; every constant of §2 is a default here).

One :class:`GrnConfig` per run, in sections: ``dynamics`` (§2.1), ``sensors`` (§2.2),
``genome`` (§2.3 initialisation and bounds), ``mutation`` (§2.4), ``evolution`` (§2.4),
``evaluation`` (§2.4 training protocol and §2.5 test), ``env`` and ``open_loop`` (§2.5 control),
``cmaes`` (the CMA-ES optimiser) and ``feedforward`` (the evolved linear and MLP policies).
Unknown keys and bad values raise :class:`~evodevo.errors.ConfigError` naming the key.

>>> cfg = GrnConfig()
>>> cfg.dynamics.n_genes, cfg.evolution.population, cfg.evolution.elites
(50, 12, 3)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from evodevo.config import doc
from evodevo.errors import ConfigError
from evodevo.seed_split import TEST_SEED, VALIDATION_SEED, require_validation

DISTANCE_AT = ("end", "grasp")
"""Values of ``evaluation.distance_at``: when the shaped training fitness reads the distance."""
WEIGHT_BLOCKS = ("W_s", "W_r", "W_m", "P")
"""The matrices of a plain GRN genome that weight mutation perturbs (SPEC §2.3, §2.4)."""
PARAMETER_BLOCKS = ("theta", "delta", "alpha")
"""The vectors of a plain GRN genome that parameter mutation perturbs (SPEC §2.3, §2.4)."""
GENOME_BLOCKS = WEIGHT_BLOCKS + PARAMETER_BLOCKS
"""Every block that ``mutation.block_sigma`` and ``mutation.block_p`` may name."""
KEEP = ("last", "record", "validated")
"""Values of ``evolution.keep``: which genome an evolution returns (:mod:`evodevo.grn.return_rule`)."""
VALIDATION_SCORES = ("successes", "return")
"""Values of ``evaluation.validation_score``: what ``evolution.keep: validated`` ranks by."""
OPTIMIZERS = ("ga", "cmaes")
"""Values of ``evolution.optimizer``: the thesis' genetic algorithm, or CMA-ES."""
DISTANCE_TO = ("nearest", "target")
"""Values of ``evaluation.distance_to``: what the shaped training fitness measures the gripper's
distance to (the nearest object, read from the simulator; or the target the front-end saw)."""

__all__ = [
    "DynamicsConfig",
    "SensorConfig",
    "GenomeInitConfig",
    "MutationConfig",
    "EvolutionConfig",
    "EvaluationConfig",
    "EnvConfig",
    "OpenLoopConfig",
    "NeuromodConfig",
    "CmaesConfig",
    "FeedForwardConfig",
    "GrnConfig",
    "DISTANCE_AT",
    "DISTANCE_TO",
    "KEEP",
    "OPTIMIZERS",
    "VALIDATION_SCORES",
    "FRONTEND_FEATURES",
    "GENOME_BLOCKS",
    "PARAMETER_BLOCKS",
    "WEIGHT_BLOCKS",
]


def _check_range(key: str, value: float, lo: float, hi: float | None = None) -> None:
    if value < lo or (hi is not None and value > hi):
        upper = f", {hi}]" if hi is not None else ", inf)"
        raise ConfigError(f"{key}={value!r} must lie in [{lo}{upper}")


def _check_bounds(key: str, pair: tuple[float, float]) -> None:
    lo, hi = pair
    if not lo < hi:
        raise ConfigError(f"{key}={list(pair)!r} must be [low, high] with low < high")


@dataclass
class DynamicsConfig:
    """Gene-expression dynamics, Eq. 4.1–4.4 (SPEC §2.1)."""

    n_genes: int = doc(50, "number of genes n")
    x0: float = doc(0.3, "initial expression x(0) of every gene")
    dt: float = doc(0.05, "Euler time step of the expression update")
    noise_std: float = doc(0.01, "std of the expression noise eta_i added each Euler step")
    substeps: int = doc(
        1, "Euler updates of the expression per control step (thesis: 1; SPEC §2.1 time scale)"
    )
    restart: bool = doc(
        False,
        "develop the expression afresh from x0 on every control step (no memory between control "
        "steps; thesis: false, x carries over)",
    )

    def validate(self) -> None:
        _check_range("n_genes", self.n_genes, 1)
        _check_range("x0", self.x0, 0.0, 1.0)
        if self.dt <= 0:
            raise ConfigError(f"dt={self.dt!r} must be positive")
        _check_range("noise_std", self.noise_std, 0.0)
        _check_range("substeps", self.substeps, 1)


#: Features per frame of each visual front-end (``sensors.encoder``; SPEC §2.2): the thesis'
#: CNN (32 channels x 2 x 2) and the blob localiser (dx, dy, size, found).
FRONTEND_FEATURES: dict[str, int] = {"cnn": 128, "blob": 4}


@dataclass
class SensorConfig:
    """The sensor vector s = [visual(4), proprio(4)] (SPEC §2.2)."""

    encoder: str = doc(
        "cnn",
        "visual front-end: cnn (the thesis' fixed random CNN) | blob (object localiser from the "
        "image: target dx, dy relative to the gripper, size, found)",
    )
    n_visual: int = doc(
        4, "visual features after the evolved projection P (feature_dim -> n_visual)"
    )
    n_proprio: int = doc(4, "proprioceptive values read from info['proprio']")
    feature_dim: int = doc(128, "front-end output size: 128 for cnn (32 x 2 x 2), 4 for blob")
    blind: bool = doc(False, "replace the visual features by zeros (the blind-GRN control, §2.5)")
    proprio: bool = doc(
        True,
        "the GRN reads the proprioceptive values (false: they are zeros in s; a front-end may "
        "still use the gripper pose, as blob does for dx, dy)",
    )
    vector_range: tuple[float, float] = doc(
        (-1.0, 1.0),
        "vector-observation envs: the Box bounds are mapped linearly onto this range "
        "(n_visual 0, n_proprio = observation size)",
    )

    def validate(self) -> None:
        _check_range("n_visual", self.n_visual, 0)
        _check_range("n_proprio", self.n_proprio, 0)
        _check_bounds("vector_range", self.vector_range)
        if self.encoder not in FRONTEND_FEATURES:
            raise ConfigError(
                f"sensors.encoder={self.encoder!r} is not a front-end; choose one of "
                f"{tuple(FRONTEND_FEATURES)}"
            )
        want = FRONTEND_FEATURES[self.encoder]
        if self.feature_dim != want:
            raise ConfigError(
                f"feature_dim={self.feature_dim} must be {want} for sensors.encoder="
                f"{self.encoder!r} (SPEC §2.2)"
            )


@dataclass
class GenomeInitConfig:
    """Genome initialisation distributions and parameter bounds (SPEC §2.1, §2.3)."""

    ws_std: float = doc(0.3, "W_s ~ N(0, ws_std^2)")
    wr_std: float = doc(0.1, "W_r ~ N(0, wr_std^2) on its present entries")
    wr_density: float = doc(0.2, "probability that a regulatory entry is present at init")
    wm_std: float = doc(0.2, "W_m ~ N(0, wm_std^2)")
    p_std: float = doc(1.0, "P ~ N(0, p_std^2) (encoder output has unit L2 norm)")
    p_init: str = doc(
        "normal",
        "normal: P ~ N(0, p_std^2); identity: P = I (needs feature_dim == n_visual, e.g. blob)",
    )
    theta_init: tuple[float, float] = doc((0.2, 0.8), "theta ~ U(low, high) at init")
    delta_init: tuple[float, float] = doc((0.1, 0.9), "delta ~ U(low, high) at init")
    alpha_init: tuple[float, float] = doc((0.5, 2.0), "alpha ~ U(low, high) at init")
    theta_bounds: tuple[float, float] = doc((0.1, 1.0), "bounds of the thresholds theta")
    delta_bounds: tuple[float, float] = doc((0.05, 1.0), "bounds of the decay rates delta")
    alpha_bounds: tuple[float, float] = doc((0.1, 3.0), "bounds of the interaction strengths")
    regulation: bool = doc(
        True,
        "false: the no-regulation arm, W_r = 0 from initialisation on and never mutated (no "
        "structural or W_r weight mutation; no W_r coordinates for CMA-ES), in evolution and test",
    )

    def validate(self) -> None:
        for key in ("ws_std", "wr_std", "wm_std", "p_std"):
            _check_range(key, getattr(self, key), 0.0)
        _check_range("wr_density", self.wr_density, 0.0, 1.0)
        if self.p_init not in ("normal", "identity"):
            raise ConfigError(f"p_init={self.p_init!r} must be normal or identity")
        for name in ("theta", "delta", "alpha"):
            init = getattr(self, f"{name}_init")
            bounds = getattr(self, f"{name}_bounds")
            _check_bounds(f"{name}_init", init)
            _check_bounds(f"{name}_bounds", bounds)
            if init[0] < bounds[0] or init[1] > bounds[1]:
                raise ConfigError(
                    f"{name}_init={list(init)} must lie inside {name}_bounds={list(bounds)}"
                )


@dataclass
class MutationConfig:
    """The three mutation kinds of SPEC §2.4, each decided independently."""

    p_struct: float = doc(0.1, "probability of toggling one random regulatory connection")
    p_weight: float = doc(0.2, "probability, per matrix (W_s, W_r, W_m, P), of weight noise")
    p_param: float = doc(0.2, "probability, per vector (theta, delta, alpha), of parameter noise")
    sigma: float = doc(0.1, "std of weight and parameter noise")
    struct_std: float = doc(0.1, "std of a newly added regulatory connection")
    dense_regulatory_noise: bool = doc(
        False,
        "add weight noise to every W_r entry (the thesis' density artefact) not only present ones",
    )
    block_sigma: dict[str, float] = doc(
        {},
        "noise std per block, overriding sigma for the blocks named (W_s, W_r, W_m, P, theta, "
        "delta, alpha); {} = sigma for every block (SPEC §2.4)",
    )
    block_p: dict[str, float] = doc(
        {},
        "noise probability per block, overriding p_weight (matrices) or p_param (vectors) for "
        "the blocks named; {} = the SPEC §2.4 probabilities",
    )

    def validate(self) -> None:
        for key in ("p_struct", "p_weight", "p_param"):
            _check_range(key, getattr(self, key), 0.0, 1.0)
        _check_range("sigma", self.sigma, 0.0)
        _check_range("struct_std", self.struct_std, 0.0)
        for section, hi in (("block_sigma", None), ("block_p", 1.0)):
            for block, value in getattr(self, section).items():
                if block not in GENOME_BLOCKS:
                    raise ConfigError(
                        f"mutation.{section} has unknown block {block!r}; "
                        f"use one of {list(GENOME_BLOCKS)}"
                    )
                if not isinstance(value, (int, float)) or isinstance(value, bool):
                    raise ConfigError(f"mutation.{section}.{block}={value!r} must be a number")
                _check_range(f"mutation.{section}.{block}", float(value), 0.0, hi)

    def sigma_of(self, block: str) -> float:
        """The noise std of one genome block (``block_sigma`` or ``sigma``)."""
        return float(self.block_sigma.get(block, self.sigma))

    def p_of(self, block: str) -> float:
        """The noise probability of one genome block (``block_p``, else p_weight / p_param)."""
        default = self.p_param if block in PARAMETER_BLOCKS else self.p_weight
        return float(self.block_p.get(block, default))


@dataclass
class EvolutionConfig:
    """The optimiser of Algorithm 3 (SPEC §2.4), or CMA-ES, and the loop both share."""

    optimizer: str = doc(
        "ga",
        "ga (Algorithm 3: elites and tournament-selected mutants, the thesis) or cmaes (CMA-ES "
        "on the genome as a vector, section cmaes; population is its lambda, elite_fraction and "
        "tournament and the mutation probabilities are not used)",
    )
    population: int = doc(12, "genomes per generation")
    generations: int = doc(15, "maximum number of generations")
    elite_fraction: float = doc(
        0.25, "fraction of the population passed on unchanged, floor(f·N): 3 of 12 (Algorithm 3)"
    )
    tournament: int = doc(3, "tournament size for picking the parents of the offspring")
    early_stop_success: float = doc(
        0.7, "training success of the best genome that triggers a retest"
    )
    retest_episodes: int = doc(20, "episodes of the early-stop retest (same clean/noisy protocol)")
    retest_success: float = doc(0.5, "retest success at or above which evolution stops")
    early_stop: bool = doc(True, "use the early stop at all")
    final_pick_episodes: int = doc(
        0,
        "re-select the final genome: once the budget is spent, score the last generation's "
        "elites on this many fresh clean training-object episodes (the same for each; success "
        "only, like the test) and keep the one with the most successes (the better rank on a "
        "tie). Paid from the training budget: elites x final_pick_episodes episodes "
        "(0 = the best of the last generation, the thesis)",
    )
    keep: str = doc(
        "last",
        "which genome the run returns: last (the best of the last generation, the thesis) or "
        "record (the champion by lifetime record: every genome's successes accumulate over all "
        "the generations it is evaluated in — elites are re-evaluated on fresh episodes each "
        "generation, identical genomes share one record — and after each generation the "
        "champion is replaced by any evaluated genome whose record has a higher 95 % Wilson "
        "lower bound than the champion's; no extra episodes, selection unchanged) or "
        "validated (every generation's best by training fitness is a candidate, scored on the "
        "same evaluation.validation_episodes clean training-object episodes from "
        "evaluation.validation_seed; the run returns the one with the most successes, the "
        "later on a tie; those episodes are counted apart from the training budget and "
        "selection is unchanged; evodevo.grn.return_rule)",
    )

    @property
    def elites(self) -> int:
        """Number of elites, floor(elite_fraction · population)."""
        return int(math.floor(self.elite_fraction * self.population + 1e-9))

    def validate(self) -> None:
        _check_range("population", self.population, 1)
        _check_range("generations", self.generations, 1)
        _check_range("elite_fraction", self.elite_fraction, 0.0, 1.0)
        _check_range("tournament", self.tournament, 1)
        _check_range("early_stop_success", self.early_stop_success, 0.0, 1.0)
        _check_range("retest_episodes", self.retest_episodes, 1)
        _check_range("retest_success", self.retest_success, 0.0, 1.0)
        _check_range("final_pick_episodes", self.final_pick_episodes, 0)
        if self.keep not in KEEP:
            raise ConfigError(f"evolution.keep must be one of {list(KEEP)}, got {self.keep!r}")
        if self.optimizer not in OPTIMIZERS:
            raise ConfigError(
                f"evolution.optimizer must be one of {list(OPTIMIZERS)}, got {self.optimizer!r}"
            )
        if self.optimizer == "cmaes" and self.population < 4:
            raise ConfigError(
                f"evolution.optimizer=cmaes needs population >= 4 (its lambda: mu = lambda / 2 "
                f"parents; cma's mirrored sampling fails with lambda = 2), got {self.population}"
            )
        if self.keep != "last" and self.final_pick_episodes > 0:
            raise ConfigError(
                f"evolution.keep={self.keep} and final_pick_episodes > 0 both choose the "
                "returned genome; set final_pick_episodes: 0 or keep: last"
            )
        if self.final_pick_episodes > 0 and self.elites < 2:
            raise ConfigError(
                f"final_pick_episodes={self.final_pick_episodes} needs at least 2 elites to "
                f"choose between, but elite_fraction={self.elite_fraction} x population="
                f"{self.population} gives {self.elites}; raise elite_fraction or set "
                "final_pick_episodes: 0"
            )


@dataclass
class EvaluationConfig:
    """Episodes per fitness evaluation (SPEC §2.4) and the test protocol (SPEC §2.5)."""

    episodes: int = doc(10, "episodes per genome per generation")
    noisy_fraction: float = doc(0.3, "fraction of those episodes with visual-feature noise")
    visual_noise: float = doc(
        0.03, "std of the noise added to the visual features of noisy episodes"
    )
    test_episodes: int = doc(40, "episodes of the test (fixed seeds)")
    test_seed: int = doc(
        TEST_SEED,
        "seed of the fixed test episodes (independent of the run seed); 1000000.. is the "
        "locked test range, 10000..999999 validation (SPEC §6)",
    )
    lockstep: int = doc(4, "episodes one worker steps together (one encoder batch per env step)")
    dedupe: bool = doc(
        True,
        "evaluate each distinct genome of a batch once and copy its results to its identical "
        "twins (same episodes and noise seeds, so the same outcomes; saves the episodes of "
        "unmutated clones)",
    )
    distance_weight: float = doc(
        0.0,
        "shaped training fitness: subtract weight x mean over episodes of the gripper-to-nearest-"
        "object distance at the episode's end (units of 5 cm, capped at 20 cm), read from the "
        "simulator during training only (0 = Eq. 4.6 alone, the thesis)",
    )
    distance_at: str = doc(
        "end",
        "when the shaped fitness reads that distance: end (after the episode, the automatic "
        "grasp's lift included) or grasp (when the automatic grasp starts: the reach alone)",
    )
    distance_to: str = doc(
        "nearest",
        "what that distance is measured to: nearest (the nearest object's base, read from the "
        "simulator) or target (the table point the blob front-end localised on the first frame: "
        "the robot's own estimate, no simulator pose; an episode without a target counts 20 cm)",
    )

    validation_episodes: int = doc(
        20,
        "evolution.keep / keep.rule validated: clean training-object episodes each candidate "
        "is scored on (the same for every candidate and learner; not training budget)",
    )
    validation_seed: int = doc(
        VALIDATION_SEED,
        "first seed of those episodes (episode i resets with derive(seed, i)); must lie in the "
        "validation range 10000..999999 (SPEC §6)",
    )
    validation_score: str = doc(
        "successes",
        "evolution.keep validated: what ranks the candidates, successes (the most validation "
        "successes, the later on a tie) or return (the highest mean validation return: for "
        "tasks where success is rare or undefined, e.g. Pendulum, on which every candidate "
        "ties at 0 successes and successes returns the last one)",
    )

    def validate(self) -> None:
        _check_range("episodes", self.episodes, 1)
        _check_range("noisy_fraction", self.noisy_fraction, 0.0, 1.0)
        _check_range("validation_episodes", self.validation_episodes, 1)
        require_validation(self.validation_seed, 1, "evaluation.validation_seed")
        if self.validation_score not in VALIDATION_SCORES:
            raise ConfigError(
                f"evaluation.validation_score={self.validation_score!r}: use successes or return"
            )
        _check_range("visual_noise", self.visual_noise, 0.0)
        _check_range("test_episodes", self.test_episodes, 1)
        _check_range("lockstep", self.lockstep, 1)
        _check_range("distance_weight", self.distance_weight, 0.0)
        if self.distance_at not in DISTANCE_AT:
            raise ConfigError(
                f"evaluation.distance_at must be one of {list(DISTANCE_AT)}, got "
                f"{self.distance_at!r}"
            )
        if self.distance_to not in DISTANCE_TO:
            raise ConfigError(
                f"evaluation.distance_to must be one of {list(DISTANCE_TO)}, got "
                f"{self.distance_to!r}"
            )


@dataclass
class EnvConfig:
    """The environment the controller drives (SPEC §2.6, §3)."""

    id: str = doc("evodevo/KukaDiverseObject-v0", "Gymnasium id (evodevo.envs is imported first)")
    kwargs: dict[str, Any] = doc({"max_steps": 8}, "keyword arguments of gymnasium.make")

    def validate(self) -> None:
        if not self.id:
            raise ConfigError("id must name a Gymnasium environment")
        if "test_objects" in self.kwargs:
            raise ConfigError(
                "kwargs.test_objects is chosen by the command (training on training objects, "
                "evaluate --objects test|train); remove it from the config"
            )


@dataclass
class OpenLoopConfig:
    """The best open-loop policy control of SPEC §2.5: a fixed action sequence, evolved."""

    steps: int = doc(8, "length of the action sequence (the env's max_steps; the last repeats)")
    init_low: float = doc(-1.0, "actions ~ U(init_low, init_high) at init")
    init_high: float = doc(1.0, "actions ~ U(init_low, init_high) at init")
    p_mutate: float = doc(
        1.0,
        "probability that an offspring's sequence is perturbed (one matrix: else it is a clone)",
    )
    sigma: float = doc(0.2, "std of the perturbation; actions are clipped to [-1, 1]")

    def validate(self) -> None:
        _check_range("steps", self.steps, 1)
        _check_bounds("init_low/init_high", (self.init_low, self.init_high))
        _check_range("p_mutate", self.p_mutate, 0.0, 1.0)
        _check_range("sigma", self.sigma, 0.0)


@dataclass
class CmaesConfig:
    """CMA-ES (``evolution.optimizer: cmaes``; ``grn/optimizers/cmaes.py``)."""

    sigma0: float = doc(
        1.0,
        "initial step size, in units of each block's mutation std (mutation.block_sigma or "
        "sigma; open_loop.sigma, feedforward.sigma, neuromod.sigma): 1 = the GA's mutation step "
        "on every coordinate",
    )
    diagonal: bool = doc(
        True,
        "separable CMA-ES: a diagonal covariance (linear time and memory; with ~1,000 GRN "
        "coordinates a full covariance learns ~2/N^2 per generation); false: full covariance",
    )

    def validate(self) -> None:
        if not self.sigma0 > 0:
            raise ConfigError(f"cmaes.sigma0={self.sigma0!r} must be positive")


@dataclass
class FeedForwardConfig:
    """The evolved feed-forward policies (``controller: linear | mlp``; ``grn/feedforward.py``)."""

    hidden: int = doc(16, "tanh units of the MLP's hidden layer (controller: mlp)")
    init_std: float = doc(0.5, "weights and biases ~ N(0, init_std^2) at init")
    p_mutate: float = doc(
        1.0, "GA: probability, per array (weights, biases), that an offspring's array is perturbed"
    )
    sigma: float = doc(0.1, "std of the GA's perturbation; CMA-ES's coordinate scale")

    def validate(self) -> None:
        _check_range("hidden", self.hidden, 1)
        _check_range("init_std", self.init_std, 0.0)
        _check_range("p_mutate", self.p_mutate, 0.0, 1.0)
        _check_range("sigma", self.sigma, 0.0)


@dataclass
class NeuromodConfig:
    """The neuromodulated GRN of SPEC §5 (thesis Eq. 5.1–5.4, modulators by Eq. 3.1 and 3.5).

    Modulators are always ordered DA, 5HT, NE, ACh.
    """

    tau: tuple[float, float, float, float] = doc(
        (0.1, 0.5, 0.05, 0.3), "Eq. 3.1 rates tau_m of DA, 5HT, NE, ACh (Chapter 3)"
    )
    m0: float = doc(0.5, "modulator states at the start of every episode")
    novelty_decay: float = doc(0.995, "novelty n <- novelty_decay * n per step, n = 1 at start")
    reward_scale: float = doc(1.0, "the DA network reads tanh(reward_scale * reward so far)")
    hidden: int = doc(8, "hidden ReLU units of each modulator target network")
    net_init_std: float = doc(0.5, "target-network weights and hidden biases ~ N(0, std^2) at init")
    gamma_init_std: float = doc(0.5, "gamma_m ~ N(0, std^2) at init, clipped to its bounds")
    gamma_da_bounds: tuple[float, float] = doc((-2.0, 2.0), "bounds of gamma_DA (Eq. 5.2)")
    gamma_5ht_bounds: tuple[float, float] = doc(
        (-1.5, 1.5), "bounds of gamma_5HT (Eq. 5.3); |gamma| < 2 keeps theta > 0"
    )
    gamma_ne_bounds: tuple[float, float] = doc((-1.0, 1.0), "bounds of gamma_NE (Eq. 5.4)")
    gamma_ach_bounds: tuple[float, float] = doc((-1.0, 1.0), "bounds of gamma_ACh (Eq. 5.4)")
    p_net: float = doc(0.2, "probability, per target network, of weight noise")
    p_gamma: float = doc(0.2, "probability of noise on the gamma vector")
    sigma: float = doc(0.1, "std of the target-network and gamma noise")

    @property
    def gamma_bounds(self) -> tuple[tuple[float, float], ...]:
        """Bounds of (gamma_DA, gamma_5HT, gamma_NE, gamma_ACh)."""
        return (
            self.gamma_da_bounds,
            self.gamma_5ht_bounds,
            self.gamma_ne_bounds,
            self.gamma_ach_bounds,
        )

    def validate(self) -> None:
        for i, t in enumerate(self.tau):
            _check_range(f"tau[{i}]", t, 0.0, 1.0)
        _check_range("m0", self.m0, 0.0, 1.0)
        _check_range("novelty_decay", self.novelty_decay, 0.0, 1.0)
        _check_range("reward_scale", self.reward_scale, 0.0)
        _check_range("hidden", self.hidden, 1)
        for key in ("net_init_std", "gamma_init_std", "sigma"):
            _check_range(key, getattr(self, key), 0.0)
        for key in ("p_net", "p_gamma"):
            _check_range(key, getattr(self, key), 0.0, 1.0)
        for name in ("da", "5ht", "ne", "ach"):
            bounds = getattr(self, f"gamma_{name}_bounds")
            if not bounds[0] <= bounds[1]:
                raise ConfigError(
                    f"gamma_{name}_bounds={list(bounds)!r} must be [low, high] with low <= high"
                )
        if max(abs(b) for b in self.gamma_5ht_bounds) >= 2.0:
            raise ConfigError(
                f"gamma_5ht_bounds={list(self.gamma_5ht_bounds)!r} must lie inside (-2, 2): "
                "Eq. 5.3 would make a threshold 0 or negative"
            )


@dataclass
class GrnConfig:
    """Everything a GRN run needs (SPEC §2). Saved resolved in ``config.json`` of the run."""

    seed: int = doc(0, "run seed: encoder weights, genomes, episode seeds, noise")
    controller: str = doc(
        "plain",
        "controller kind: plain | neuromodulated | open_loop | linear | mlp | a registered "
        "name | 'module:attr' of a ControllerKind",
    )
    dynamics: DynamicsConfig = field(default_factory=DynamicsConfig)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    genome: GenomeInitConfig = field(default_factory=GenomeInitConfig)
    mutation: MutationConfig = field(default_factory=MutationConfig)
    evolution: EvolutionConfig = field(default_factory=EvolutionConfig)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    env: EnvConfig = field(default_factory=EnvConfig)
    open_loop: OpenLoopConfig = field(default_factory=OpenLoopConfig)
    neuromod: NeuromodConfig = field(default_factory=NeuromodConfig)
    cmaes: CmaesConfig = field(default_factory=CmaesConfig)
    feedforward: FeedForwardConfig = field(default_factory=FeedForwardConfig)

    def validate(self) -> None:
        if not self.controller:
            raise ConfigError("controller must name a controller kind, e.g. plain")
        # the name itself is checked against the registered kinds where controllers are made
        # (evodevo.grn.controller.check_controller), before any work starts
        if self.genome.p_init == "identity" and self.sensors.feature_dim != self.sensors.n_visual:
            raise ConfigError(
                f"genome.p_init=identity needs sensors.feature_dim ({self.sensors.feature_dim}) "
                f"== sensors.n_visual ({self.sensors.n_visual})"
            )
        if self.evaluation.distance_to == "target" and self.sensors.encoder != "blob":
            raise ConfigError(
                "evaluation.distance_to=target measures the reach to the target the blob "
                f"front-end localised; sensors.encoder is {self.sensors.encoder!r}. Use "
                "sensors.encoder: blob or evaluation.distance_to: nearest"
            )
