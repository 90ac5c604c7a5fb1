"""Evolved feed-forward policies on the GRN's inputs: controller kinds ``linear`` and ``mlp``.

The comparison arms of "does the regulatory network help?": the same front-end features and
proprioception the GRN reads, the same optimiser, evaluator and budget, only the map from
sensors to actions differs. The input is

    ``s = [features (+ noise on noisy episodes), proprio]``

with the front-end's ``sensors.feature_dim`` features read directly (for the blob front-end
the 4 values ``[dx, dy, size, found]``; a first layer makes the GRN's projection P redundant),
zeros for them with ``sensors.blind`` and for the proprioceptive values with ``sensors.proprio:
false``, exactly as the GRN's sensor vector; the visual noise of noisy episodes, N(0,
``evaluation.visual_noise``²) per feature, comes from the episode's generator. Then

* ``linear``: ``a = tanh(s W1 + b1)``;
* ``mlp``: ``a = tanh(tanh(s W1 + b1) W2 + b2)``, ``feedforward.hidden`` tanh units.

Weights and biases start N(0, ``feedforward.init_std``²). The GA perturbs each array of an
offspring with probability ``feedforward.p_mutate`` by N(0, ``feedforward.sigma``²); CMA-ES
moves every entry at that scale. A batch of genomes steps in one array operation, like the GRN.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> ctrl = MlpController(GrnConfig(), n_actions=3)
>>> sorted(ctrl.init_genome(np.random.default_rng(0)).arrays())
['W1', 'W2', 'b1', 'b2']
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.grn.genome import check_frontend, load_arrays, save_arrays

__all__ = [
    "FeedForwardGenome",
    "FeedForwardState",
    "FeedForwardController",
    "LinearController",
    "MlpController",
]

_LAYER_NAMES = ("W1", "b1", "W2", "b2")


@dataclass
class FeedForwardGenome:
    """The weights of a feed-forward policy (a leading batch axis when stacked).

    Attributes:
        W1: (n_inputs, units) first-layer weights; units = actions for ``linear``.
        b1: (units,) first-layer biases.
        W2: (hidden, actions) output weights (``mlp`` only).
        b2: (actions,) output biases (``mlp`` only).
    """

    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray | None = None
    b2: np.ndarray | None = None

    KIND = "feedforward"

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays by name (W1, b1, and W2, b2 with a hidden layer)."""
        return {n: a for n in _LAYER_NAMES if (a := getattr(self, n)) is not None}

    def copy(self) -> FeedForwardGenome:
        """A deep copy."""
        return FeedForwardGenome(**{k: v.copy() for k, v in self.arrays().items()})

    def connections(self) -> int:
        """Feed-forward policies have no regulatory connections."""
        return 0

    def save(self, path: str | Path, config: dict[str, Any] | None = None) -> None:
        """Write one ``.npz`` with a JSON header holding ``config``."""
        save_arrays(path, self.KIND, self.arrays(), {"config": dict(config or {})})


@dataclass
class FeedForwardState:
    """Stacked genomes of the episodes stepped together."""

    genome: FeedForwardGenome


