"""Trained baselines as evaluator policies, so they are tested by the GRN's evaluate code path.

The GRN :class:`~evodevo.grn.evaluator.Evaluator` runs any object with the ``Policy`` protocol
of :mod:`evodevo.grn.controller` (``reset_state(genomes)``, vectorised ``step``). Here:

* :class:`Sb3Policy` (controller ``"evodevo.baselines.policies:Sb3Policy"``) drives a saved
  Stable-Baselines3 model; its "genome" is an :class:`Sb3Model` (algorithm and file), whose
  policy is loaded once per worker by :func:`load_sb3` (no pickle is read:
  :mod:`evodevo.baselines.sb3_files`). It sets ``uses_image`` so the evaluator hands it the raw 48x48 images.
* :class:`NeatPolicy` (controller ``"evodevo.baselines.policies:NeatPolicy"``) drives a
  neat-python feed-forward network on the run's fixed encoder features (SPEC §4: 128-d → actions);
  its genome is a :class:`NeatNet` (the neat genome as JSON, :mod:`evodevo.baselines.neat_files`,
  and the neat config file). On noisy episodes every feature gets
  N(0, ``evaluation.visual_noise``²).

The SB3 policy on the image ignores the noisy flag (its input is the image, not features); on
the blob front-end (``ppo.encoder: blob``) it encodes the images itself and noisy episodes get
the GRN's N(0, ``evaluation.visual_noise``²) on every feature.

Both are picklable references, so the evaluator's worker processes receive them like genomes.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.grn.frontends import BlobLocaliser
from evodevo.safe_io import legacy_error

__all__ = ["Sb3Model", "Sb3Policy", "NeatNet", "NeatPolicy", "SB3_ALGOS", "load_sb3"]

SB3_ALGOS = ("ppo", "td3", "recurrent_ppo")
"""The Stable-Baselines3 methods of SPEC §4, and sb3-contrib's RecurrentPPO (the memory task)."""


def load_sb3(algo: str, path: str | Path) -> Any:
    """The policy of a saved SB3 model of ``algo`` ("ppo", "td3", "recurrent_ppo"; "dqn" for
    the BIARM baseline), for acting: ``policy.predict(obs, deterministic=True)`` is what the
    model's own ``predict`` returns. A clear :class:`~evodevo.errors.CheckpointError` on a
    mismatch."""
    # optional dependency: stable_baselines3
    from evodevo.baselines.sb3_files import load_sb3_policy

    if algo not in (*SB3_ALGOS, "dqn"):
        raise CheckpointError(f"{algo!r} is not an SB3 baseline; choose one of {list(SB3_ALGOS)}")
    return load_sb3_policy(algo, path)


@dataclass(frozen=True)
class Sb3Model:
    """Reference to a saved SB3 model: which algorithm, which ``.safetensors`` file."""

    algo: str
    path: str

    def arrays(self) -> dict[str, np.ndarray]:
        """No arrays (the evaluator groups genomes by array shapes)."""
        return {}


def add_visual_noise(
    features: np.ndarray, rngs: Sequence[np.random.Generator], noisy: np.ndarray, std: float
) -> None:
    """In place: N(0, std²) on every feature of the rows of noisy episodes, each row's noise
    from its own episode generator (the GRN's visual-noise protocol, SPEC §2.5)."""
    for j, rng in enumerate(rngs):
        if noisy[j]:
            features[j] += rng.normal(0.0, std, features.shape[1])


