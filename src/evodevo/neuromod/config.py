"""Typed configuration of a BIARM / PNN run (SPEC §1; thesis Table 3.1).

Every constant of SPEC §1 is a field here with its thesis value as default; the YAML files
``configs/biarm.yaml`` and ``configs/biarm_quick.yaml`` hold the same keys. Load with
:func:`evodevo.config.load_config`, which rejects unknown keys and wrong types; bad values are
rejected by the ``validate()`` methods below, naming the key.

>>> cfg = BiarmConfig()
>>> [t.env_id for t in cfg.tasks][:2]
['CartPole-v1', 'Acrobot-v1']
>>> cfg.dqn.lr
0.001
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from evodevo.config import doc, from_dict, replace, to_dict
from evodevo.envs.env_ids import parse_env_id
from evodevo.errors import ConfigError
from evodevo.seed_split import TEST_SEED, VALIDATION_SEED, range_label, require_selection

__all__ = [
    "TaskConfig",
    "DQNConfig",
    "NetworkConfig",
    "ModuleConfig",
    "EvalConfig",
    "EWCConfig",
    "BiarmConfig",
    "THESIS_TASKS",
    "MODULE_NAMES",
]

#: Neuromodulator order used everywhere (arrays, CSV columns, Eq. 3.7 weights).
MODULE_NAMES: tuple[str, ...] = ("DA", "5HT", "NE", "ACh")


@dataclass
class TaskConfig:
    """One task of the sequence (SPEC §1 table)."""

    env_id: str = doc(
        "CartPole-v1",
        "Gymnasium id (Box observation, Discrete actions), optionally with the environment's "
        "own parameters: ID[key=value,...], e.g. LunarLander-v3[gravity=-5]",
    )
    episodes: int = doc(400, "training episodes before --episodes-scale")
    max_steps: int | None = doc(500, "episode step limit; null keeps the environment's own")

    def validate(self) -> None:
        if not self.env_id:
            raise ConfigError("tasks[].env_id is empty; give a Gymnasium id such as CartPole-v1")
        parse_env_id(self.env_id)  # a malformed ID[key=value,...] fails here, naming it
        if self.episodes < 1:
            raise ConfigError(f"tasks[].episodes={self.episodes} must be at least 1")
        if self.max_steps is not None and self.max_steps < 1:
            raise ConfigError(f"tasks[].max_steps={self.max_steps} must be at least 1 or null")


#: SPEC §1 default sequence: (env id, episodes, max steps).
THESIS_TASKS: tuple[tuple[str, int, int], ...] = (
    ("CartPole-v1", 400, 500),
    ("Acrobot-v1", 500, 500),
    ("MountainCar-v0", 800, 200),
    ("LunarLander-v3", 800, 1000),
)


def _default_tasks() -> list[TaskConfig]:
    return [TaskConfig(e, n, m) for e, n, m in THESIS_TASKS]


@dataclass
class DQNConfig:
    """DQN settings shared by every variant (SPEC §1.6, Table 3.1)."""

    lr: float = doc(1e-3, "base learning rate eta_base of Adam (Eq. 3.7)")
    batch_size: int = doc(64, "mini-batch size")
    replay_size: int = doc(10_000, "replay capacity, fresh buffer per task")
    learning_starts: int = doc(64, "transitions in the buffer before the first gradient step")
    gamma: float = doc(0.99, "discount factor")
    eps_start: float = doc(1.0, "epsilon at the start of each task")
    eps_decay: float = doc(0.995, "epsilon multiplier per eps_unit (Table 3.1's 'rate 0.995')")
    eps_min: float = doc(0.01, "epsilon floor")
    eps_unit: Literal["episode", "step"] = doc(
        "step", "what eps_decay is applied per: step (environment step) or episode (v1)"
    )
    huber_delta: float = doc(1.0, "Huber loss threshold")
    grad_clip: float = doc(10.0, "gradient-norm clip")
    target_mode: Literal["hard", "soft"] = doc(
        "soft", "target network: soft (Polyak, rate tau every gradient step) or hard (v1)"
    )
    target_update: int = doc(500, "gradient steps between hard target-network copies (hard)")
    tau: float = doc(0.005, "soft target rate: target <- (1 - tau) target + tau online (soft)")
    double_q: bool = doc(False, "double Q-learning: the online column picks the next action")
    train_every: int = doc(
        1,
        "environment steps per gradient step (Table 3.1 is silent; 1 = every step, as in v1 "
        "and v2; SB3's DQN default is 4)",
    )
    keep: Literal["last", "best"] = doc(
        "best",
        "network a task keeps when frozen: last, or best by greedy validation return "
        "(eval.validation_*)",
    )
    per_task: dict[str, dict[str, Any]] = doc(
        {"CartPole-v1": {"grad_clip": 1.0}},
        "overrides of the keys above for one task, by Gymnasium id (every other task keeps the "
        "values above); the default clips CartPole's gradient norm at 1 ({} in "
        "protocols v3, scaled, v2, v1)",
    )

    def for_task(self, env_id: str) -> DQNConfig:
        """The DQN settings task ``env_id`` trains with: these, with its ``per_task`` entry
        applied (SPEC §1.6: Table 3.1 is one protocol for every task; an override is ours).

        >>> DQNConfig(per_task={"CartPole-v1": {"grad_clip": 1.0}}).for_task("CartPole-v1").grad_clip
        1.0
        >>> DQNConfig(per_task={"CartPole-v1": {"grad_clip": 1.0}}).for_task("Acrobot-v1").grad_clip
        10.0
        """
        over = self.per_task.get(env_id)
        if not over:
            return self
        base = {**to_dict(self), "per_task": {}}  # the task's own settings have none
        return from_dict(DQNConfig, {**base, **over}, f"dqn.per_task.{env_id}")

    def validate(self) -> None:
        for env_id, over in self.per_task.items():
            if not isinstance(over, Mapping) or "per_task" in over:
                raise ConfigError(
                    f"dqn.per_task.{env_id}={over!r} must map dqn keys (not per_task) to "
                    "values, e.g. {grad_clip: 1.0}; see `evodevo biarm config`"
                )
            self.for_task(env_id)  # unknown keys and bad values: one error naming the key
        checks = [
            ("dqn.lr", self.lr > 0),
            ("dqn.batch_size", self.batch_size >= 1),
            ("dqn.replay_size", self.replay_size >= self.batch_size),
            ("dqn.learning_starts", self.learning_starts >= 1),
            ("dqn.gamma", 0 <= self.gamma <= 1),
            ("dqn.eps_start", 0 <= self.eps_start <= 1),
            ("dqn.eps_decay", 0 < self.eps_decay <= 1),
            ("dqn.eps_min", 0 <= self.eps_min <= 1),
            ("dqn.huber_delta", self.huber_delta > 0),
            ("dqn.grad_clip", self.grad_clip > 0),
            ("dqn.target_update", self.target_update >= 1),
            ("dqn.tau", 0 < self.tau <= 1),
            ("dqn.train_every", self.train_every >= 1),
        ]
        for key, ok in checks:
            if not ok:
                value = getattr(self, key.split(".")[1])
                hint = " (it must lie in (0, 1])" if key == "dqn.tau" else ""
                raise ConfigError(
                    f"{key}={value!r} is out of range{hint}; see `evodevo biarm config`"
                )
        for key, value, allowed in (
            ("eps_unit", self.eps_unit, ("episode", "step")),
            ("target_mode", self.target_mode, ("hard", "soft")),
            ("keep", self.keep, ("last", "best")),
        ):
            if value not in allowed:
                raise ConfigError(
                    f"dqn.{key}={value!r} is not one of {', '.join(allowed)}; "
                    "see `evodevo biarm config`"
                )


@dataclass
class NetworkConfig:
    """Progressive columns and lateral adapters (SPEC §1.2)."""

    hidden: int = doc(128, "units of each of the two hidden layers of a column")
    adapter_dim: int = doc(32, "BIARM adapter width r of V and W_alpha (lateral d -> r -> width)")
    d_max: int | None = doc(
        None, "input size of phi (Eq. 3.10); null = largest obs of the sequence"
    )
    lateral_kernel: str = doc(
        "auto",
        "cpp (C++ kernels, built once: BIARM's gated laterals and module update, the frozen "
        "columns of PNN and BIARM), torch (PyTorch/NumPy ops), auto (cpp when it builds)",
    )
    lateral_init: str = doc(
        "zero",
        "initial lateral maps U of a new column (SPEC §1.2, §1.6): zero (the new column starts "
        "as an isolated column and learns to read the earlier ones), or xavier (v1, v2)",
    )
    lateral_scale: float = doc(
        0.0001,
        "fixed factor on the earlier columns' activations a new column's laterals read "
        "(Rusu et al. 2016's input scale, not learned; SPEC §1.2): under Adam it scales the "
        "laterals' initial size and their learning rate alike; 1.0 = v1, v2",
    )
    stale_padding: bool = doc(
        False,
        "true reproduces runs made before 2026-12-05 (v1): the padded input positions beyond a "
        "task's observation kept the previous task's last observation during training (a bug: "
        "phi of Eq. 3.10 zero-pads, and evaluation did); false zero-pads them",
    )

    def validate(self) -> None:
        if self.hidden < 1:
            raise ConfigError(f"network.hidden={self.hidden} must be at least 1")
        if self.adapter_dim < 1:
            raise ConfigError(f"network.adapter_dim={self.adapter_dim} must be at least 1")
        if self.d_max is not None and self.d_max < 1:
            raise ConfigError(f"network.d_max={self.d_max} must be at least 1 or null")
        if self.lateral_kernel not in ("auto", "cpp", "torch"):
            raise ConfigError(
                f"network.lateral_kernel={self.lateral_kernel!r} is not one of auto, cpp, torch"
            )
        if self.lateral_init not in ("xavier", "zero"):
            raise ConfigError(
                f"network.lateral_init={self.lateral_init!r} is not one of xavier, zero"
            )
        if not (math.isfinite(self.lateral_scale) and self.lateral_scale > 0):
            raise ConfigError(
                f"network.lateral_scale={self.lateral_scale!r} must be a finite number > 0 "
                "(1.0 = the earlier columns' activations as they are)"
            )


@dataclass
class ModuleConfig:
    """The four neuromodulator modules (SPEC §1.3-1.4)."""

    hidden: int = doc(64, "hidden ReLU units of each target network")
    tau_da: float = doc(0.1, "EMA rate of dopamine (Eq. 3.1)")
    tau_5ht: float = doc(0.5, "EMA rate of serotonin (Eq. 3.1)")
    tau_ne: float = doc(0.05, "EMA rate of norepinephrine (Eq. 3.1)")
    tau_ach: float = doc(0.3, "EMA rate of acetylcholine (Eq. 3.1)")
    initial_state: float = doc(0.5, "state of every module at the start of training")
    novelty_decay: float = doc(0.995, "n_task multiplier after every environment step (Eq. 3.5)")
    lr_weights: list[float] = doc([0.3, 0.2, 0.3, 0.2], "Eq. 3.7 weights (DA, 5HT, NE, ACh)")
    lr_relative: bool = doc(
        True,
        "Eq. 3.7 relative to the resting state: eta_eff = eta_base * sum w_m s_m / (initial_state "
        "* sum w_m), so eta_base is the rate at rest (false, v1 and v2: Eq. 3.7 as written, half "
        "of eta_base at rest)",
    )
    context_weights: list[float] = doc(
        [0.3, 0.2, 0.3, 0.2], "initial w_m of the context gate of Eq. 3.8 (DA, 5HT, NE, ACh)"
    )
    learn_context_weights: bool = doc(True, "train the Eq. 3.8 w_m with the column")
    learning: Literal["fixed", "learned"] = doc(
        "fixed", "fixed: random target nets; learned: trained by TD loss via the gate"
    )
    ablated_value: float = doc(0.5, "state held by an ablated module, and fed downstream")
    sample_interval: int = doc(100, "environment steps between rows of neuromod.csv")

    @property
    def taus(self) -> tuple[float, float, float, float]:
        return (self.tau_da, self.tau_5ht, self.tau_ne, self.tau_ach)

    def validate(self) -> None:
        if self.hidden < 1:
            raise ConfigError(f"modules.hidden={self.hidden} must be at least 1")
        for name, tau in zip(("tau_da", "tau_5ht", "tau_ne", "tau_ach"), self.taus, strict=True):
            if not 0 < tau <= 1:
                raise ConfigError(f"modules.{name}={tau} must lie in (0, 1]")
        for name in ("initial_state", "ablated_value"):
            v = getattr(self, name)
            if not 0 <= v <= 1:
                raise ConfigError(f"modules.{name}={v} must lie in [0, 1]")
        if not 0 < self.novelty_decay <= 1:
            raise ConfigError(f"modules.novelty_decay={self.novelty_decay} must lie in (0, 1]")
        for name in ("lr_weights", "context_weights"):
            v = getattr(self, name)
            if len(v) != 4 or not all(math.isfinite(x) for x in v):
                raise ConfigError(
                    f"modules.{name}={v} must hold 4 finite numbers (DA, 5HT, NE, ACh)"
                )
        if self.sample_interval < 1:
            raise ConfigError(f"modules.sample_interval={self.sample_interval} must be >= 1")
        if self.lr_relative and self.initial_state * sum(self.lr_weights) <= 0:
            raise ConfigError(
                f"modules.lr_relative needs initial_state * sum(lr_weights) > 0, got "
                f"{self.initial_state} * {sum(self.lr_weights)}; set modules.lr_relative: false"
            )


@dataclass
class EvalConfig:
    """Greedy evaluation (SPEC §1.7) on the locked test range, and the validation that
    ``dqn.keep: best`` selects on (SPEC §1.6) on the validation range (SPEC §6,
    :mod:`evodevo.seed_split`)."""

    episodes: int = doc(20, "greedy evaluation episodes per column")
    seed: int = doc(
        TEST_SEED,
        "first evaluation seed; episode j uses seed + j (same for all runs); 1000000.. is the "
        "locked test range, 10000..999999 validation (SPEC §6)",
    )
    validation_episodes: int = doc(
        20, "greedy validation episodes per check (dqn.keep: best); seeds validation_seed + j"
    )
    validation_every: int = doc(
        25, "training episodes between validation checks (and one after the last episode)"
    )
    validation_seed: int = doc(
        VALIDATION_SEED,
        "first validation seed; in the validation range 10000..999999, never the test range",
    )

    def validate(self) -> None:
        if self.episodes < 1:
            raise ConfigError(f"eval.episodes={self.episodes} must be at least 1")
        if self.validation_episodes < 1:
            raise ConfigError(
                f"eval.validation_episodes={self.validation_episodes} must be at least 1"
            )
        if self.validation_every < 1:
            raise ConfigError(f"eval.validation_every={self.validation_every} must be at least 1")
        require_selection(self.validation_seed, self.validation_episodes, "eval.validation_seed")
        lo, hi = self.seed, self.seed + self.episodes
        vlo, vhi = self.validation_seed, self.validation_seed + self.validation_episodes
        if vlo < hi and lo < vhi:
            raise ConfigError(
                f"eval.validation_seed={self.validation_seed} gives validation seeds "
                f"{vlo}..{vhi - 1}, which overlap the evaluation seeds {lo}..{hi - 1}; "
                "choose a validation_seed outside them (selection must never see the test)"
            )

    @property
    def seed_range(self) -> str:
        """The range of the evaluation seeds (``"test"``, ``"validation"``; SPEC §6)."""
        return range_label(self.seed, self.episodes)


@dataclass
class EWCConfig:
    """Elastic Weight Consolidation of the ``ewc`` variant (thesis Eq. 2.4; Kirkpatrick et al.
    2017). See :mod:`evodevo.neuromod.ewc` for the Fisher estimate."""

    lam: float = doc(
        1000.0, "lambda of Eq. 2.4: strength of the penalty (lambda/2) F (theta - theta*)^2"
    )
    fisher_samples: int = doc(
        10_000, "replay states (newest first) the diagonal Fisher is averaged over at a task's end"
    )
    fisher_chunk: int = doc(500, "states per vectorised per-sample-gradient chunk (memory only)")

    def validate(self) -> None:
        if not (self.lam >= 0 and math.isfinite(self.lam)):
            raise ConfigError(f"ewc.lam={self.lam} must be a finite number >= 0")
        if self.fisher_samples < 1:
            raise ConfigError(f"ewc.fisher_samples={self.fisher_samples} must be at least 1")
        if self.fisher_chunk < 1:
            raise ConfigError(f"ewc.fisher_chunk={self.fisher_chunk} must be at least 1")


@dataclass
class BiarmConfig:
    """Everything a BIARM/PNN run needs (SPEC §1). The variant is chosen separately."""

    tasks: list[TaskConfig] = field(
        default_factory=_default_tasks, metadata={"doc": "task sequence, in order"}
    )
    episodes_scale: float = doc(1.0, "multiplies every task's episodes (rounded, min 1)")
    default_episodes: int = doc(500, "episodes for a --tasks id not in the thesis table")
    checkpoint_every: int = doc(
        50, "episodes between mid-task checkpoints (0: only after each task)"
    )
    dqn: DQNConfig = field(default_factory=DQNConfig, metadata={"doc": "DQN section"})
    network: NetworkConfig = field(default_factory=NetworkConfig, metadata={"doc": "columns"})
    modules: ModuleConfig = field(default_factory=ModuleConfig, metadata={"doc": "modules"})
    eval: EvalConfig = field(default_factory=EvalConfig, metadata={"doc": "evaluation"})
    ewc: EWCConfig = field(default_factory=EWCConfig, metadata={"doc": "EWC (ewc variant)"})

    def validate(self) -> None:
        if not self.tasks:
            raise ConfigError("tasks is empty; give at least one Gymnasium id")
        if not (self.episodes_scale > 0 and math.isfinite(self.episodes_scale)):
            raise ConfigError(
                f"episodes_scale={self.episodes_scale} must be a positive number (e.g. 0.25)"
            )
        if self.default_episodes < 1:
            raise ConfigError(f"default_episodes={self.default_episodes} must be at least 1")
        if self.checkpoint_every < 0:
            raise ConfigError(
                f"checkpoint_every={self.checkpoint_every} must be >= 0 (0 turns mid-task "
                "checkpoints off)"
            )

    def for_task(self, env_id: str) -> BiarmConfig:
        """This config with the DQN settings of task ``env_id`` (:meth:`DQNConfig.for_task`)."""
        dqn = self.dqn.for_task(env_id)
        return self if dqn is self.dqn else replace(self, dqn=dqn)

    def scaled_episodes(self, task: TaskConfig) -> int:
        """Episodes of ``task`` after ``episodes_scale`` (round, at least 1)."""
        return max(1, int(round(task.episodes * self.episodes_scale)))