class FeedForwardController:
    """A feed-forward policy with ``hidden_units`` tanh units (0: linear); see the module.

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig` (``sensors``, ``feedforward``,
            ``evaluation.visual_noise``).
        n_actions: action dimensions of the environment.
        hidden_units: tanh units of the hidden layer, 0 for none.
    """

    name = "feedforward"
    uses_encoder = True

    def __init__(self, config: GrnConfig, n_actions: int, hidden_units: int = 0) -> None:
        self.config = config
        self.sensors = config.sensors
        self.ff = config.feedforward
        self.n_actions = int(n_actions)
        self.hidden_units = int(hidden_units)
        self.uses_encoder = not config.sensors.blind
        self.n_features = int(self.sensors.feature_dim) if self.sensors.n_visual > 0 else 0
        self.n_inputs = self.n_features + int(self.sensors.n_proprio)

    def shapes(self) -> dict[str, tuple[int, ...]]:
        """The shape of each array of a genome."""
        n_in, h, a = self.n_inputs, self.hidden_units, self.n_actions
        if h == 0:
            return {"W1": (n_in, a), "b1": (a,)}
        return {"W1": (n_in, h), "b1": (h,), "W2": (h, a), "b2": (a,)}

    # -- genome -------------------------------------------------------------------------------
    def init_genome(self, rng: np.random.Generator) -> FeedForwardGenome:
        return FeedForwardGenome(
            **{k: rng.normal(0.0, self.ff.init_std, s) for k, s in self.shapes().items()}
        )

    def mutate(self, genome: FeedForwardGenome, rng: np.random.Generator) -> FeedForwardGenome:
        child = genome.copy()
        for a in child.arrays().values():
            if rng.random() < self.ff.p_mutate:
                a += rng.normal(0.0, self.ff.sigma, a.shape)
        return child

    def genome_from_arrays(self, arrays: dict[str, np.ndarray], where: str = "genome") -> Any:
        shapes = self.shapes()
        if set(arrays) != set(shapes):
            raise CheckpointError(
                f"{where}: holds the arrays {sorted(arrays)}, a {self.name} policy has "
                f"{sorted(shapes)}; it was evolved with another controller"
            )
        for k, s in shapes.items():
            a = arrays[k]
            if tuple(a.shape) != s:
                raise CheckpointError(
                    f"{where}: {k} has shape {tuple(a.shape)}, expected {s} (inputs, "
                    "feedforward.hidden or actions differ)"
                )
            if not np.all(np.isfinite(a)):
                raise CheckpointError(f"{where}: {k} holds non-finite values")
        return FeedForwardGenome(**{k: np.asarray(arrays[k], dtype=np.float64) for k in shapes})

    def load_genome(self, path: str | Path) -> FeedForwardGenome:
        arrays, header = load_arrays(path, FeedForwardGenome.KIND)
        check_frontend(header, self.sensors.encoder, path)
        return self.genome_from_arrays(arrays, str(path))  # type: ignore[no-any-return]

    def connections(self, genome: FeedForwardGenome) -> int:
        return genome.connections()

    def evolvable(self, genome: FeedForwardGenome) -> dict[str, tuple[np.ndarray, float]]:
        """Every weight and bias moves, at the scale ``feedforward.sigma`` (CMA-ES)."""
        return {
            k: (np.ones(a.shape, dtype=bool), self.ff.sigma) for k, a in genome.arrays().items()
        }

    def repair(self, genome: FeedForwardGenome) -> FeedForwardGenome:
        """Nothing is bounded."""
        return genome

    # -- runtime ------------------------------------------------------------------------------
    def reset_state(self, genomes: Sequence[FeedForwardGenome]) -> FeedForwardState:
        stacked = {
            k: np.stack([self.genome_from_arrays(g.arrays()).arrays()[k] for g in genomes])
            for k in self.shapes()
        }
        return FeedForwardState(FeedForwardGenome(**stacked))

    def inputs(
        self,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        """``s`` (len(rngs), n_inputs): features (+ noise on noisy episodes), proprio."""
        n_b = len(rngs)
        visual = np.zeros((n_b, self.n_features))
        if self.n_features and features is not None and not self.sensors.blind:
            visual = np.asarray(features, dtype=np.float64).reshape(n_b, self.n_features).copy()
            std = self.config.evaluation.visual_noise
            for b, rng in enumerate(rngs):
                if noisy[b]:
                    visual[b] += rng.normal(0.0, std, self.n_features)
        prop = np.asarray(proprio, dtype=np.float64)
        if not self.sensors.proprio:
            prop = np.zeros_like(prop)
        return np.concatenate([visual, prop], axis=1)

    def step(
        self,
        state: FeedForwardState,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        g = state.genome
        s = self.inputs(features, proprio, rngs, noisy)
        out = np.einsum("bi,bio->bo", s, g.W1[idx]) + g.b1[idx]
        if g.W2 is not None and g.b2 is not None:
            out = np.einsum("bh,bha->ba", np.tanh(out), g.W2[idx]) + g.b2[idx]
        return np.asarray(np.tanh(out))


class LinearController(FeedForwardController):
    """Controller kind ``linear``: ``a = tanh(s W1 + b1)``."""

    name = "linear"

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        super().__init__(config, n_actions, hidden_units=0)


class MlpController(FeedForwardController):
    """Controller kind ``mlp``: one hidden layer of ``feedforward.hidden`` tanh units."""

    name = "mlp"

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        super().__init__(config, n_actions, hidden_units=config.feedforward.hidden)