class Sb3Policy:
    """Deterministic actions of a saved SB3 model from the raw image (see module docstring)."""

    uses_encoder = False
    uses_image = True

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        self.n_actions = int(n_actions)
        self._models: dict[Sb3Model, Any] = {}
        # ppo.encoder: blob -> the model reads the blob front-end's features; the
        # calibration is deterministic, so it is the one the model was trained with
        self.frontend: Any = None
        self.visual_noise = 0.0
        if getattr(getattr(config, "sensors", None), "encoder", "cnn") == "blob":
            self.frontend = blob_frontend(config.env.id, dict(config.env.kwargs))
            self.visual_noise = float(config.evaluation.visual_noise)

    def model(self, ref: Sb3Model) -> Any:
        """The loaded model of ``ref`` (cached)."""
        if ref not in self._models:
            self._models[ref] = load_sb3(ref.algo, ref.path)
        return self._models[ref]

    def reset_state(self, genomes: Sequence[Sb3Model]) -> tuple[list[Any], Any]:
        fstate = None if self.frontend is None else self.frontend.reset(len(genomes))
        return [self.model(g) for g in genomes], fstate

    def step(
        self,
        state: list[Any],
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        if features is None:
            raise CheckpointError("Sb3Policy needs the images; the evaluator passed none")
        out = np.zeros((len(idx), self.n_actions))
        models = [state[0][i] for i in idx]
        if self.frontend is not None:  # blob features, with the GRN's noise on noisy episodes
            features = self.frontend.encode(features, proprio, state[1], idx).astype(np.float32)
            add_visual_noise(features, rngs, noisy, self.visual_noise)
        # one predict per distinct model (usually one): a batch of images in one forward pass
        for model in {id(m): m for m in models}.values():
            rows = [j for j, m in enumerate(models) if m is model]
            out[rows] = self.act(model, features[rows], state, np.asarray(idx)[rows])
        return out

    def act(self, model: Any, obs: np.ndarray, state: Any, slots: np.ndarray) -> np.ndarray:
        """Deterministic actions (len(slots), A) of ``model`` on ``obs``, the inputs of slots
        ``slots`` (a recurrent policy also advances their memory in ``state``)."""
        actions, _ = model.predict(obs, deterministic=True)
        return np.asarray(actions, dtype=np.float64).reshape(len(obs), -1)


@dataclass(frozen=True)
class NeatNet:
    """A neat-python genome (JSON text of :func:`~evodevo.baselines.neat_files.genome_to_dict`)
    and the neat config file it was evolved with."""

    genome: str
    config_path: str

    def arrays(self) -> dict[str, np.ndarray]:
        """No arrays (the evaluator groups genomes by array shapes)."""
        return {}

    def behaviour_key(self) -> tuple[Any, ...]:
        """The network's genes in the genome's order, without its id and fitness.

        Two genomes with equal keys build the same feed-forward network (same nodes, same
        connections in the same order, hence the same sums), so the evaluator runs one of them
        (:func:`evodevo.grn.evaluator.genome_key`).
        """
        g = json.loads(self.genome)

        def genes(items: list[dict[str, Any]]) -> tuple[Any, ...]:
            return tuple(
                (json.dumps(gene["key"]), tuple(sorted((k, repr(v)) for k, v in gene.items())))
                for gene in items
            )

        return (self.config_path, genes(g["nodes"]), genes(g["connections"]))

    @classmethod
    def from_genome(cls, genome: Any, config_path: str | Path) -> NeatNet:
        """Wrap a live neat genome."""
        from evodevo.baselines.neat_files import genome_to_dict  # optional dependency: neat

        return cls(json.dumps(genome_to_dict(genome)), str(config_path))

    def neat_genome(self, config: Any) -> Any:
        """The neat-python genome, rebuilt for ``config`` (the ``neat.Config`` of the file)."""
        from evodevo.baselines.neat_files import genome_from_dict  # optional dependency: neat

        return genome_from_dict(json.loads(self.genome), config)

    @classmethod
    def load(cls, path: str | Path, config_path: str | Path) -> NeatNet:
        """Load ``best_genome.json`` of a NEAT run (written by :meth:`save`)."""
        from evodevo.baselines.neat_files import read_genome  # optional dependency: neat

        p = Path(path)
        if not p.is_file() and p.with_suffix(".pkl").is_file():
            raise legacy_error(p.with_suffix(".pkl"), "a pickled NEAT genome")
        return cls(json.dumps(read_genome(p, neat_config(config_path))), str(config_path))

    def save(self, path: str | Path) -> None:
        """Atomically write the genome as JSON, with the text of its neat config file."""
        from evodevo.baselines.neat_files import save_genome  # optional dependency: neat

        save_genome(path, json.loads(self.genome), self.config_path)


def neat_config(path: str | Path) -> Any:
    """The neat-python ``Config`` of a neat config file."""
    import neat  # optional dependency: neat

    p = Path(path)
    if not p.is_file():
        raise CheckpointError(f"neat config {str(p)!r} does not exist")
    return neat.Config(
        neat.DefaultGenome,
        neat.DefaultReproduction,
        neat.DefaultSpeciesSet,
        neat.DefaultStagnation,
        str(p),
    )


class NeatPolicy:
    """A NEAT feed-forward network on the 128 encoder features (see module docstring)."""

    uses_encoder = True

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        self.n_actions = int(n_actions)
        self.visual_noise = float(config.evaluation.visual_noise)
        self._configs: dict[str, Any] = {}

    def reset_state(self, genomes: Sequence[NeatNet]) -> list[Any]:
        import neat  # optional dependency: neat

        nets = []
        for g in genomes:
            if g.config_path not in self._configs:
                self._configs[g.config_path] = neat_config(g.config_path)
            config = self._configs[g.config_path]
            nets.append(neat.nn.FeedForwardNetwork.create(g.neat_genome(config), config))
        return nets

    def step(
        self,
        state: list[Any],
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        if features is None:
            raise CheckpointError("NeatPolicy needs encoder features; the run has no encoder")
        feats = np.array(features, dtype=np.float64, copy=True)
        add_visual_noise(feats, rngs, noisy, self.visual_noise)
        out = np.array([state[i].activate(feats[j].tolist()) for j, i in enumerate(idx)])
        return np.clip(out.reshape(len(idx), self.n_actions), -1.0, 1.0)


__all__ += ["neat_config"]


_CALIBRATIONS: dict[str, Any] = {}


def blob_frontend(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """The blob front-end calibrated for ``env_id`` (once per process; SPEC §2.2)."""
    key = f"{env_id}|{sorted(env_kwargs.items())!r}"
    if key not in _CALIBRATIONS:
        _CALIBRATIONS[key] = BlobLocaliser.calibrate(env_id, env_kwargs)
    return _CALIBRATIONS[key]


class ScriptedPolicy:
    """The hand-written image-only reference policy of SPEC §2.5 (no learning).

    The blob front-end of :mod:`evodevo.grn.frontends` finds, on the first 48×48 frame, the blob
    nearest the gripper against the empty tray and maps its centroid to the table through the
    camera's view and projection matrices; on every step the policy moves the gripper towards it
    by at most one action unit, ``(clip(dx, −1, 1), clip(dy, −1, 1), −1)``, and turns the gripper
    like the constant-turn policy. With no blob it *is* the constant turn. It reads the raw image
    (``uses_image``) and ignores the visual-noise flag. It acts on the current frame's features:
    on a dark frame (the Kuka env's ``dark_after``) they are 0 and it turns in place, which is
    what a feed-forward map of the current frame can do there (:class:`RememberingScriptedPolicy`
    remembers the target instead).
    """

    uses_encoder = False
    uses_image = True

    def __init__(self, config: GrnConfig, n_actions: int) -> None:
        self.n_actions = int(n_actions)
        if self.n_actions != 3:
            raise CheckpointError(
                f"the scripted policy drives (dx, dy, d-angle), 3 actions; the env has "
                f"{self.n_actions} (use the Kuka env with its height hack)"
            )
        self.frontend = blob_frontend(config.env.id, dict(config.env.kwargs))

    def reset_state(self, genomes: Sequence[Any]) -> Any:
        return self.frontend.reset(len(genomes))

    def step(
        self,
        state: Any,
        idx: np.ndarray,
        features: np.ndarray | None,
        proprio: np.ndarray,
        rngs: Sequence[np.random.Generator],
        noisy: np.ndarray,
    ) -> np.ndarray:
        f = self.features(features, proprio, state, idx)
        a = np.zeros((len(idx), 3))
        a[:, :2] = np.clip(f[:, :2], -1.0, 1.0)
        a[:, 2] = -1.0
        return a

    def features(
        self, images: np.ndarray | None, proprio: np.ndarray, state: Any, idx: np.ndarray
    ) -> np.ndarray:
        """The blob front-end's features of the current frame."""
        return np.asarray(self.frontend.encode(images, proprio, state, idx))


class RememberingScriptedPolicy(ScriptedPolicy):
    """:class:`ScriptedPolicy` that remembers the target it localised on the first frame.

    On a lit frame it acts exactly as the scripted policy; on a dark one (the Kuka env's
    ``dark_after``) it keeps steering to the remembered target with the gripper's current pose
    (``BlobLocaliser.held``) — the reference for a controller with memory.
    """

    def features(
        self, images: np.ndarray | None, proprio: np.ndarray, state: Any, idx: np.ndarray
    ) -> np.ndarray:
        """The features of the remembered target (the first frame's localisation)."""
        self.frontend.encode(images, proprio, state, idx)  # localises on the first lit frame
        return np.asarray(self.frontend.held(proprio, state, idx))


__all__ += ["ScriptedPolicy", "RememberingScriptedPolicy", "blob_frontend"]
