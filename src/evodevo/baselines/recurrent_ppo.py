"""RecurrentPPO of sb3-contrib on the blob features: the recurrent baseline of the memory task.

PPO whose actor and critic each carry an LSTM from step to step (sb3-contrib's
``MlpLstmPolicy``), so what it saw before the camera went dark (the Kuka env's ``dark_after``;
docs/grn.md, "A task that needs memory") can steer it afterwards. It reads what the GRN of the
vision preset and PPO with ``ppo.encoder: blob`` read: the blob front-end's 4 features
``[dx, dy, size, found]`` (:class:`~evodevo.baselines.feature_env.FeatureObservation`), under
the same env-step budget, evaluation callbacks and checkpoints as PPO and TD3
(:func:`evodevo.baselines.sb3_kuka.train_sb3`, which builds it with :func:`build_recurrent_ppo`).
Its PPO settings are section ``ppo``'s; section ``recurrent_ppo`` sizes the LSTM.

Saved without pickle like every SB3 model here: :func:`evodevo.baselines.sb3_files.save_sb3`
writes the policy's weights to safetensors and its description, LSTM sizes included, to JSON.
:class:`RecurrentPpoPolicy` runs a saved model in the GRN evaluator, one LSTM state per episode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from sb3_contrib import RecurrentPPO

from evodevo.baselines.kuka_config import KukaBaselineConfig
from evodevo.baselines.policies import Sb3Model, Sb3Policy

__all__ = ["build_recurrent_ppo", "LstmMemory", "RecurrentPpoPolicy"]


def build_recurrent_ppo(cfg: KukaBaselineConfig, env: Any) -> RecurrentPPO:
    """A fresh RecurrentPPO for ``cfg`` on ``env`` (the blob features; seeded by ``seed=``)."""
    p, r = cfg.ppo, cfg.recurrent_ppo
    return RecurrentPPO(
        "MlpLstmPolicy",
        env,
        **p.sb3_kwargs(),
        policy_kwargs={
            "net_arch": list(p.net_arch),
            "lstm_hidden_size": r.lstm_hidden_size,
            "n_lstm_layers": r.n_lstm_layers,
            "shared_lstm": r.shared_lstm,
            "enable_critic_lstm": not r.shared_lstm,
        },
        seed=cfg.seed,
        device="cpu",
        verbose=0,
    )


@dataclass
class LstmMemory:
    """The actor LSTM's (hidden, cell) state of every episode slot, each (layers, 1, size), and
    whether the slot's episode has not acted yet."""

    hidden: list[np.ndarray]
    cell: list[np.ndarray]
    start: np.ndarray


class RecurrentPpoPolicy(Sb3Policy):
    """A saved RecurrentPPO in the GRN evaluator (controller of method ``recurrent_ppo``).

    As :class:`~evodevo.baselines.policies.Sb3Policy` (deterministic actions; the blob features
    encoded from the images, with the GRN's noise on noisy episodes), and each episode slot
    keeps its LSTM state from step to step, reset at the episode's start as during training.
    """

    def reset_state(self, genomes: Sequence[Sb3Model]) -> tuple[Any, ...]:
        models, fstate = super().reset_state(genomes)
        shapes = [m.lstm_hidden_state_shape for m in models]
        memory = LstmMemory(
            [np.zeros(s, np.float32) for s in shapes],
            [np.zeros(s, np.float32) for s in shapes],
            np.ones(len(models), dtype=bool),
        )
        return models, fstate, memory

    def act(self, model: Any, obs: np.ndarray, state: Any, slots: np.ndarray) -> np.ndarray:
        """Actions of ``model`` for ``slots``, advancing their LSTM states."""
        memory: LstmMemory = state[2]
        slots = np.asarray(slots)
        lstm = (
            np.concatenate([memory.hidden[s] for s in slots], axis=1),
            np.concatenate([memory.cell[s] for s in slots], axis=1),
        )
        actions, (hidden, cell) = model.predict(
            obs, state=lstm, episode_start=memory.start[slots], deterministic=True
        )
        for j, s in enumerate(slots.tolist()):
            memory.hidden[s] = hidden[:, j : j + 1]
            memory.cell[s] = cell[:, j : j + 1]
        memory.start[slots] = False
        return np.asarray(actions, dtype=np.float64).reshape(len(slots), -1)
