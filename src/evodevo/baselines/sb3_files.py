"""Stable-Baselines3 models and replay buffers on disk without pickle (SPEC §4, §6).

SB3's own ``model.save()`` cloudpickles the spaces, schedules and classes of a model into its
zip, and ``PPO.load()`` unpickles them; its replay-buffer file is a pickle. Opening a run
folder somebody else sent must not run code from it, so the SB3 baselines write these instead:

* a **model file** (``model.safetensors``, ``checkpoints/rl_model_{n}_steps.safetensors``,
  ``checkpoints/sb3_task{i}.safetensors``) by :func:`save_sb3`: an :mod:`evodevo.safe_io`
  state file holding the algorithm, the policy class by its SB3 alias (``"CnnPolicy"``), the
  policy's constructor parameters as JSON (spaces as bounds and dtype; activation, optimiser
  and feature-extractor classes by name, read back only from :data:`CLASSES`; for
  sb3-contrib's RecurrentPPO also the LSTM's size, layers and sharing), the policy's
  ``state_dict``, the optimisers' ``state_dict`` s, and the counters a resumed run continues
  from (``num_timesteps``, ``_n_updates``, ``_episode_num``, ``learning_starts``);
* a **replay buffer** (``checkpoints/rl_model_replay_buffer_{n}_steps.npz``, TD3) by
  :func:`save_replay_buffer`: the filled rows of SB3's buffer arrays, its position and
  whether it wrapped, in an ``.npz`` read with ``allow_pickle=False``.

:func:`load_sb3_policy` rebuilds the SB3 policy object of a model file (its ``predict`` is the
one ``model.predict`` calls) for evaluation; :func:`restore_sb3` loads a model file into a model
freshly built from the run's own config (resume), and :func:`load_replay_buffer` its buffer.
:class:`SafeCheckpointCallback` is SB3's ``CheckpointCallback`` writing these files.

A model saved with ``training=False`` holds the policy without its target networks and
optimiser states: enough to act (the targets are only read by training), not to resume.
Runs converted from SB3 zips keep TD3's that way under 5 MB (``scripts/convert_safe_run_files.py``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from sb3_contrib import RecurrentPPO
from sb3_contrib.common.recurrent.policies import RecurrentActorCriticPolicy
from stable_baselines3 import DQN, PPO, TD3
from stable_baselines3.common.callbacks import CheckpointCallback
from stable_baselines3.common.save_util import recursive_getattr
from stable_baselines3.common.torch_layers import FlattenExtractor, NatureCNN
from torch import nn

from evodevo.baselines.kuka_cnn import KukaCnn
from evodevo.errors import CheckpointError
from evodevo.runs import atomic_write_with
from evodevo.safe_io import describe_foreign, legacy_error, load_state, save_state

__all__ = [
    "KIND",
    "MODEL_SUFFIX",
    "ALGOS",
    "CLASSES",
    "algo_of",
    "save_sb3",
    "load_sb3_policy",
    "restore_sb3",
    "read_sb3_counters",
    "save_replay_buffer",
    "load_replay_buffer",
    "SafeCheckpointCallback",
]

#: Kind of an SB3 model file (:func:`evodevo.safe_io.save_state`).
KIND = "sb3-model"
MODEL_SUFFIX = ".safetensors"
#: The SB3 algorithms evodevo trains, by name (RecurrentPPO from sb3-contrib).
ALGOS: dict[str, type[Any]] = {
    "ppo": PPO,
    "td3": TD3,
    "dqn": DQN,
    "recurrent_ppo": RecurrentPPO,
}
#: Every class a saved policy may name (activations, optimisers, feature extractors); a file
#: naming another is refused, so loading never imports anything a file asks for.
CLASSES: dict[str, type[Any]] = {
    "ReLU": nn.ReLU,
    "Tanh": nn.Tanh,
    "ELU": nn.ELU,
    "LeakyReLU": nn.LeakyReLU,
    "Adam": torch.optim.Adam,
    "AdamW": torch.optim.AdamW,
    "RMSprop": torch.optim.RMSprop,
    "FlattenExtractor": FlattenExtractor,
    "NatureCNN": NatureCNN,
    "KukaCnn": KukaCnn,
}
_COUNTERS = ("num_timesteps", "_n_updates", "_episode_num", "learning_starts")
_TARGETS = {"actor_target": "actor", "critic_target": "critic", "q_net_target": "q_net"}
_BUFFER_ARRAYS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def algo_of(model: Any) -> str:
    """``"ppo"``, ``"td3"``, ``"dqn"`` or ``"recurrent_ppo"`` for an SB3 model (subclasses
    included)."""
    for name, cls in ALGOS.items():
        if isinstance(model, cls):
            return name
    raise TypeError(f"{type(model).__name__} is not one of the SB3 algorithms {list(ALGOS)}")


def _class_name(cls: type[Any]) -> str:
    for name, known in CLASSES.items():
        if cls is known:
            return name
    raise TypeError(f"{cls.__qualname__} is not in evodevo.baselines.sb3_files.CLASSES")


def _encode_space(space: gym.Space[Any]) -> dict[str, Any]:
    if isinstance(space, gym.spaces.Box):
        return {"space": "Box", "low": space.low, "high": space.high, "dtype": space.dtype.str}
    if isinstance(space, gym.spaces.Discrete):
        return {"space": "Discrete", "n": int(space.n), "start": int(space.start)}
    raise TypeError(f"an SB3 model on a {type(space).__name__} space cannot be saved")


def _encode_params(params: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in params.items():
        if key == "lr_schedule":  # training state, rebuilt from the run's config
            continue
        if isinstance(value, gym.Space):
            out[key] = _encode_space(value)
        elif isinstance(value, type):
            out[key] = {"class": _class_name(value)}
        else:
            out[key] = value
    return out


def _constructor_parameters(policy: Any) -> dict[str, Any]:
    """The keyword arguments that rebuild ``policy``: SB3's own list, and for sb3-contrib's
    recurrent policies the LSTM's settings, which their list leaves out (its size, layers and
    sharing would otherwise come back as the defaults, and the weights would not fit)."""
    params = dict(policy._get_constructor_parameters())
    if isinstance(policy, RecurrentActorCriticPolicy):
        params.update(
            lstm_hidden_size=int(policy.lstm_output_dim),
            n_lstm_layers=int(policy.lstm_actor.num_layers),
            shared_lstm=bool(policy.shared_lstm),
            enable_critic_lstm=bool(policy.enable_critic_lstm),
            lstm_kwargs=dict(policy.lstm_kwargs),
        )
    return params


def save_sb3(model: Any, path: str | Path, training: bool = True) -> None:
    """Write ``model`` (PPO, TD3, DQN or RecurrentPPO) as a model file (see module docstring).

    Args:
        model: the SB3 model.
        path: the file (``.safetensors``).
        training: also save the target networks and optimiser states (needed to resume).
    """
    policy = model.policy
    aliases = {cls: name for name, cls in type(model).policy_aliases.items()}
    if type(policy) not in aliases:
        raise TypeError(f"{type(policy).__name__} is not one of SB3's named policies")
    state = policy.state_dict()
    if not training:
        state = {k: v for k, v in state.items() if k.split(".")[0] not in _TARGETS}
    names, _ = model._get_torch_save_params()
    save_state(
        path,
        KIND,
        {
            "algo": algo_of(model),
            "policy_class": aliases[type(policy)],
            "policy_params": _encode_params(_constructor_parameters(policy)),
            "policy": state,
            "optimizers": (
                {n: recursive_getattr(model, n).state_dict() for n in names if n != "policy"}
                if training
                else None
            ),
            "counters": {k: int(getattr(model, k)) for k in _COUNTERS if hasattr(model, k)},
        },
    )


def _read(path: str | Path, algo: str) -> dict[str, Any]:
    p = Path(path)
    if not p.is_file() and p.with_suffix(".zip").is_file():
        raise legacy_error(p.with_suffix(".zip"), "a Stable-Baselines3 zip (it holds pickles)")
    state = load_state(p, KIND, f"{algo.upper()} model", "was this run trained by evodevo?")
    saved = state.get("algo")
    if saved != algo:
        raise CheckpointError(
            f"{str(p)!r} is not a saved {algo.upper()} model (it holds a {str(saved).upper()} "
            "model); a run directory of another method was passed"
        )
    return state


def _bad(path: str | Path, what: str) -> CheckpointError:
    return CheckpointError(f"SB3 model {str(path)!r} {what}; it was not written by evodevo")


def _decode_space(path: str | Path, spec: Any) -> gym.Space[Any]:
    kind = spec.get("space") if isinstance(spec, dict) else None
    if kind == "Box":
        dtype = np.dtype(str(spec["dtype"]))
        if dtype.kind not in "biuf":
            raise _bad(path, f"has a Box space of dtype {dtype}")
        return gym.spaces.Box(np.asarray(spec["low"]), np.asarray(spec["high"]), dtype=dtype)  # type: ignore[arg-type]
    if kind == "Discrete":
        return gym.spaces.Discrete(int(spec["n"]), start=int(spec["start"]))
    raise _bad(path, f"has an observation or action space {kind!r} evodevo does not load")


def _decode_params(path: str | Path, params: Any) -> dict[str, Any]:
    if not isinstance(params, dict):
        raise _bad(path, "has no policy parameters")
    out: dict[str, Any] = {}
    for key, value in params.items():
        if key in ("observation_space", "action_space"):
            out[key] = _decode_space(path, value)
        elif isinstance(value, dict) and set(value) == {"class"}:
            if value["class"] not in CLASSES:
                raise _bad(path, f"names the class {value['class']!r}, which evodevo does not load")
            out[key] = CLASSES[value["class"]]
        else:
            out[key] = value
    return out


def _no_schedule(_: float) -> float:
    return 0.0


def _policy(path: str | Path, algo: str, state: dict[str, Any]) -> Any:
    """The SB3 policy object described by a model file, with its weights."""
    aliases = ALGOS[algo].policy_aliases
    name = state.get("policy_class")
    if name not in aliases:
        raise _bad(path, f"names the policy {name!r}, not one of {sorted(aliases)}")
    try:
        params = _decode_params(path, state.get("policy_params"))
        with torch.random.fork_rng(devices=[]):  # the initial weights are overwritten
            policy = aliases[name](lr_schedule=_no_schedule, **params)
    except (TypeError, ValueError, KeyError, AssertionError, RuntimeError, AttributeError) as exc:
        raise _bad(path, f"describes a policy SB3 cannot build ({exc})") from None
    weights = state.get("policy")
    if not isinstance(weights, dict):
        raise _bad(path, "holds no policy weights")
    try:
        missing, unexpected = policy.load_state_dict(weights, strict=False)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()[0]
        raise _bad(path, f"holds weights of another shape ({first})") from None
    if unexpected or any(k.split(".")[0] not in _TARGETS for k in missing):
        raise _bad(
            path, f"holds other weights (missing {missing[:3]}, unexpected {unexpected[:3]})"
        )
    if missing:  # saved with training=False: the targets (read only by training) = the nets
        for target, net in _TARGETS.items():
            if hasattr(policy, target):
                getattr(policy, target).load_state_dict(getattr(policy, net).state_dict())
    policy.set_training_mode(False)
    return policy


def load_sb3_policy(algo: str, path: str | Path) -> Any:
    """The SB3 policy of a model file of ``algo``, for acting (``policy.predict(obs)``).

    Raises:
        CheckpointError: missing, corrupt, pickle-based, another algorithm's, or naming a
            class outside :data:`CLASSES`.
    """
    if algo not in ALGOS:
        raise CheckpointError(f"{algo!r} is not an SB3 algorithm; choose one of {list(ALGOS)}")
    return _policy(path, algo, _read(path, algo))


def read_sb3_counters(algo: str, path: str | Path) -> dict[str, int]:
    """The counters saved with a model (``num_timesteps``, ``_n_updates``, ...)."""
    counters = _read(path, algo).get("counters")
    if not isinstance(counters, dict):
        raise _bad(path, "holds no counters")
    return {str(k): int(v) for k, v in counters.items()}


def restore_sb3(model: Any, path: str | Path) -> None:
    """Load a model file into ``model``, built from the run's own config (resume).

    The policy weights (with its target networks), the optimiser states and the counters are
    restored; the environment is reset when training continues.
    """
    algo = algo_of(model)
    state = _read(path, algo)
    saved = _policy(path, algo, state)
    for space in ("observation_space", "action_space"):
        if getattr(saved, space) != getattr(model.policy, space):
            raise CheckpointError(
                f"SB3 model {str(path)!r} was saved for the {space} {getattr(saved, space)}, "
                f"this run has {getattr(model.policy, space)}; resume with the run's own config"
            )
    optimizers = state.get("optimizers")
    names, _ = model._get_torch_save_params()
    if not isinstance(optimizers, dict) or set(optimizers) != set(names) - {"policy"}:
        raise CheckpointError(
            f"SB3 model {str(path)!r} holds a policy for acting only, without its optimiser "
            "states; a run cannot continue from it"
        )
    try:
        model.policy.load_state_dict(state["policy"])
        for name, opt_state in optimizers.items():
            recursive_getattr(model, name).load_state_dict(opt_state)
    except (RuntimeError, ValueError, KeyError) as exc:
        first = str(exc).strip().splitlines()[0]
        raise _bad(path, f"does not fit this run's model ({first})") from None
    for key, value in dict(state.get("counters") or {}).items():
        if key in _COUNTERS:
            setattr(model, key, int(value))


def save_replay_buffer(model: Any, path: str | Path) -> None:
    """Atomically write the filled part of ``model.replay_buffer`` as an ``.npz``."""
    rb = model.replay_buffer
    n = rb.buffer_size if rb.full else rb.pos
    arrays = {
        name: getattr(rb, name)[:n]
        for name in _BUFFER_ARRAYS
        if getattr(rb, name, None) is not None
    }
    arrays["pos"] = np.asarray(rb.pos, dtype=np.int64)
    arrays["full"] = np.asarray(rb.full, dtype=np.bool_)
    atomic_write_with(path, lambda fh: np.savez(fh, **arrays))  # type: ignore[arg-type]


def load_replay_buffer(model: Any, path: str | Path) -> None:
    """Fill ``model.replay_buffer`` from a file written by :func:`save_replay_buffer`."""
    p = Path(path)
    rb = model.replay_buffer
    with p.open("rb") as fh:
        head = fh.read(9)
    if head[:4] != b"PK\x03\x04":
        raise legacy_error(p, describe_foreign(head) or "not an .npz archive")
    try:
        with np.load(p, allow_pickle=False) as data:
            saved = {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError) as exc:
        raise CheckpointError(
            f"replay buffer {str(p)!r} is corrupt or truncated ({exc}); delete it to resume "
            "with a refilled buffer"
        ) from None
    try:
        pos, full = int(saved.get("pos", -1)), bool(saved.get("full", False))
    except (TypeError, ValueError):
        pos, full = -1, False
    n = rb.buffer_size if full else pos
    for name in _BUFFER_ARRAYS:
        mine = getattr(rb, name, None)
        if mine is None:
            continue
        got = saved.get(name)
        if (
            got is None
            or not 0 <= pos <= rb.buffer_size
            or got.shape != (n, *mine.shape[1:])
            or got.dtype != mine.dtype
        ):
            raise CheckpointError(
                f"replay buffer {str(p)!r} does not fit this run's buffer ({name}); resume with "
                "the run's own config, or delete it to resume with a refilled buffer"
            )
        mine[:n] = got
    rb.pos, rb.full = pos % rb.buffer_size, full


class SafeCheckpointCallback(CheckpointCallback):
    """SB3's ``CheckpointCallback``, writing :func:`save_sb3` and :func:`save_replay_buffer`
    files (``{prefix}_{n}_steps.safetensors``, ``{prefix}_replay_buffer_{n}_steps.npz``)."""

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            save_sb3(self.model, self._checkpoint_path(extension=MODEL_SUFFIX[1:]))
            if self.save_replay_buffer and getattr(self.model, "replay_buffer", None) is not None:
                save_replay_buffer(
                    self.model, self._checkpoint_path("replay_buffer_", extension="npz")
                )
        return True
