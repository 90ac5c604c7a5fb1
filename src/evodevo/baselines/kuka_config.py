"""Typed configuration of the Kuka grasping baselines (SPEC §4, thesis Table 4.1).

One :class:`KukaBaselineConfig` per run, saved resolved in the run's ``config.json`` (kind
``"baseline"``). Sections: ``budget`` (what every method gets: env steps and/or wall minutes),
``ppo`` and ``td3`` (Stable-Baselines3 settings, Table 4.1 defaults), ``recurrent_ppo`` (the
LSTM of sb3-contrib's RecurrentPPO, the memory task's recurrent baseline), ``neat`` (neat-python
settings, Table 4.1 defaults), ``keep`` (which model the run returns, :mod:`evodevo.grn.return_rule`),
``env`` and ``evaluation`` (the same sections, and so the same test and validation seeds, as a
GRN run's :class:`~evodevo.grn.config.GrnConfig`).

>>> cfg = KukaBaselineConfig(method="ppo")
>>> cfg.ppo.gamma, cfg.ppo.clip_range, cfg.td3.buffer_size, cfg.neat.population
(0.993, 0.07, 50000, 12)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from evodevo.config import doc
from evodevo.errors import ConfigError
from evodevo.grn.config import EnvConfig, EvaluationConfig, GrnConfig, SensorConfig

__all__ = [
    "METHODS",
    "SB3_METHODS",
    "BudgetConfig",
    "CnnConfig",
    "PpoConfig",
    "Td3Config",
    "RecurrentPpoConfig",
    "NeatConfig",
    "KeepConfig",
    "KukaBaselineConfig",
]

METHODS = ("ppo", "td3", "neat", "random", "zero", "recurrent_ppo")
"""The Kuka baselines of SPEC §4."""

SB3_METHODS = ("ppo", "td3", "recurrent_ppo")
"""The methods trained by Stable-Baselines3 (sb3-contrib) in steps, not generations."""

Method = Literal["ppo", "td3", "neat", "random", "zero", "recurrent_ppo"]


def _positive(key: str, value: float | None) -> None:
    if value is not None and not value > 0:
        raise ConfigError(f"{key}={value!r} must be > 0")


@dataclass
class BudgetConfig:
    """The training budget (SPEC §4: the same for every method, stated in the table)."""

    env_steps: int | None = doc(
        None,
        "environment steps of training (null: PPO/TD3 use default_env_steps, NEAT its generations)",
    )
    minutes: float | None = doc(None, "wall-clock minutes of training (null: no time limit)")
    default_env_steps: int = doc(
        13_500,
        "PPO/TD3 steps when neither env_steps nor minutes is set: a full GRN run "
        "(12 genomes x 15 generations x 10 episodes x ~7.5 steps)",
    )
    target_success: float = doc(
        0.5, "success whose first reach during training is the 'time to target' of the table"
    )
    eval_every_steps: int = doc(
        1_000, "PPO/TD3: env steps between success estimates on training objects (EvalCallback)"
    )
    eval_episodes: int = doc(10, "PPO/TD3: episodes of each success estimate during training")
    checkpoint_every_steps: int = doc(1_000, "PPO/TD3: env steps between checkpoints")

    def validate(self) -> None:
        _positive("env_steps", self.env_steps)
        _positive("minutes", self.minutes)
        _positive("default_env_steps", self.default_env_steps)
        if not 0.0 <= self.target_success <= 1.0:
            raise ConfigError(f"target_success={self.target_success!r} must lie in [0, 1]")
        _positive("eval_every_steps", self.eval_every_steps)
        _positive("eval_episodes", self.eval_episodes)
        _positive("checkpoint_every_steps", self.checkpoint_every_steps)


@dataclass
class CnnConfig:
    """The image encoder of an SB3 policy (Table 4.1 'Architecture'), trained with it."""

    channels: list[int] = doc([16, 32, 32], "conv channels; kernels 8/4/3, strides 4/2/1")
    features_dim: int = doc(128, "linear layer after the convolutions (features of the heads)")

    def validate(self) -> None:
        if not 1 <= len(self.channels) <= 3 or any(c < 1 for c in self.channels):
            raise ConfigError(f"channels={self.channels!r} must hold 1 to 3 positive counts")
        _positive("features_dim", self.features_dim)


@dataclass
class PpoConfig:
    """PPO of Stable-Baselines3 with a CNN policy on the 48x48 image (Table 4.1 values)."""

    learning_rate: float = doc(2e-4, "Adam learning rate (Table 4.1: 2e-4)")
    gamma: float = doc(0.993, "discount (Table 4.1: 0.993)")
    ent_coef: float = doc(0.01, "entropy coefficient beta (Table 4.1: 0.01)")
    clip_range: float = doc(0.07, "clip epsilon (Table 4.1: 0.07)")
    n_steps: int = doc(512, "env steps per rollout (not in the thesis)")
    batch_size: int = doc(64, "minibatch size (not in the thesis; SB3 default)")
    n_epochs: int = doc(10, "epochs per rollout (not in the thesis; SB3 default)")
    gae_lambda: float = doc(0.95, "GAE lambda (not in the thesis; SB3 default)")
    cnn: CnnConfig = field(default_factory=CnnConfig)
    net_arch: list[int] = doc([64], "hidden layers of the policy and value heads (Table 4.1: 64)")
    encoder: str = doc(
        "image",
        "what the policy reads: image (the 48x48 camera image through the trained CNN, Table "
        "4.1) or blob (the vision preset's 4 image-only object-localising features, an MLP "
        "policy)",
    )

    def sb3_kwargs(self) -> dict[str, Any]:
        """The PPO hyper-parameters as Stable-Baselines3's (and sb3-contrib's) keywords."""
        return {
            "learning_rate": self.learning_rate,
            "n_steps": self.n_steps,
            "batch_size": self.batch_size,
            "n_epochs": self.n_epochs,
            "gamma": self.gamma,
            "gae_lambda": self.gae_lambda,
            "clip_range": self.clip_range,
            "ent_coef": self.ent_coef,
        }

    def validate(self) -> None:
        for key in ("learning_rate", "clip_range", "n_steps", "batch_size", "n_epochs"):
            _positive(key, getattr(self, key))
        if not 0.0 < self.gamma <= 1.0:
            raise ConfigError(f"gamma={self.gamma!r} must lie in (0, 1]")
        if self.ent_coef < 0:
            raise ConfigError(f"ent_coef={self.ent_coef!r} must be >= 0")
        if self.n_steps < 2:
            raise ConfigError(f"n_steps={self.n_steps!r} must be >= 2 (SB3 normalises advantages)")
        if self.encoder not in ("image", "blob"):
            raise ConfigError(f"ppo.encoder={self.encoder!r} must be image or blob")


@dataclass
class Td3Config:
    """TD3 of Stable-Baselines3 with a CNN policy on the 48x48 image (Table 4.1 values)."""

    buffer_size: int = doc(50_000, "replay buffer transitions (Table 4.1: 50K)")
    batch_size: int = doc(128, "minibatch size (Table 4.1: 128)")
    actor_lr: float = doc(1e-4, "actor Adam learning rate (Table 4.1: 1e-4)")
    critic_lr: float = doc(1e-3, "critic Adam learning rate (Table 4.1: 1e-3)")
    gamma: float = doc(0.99, "discount (not in the thesis; SB3 default)")
    tau: float = doc(0.005, "target-network soft update (not in the thesis; SB3 default)")
    learning_starts: int = doc(500, "random-action steps before learning (not in the thesis)")
    action_noise: float = doc(0.1, "std of the Gaussian exploration noise on actions")
    train_freq: int = doc(1, "env steps between gradient phases")
    gradient_steps: int = doc(1, "gradient steps per phase")
    cnn: CnnConfig = field(default_factory=lambda: CnnConfig(channels=[16, 32], features_dim=256))
    net_arch: list[int] = doc([256, 256], "hidden layers of actor and critics (Table 4.1)")

    def validate(self) -> None:
        for key in ("buffer_size", "batch_size", "actor_lr", "critic_lr", "tau", "train_freq"):
            _positive(key, getattr(self, key))
        if not 0.0 < self.gamma <= 1.0:
            raise ConfigError(f"gamma={self.gamma!r} must lie in (0, 1]")
        if self.learning_starts < 0 or self.action_noise < 0 or self.gradient_steps < 1:
            raise ConfigError("learning_starts and action_noise must be >= 0, gradient_steps >= 1")


@dataclass
class RecurrentPpoConfig:
    """RecurrentPPO of sb3-contrib (``method: recurrent_ppo``; baselines/recurrent_ppo.py): PPO
    with an LSTM in the actor and the critic, on the blob front-end's 4 features. Its PPO
    settings (learning rate, gamma, n_steps, batch_size, net_arch, ...) are section ppo's."""

    lstm_hidden_size: int = doc(64, "units of each LSTM (as many as the PPO heads' hidden layer)")
    n_lstm_layers: int = doc(1, "stacked LSTM layers")
    shared_lstm: bool = doc(
        False,
        "one LSTM shared by actor and critic (false: each has its own, sb3-contrib's default)",
    )

    def validate(self) -> None:
        _positive("lstm_hidden_size", self.lstm_hidden_size)
        _positive("n_lstm_layers", self.n_lstm_layers)


@dataclass
class NeatConfig:
    """NEAT of neat-python on the 128 encoder features (Table 4.1 values)."""

    population: int = doc(12, "genomes per generation (Table 4.1: 12)")
    generations: int = doc(15, "generations when no env-step or time budget is given (15)")
    weight_mutate_rate: float = doc(0.8, "probability that a weight mutates (Table 4.1: 80 %)")
    weight_mutate_power: float = doc(0.5, "std of a weight mutation (neat-python example value)")
    conn_add_prob: float = doc(0.5, "probability of adding a connection per offspring")
    node_add_prob: float = doc(0.2, "probability of adding a node per offspring")
    initial_connection: str = doc(
        "full_direct", "neat-python initial_connection (inputs wired straight to the outputs)"
    )
    compatibility_threshold: float = doc(3.0, "species compatibility threshold")
    elitism: int = doc(2, "genomes per species passed on unchanged")
    episodes: int = doc(10, "episodes per genome per generation (as the GRN)")
    noisy_fraction: float = doc(
        0.0,
        "fraction of episodes with N(0, evaluation.visual_noise^2) on every one of the 128 "
        "features; 0 because the GRN's noise hits 4 unit-scale values, these are ~0.09 each",
    )
    encoder: str = doc(
        "cnn",
        "visual front-end the networks read: cnn (the thesis' 128 random-CNN features) or blob "
        "(the vision preset's 4 image-only object-localising features)",
    )

    def validate(self) -> None:
        if self.population < 2:
            raise ConfigError(f"population={self.population!r} must be >= 2")
        _positive("generations", self.generations)
        _positive("episodes", self.episodes)
        from evodevo.grn.frontends import FRONTENDS

        if self.encoder not in FRONTENDS:
            raise ConfigError(
                f"neat.encoder={self.encoder!r} is not a front-end; choose one of {list(FRONTENDS)}"
            )
        for key in ("weight_mutate_rate", "conn_add_prob", "node_add_prob", "noisy_fraction"):
            value = getattr(self, key)
            if not 0.0 <= value <= 1.0:
                raise ConfigError(f"{key}={value!r} must lie in [0, 1]")
        if self.elitism < 0:
            raise ConfigError(f"elitism={self.elitism!r} must be >= 0")


@dataclass
class KeepConfig:
    """Which model a trained baseline returns (SPEC §6: one rule per table; evodevo.grn.return_rule)."""

    rule: str = doc(
        "last",
        "last (NEAT: the last generation's best; PPO/TD3: the final model; the thesis) or "
        "validated (candidates: NEAT every generation's best by training fitness, PPO/TD3 a "
        "snapshot every every_steps env steps and the final model; the run returns the one with "
        "the most successes on evaluation.validation_episodes clean training-object episodes "
        "from evaluation.validation_seed, the later on a tie; not training budget)",
    )
    candidates: int = doc(
        15,
        "PPO/TD3: snapshots spread evenly over the env-step budget, one every "
        "ceil(steps / candidates) env steps (15: as many as the GRN's and NEAT's generations)",
    )
    every_steps: int | None = doc(
        None,
        "PPO/TD3: env steps between snapshots instead (null: from candidates; needed with a "
        "wall-clock budget alone)",
    )

    def validate(self) -> None:
        if self.rule not in ("last", "validated"):
            raise ConfigError(f"keep.rule must be one of ['last', 'validated'], got {self.rule!r}")
        _positive("candidates", self.candidates)
        _positive("every_steps", self.every_steps)


@dataclass
class KukaBaselineConfig:
    """Everything a Kuka baseline run needs (SPEC §4). Saved in ``config.json`` of the run."""

    method: Method = doc("ppo", "ppo | td3 | neat | random | zero | recurrent_ppo")
    seed: int = doc(0, "run seed (SB3 seed=, NEAT population seed, encoder, episode seeds)")
    budget: BudgetConfig = field(default_factory=BudgetConfig)
    ppo: PpoConfig = field(default_factory=PpoConfig)
    td3: Td3Config = field(default_factory=Td3Config)
    recurrent_ppo: RecurrentPpoConfig = field(default_factory=RecurrentPpoConfig)
    neat: NeatConfig = field(default_factory=NeatConfig)
    keep: KeepConfig = field(default_factory=KeepConfig)
    env: EnvConfig = field(default_factory=EnvConfig)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)

    def validate(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"method={self.method!r} is not known; choose one of {list(METHODS)}")
        snapshots = self.keep.rule == "validated" and self.method in SB3_METHODS
        no_steps = self.budget.env_steps is None and self.budget.minutes is not None
        if snapshots and no_steps and self.keep.every_steps is None:
            raise ConfigError(
                "keep.rule=validated with a wall-clock budget only needs keep.every_steps "
                "(env steps between candidates); set it, or give budget.env_steps"
            )

    def evaluator_config(self) -> GrnConfig:
        """The config the GRN :class:`~evodevo.grn.evaluator.Evaluator` runs this baseline with.

        Same ``env`` and ``evaluation`` sections (so the same test seeds as a GRN run); the
        controller is the baseline's policy (:data:`CONTROLLERS`); NEAT's front-end is
        ``neat.encoder``, PPO's ``ppo.encoder`` (``sensors.encoder`` "blob" when it is),
        RecurrentPPO's always "blob".
        """
        from evodevo.grn.frontends import frontend_dim

        encoder = {"neat": self.neat.encoder, "ppo": self.ppo.encoder, "recurrent_ppo": "blob"}.get(
            self.method, "cnn"
        )
        encoder = "cnn" if encoder == "image" else encoder  # SB3's own CNN: no GRN front-end
        return GrnConfig(
            seed=self.seed,
            controller=CONTROLLERS[self.method],
            sensors=SensorConfig(encoder=encoder, feature_dim=frontend_dim(encoder)),
            env=self.env,
            evaluation=self.evaluation,
        )


CONTROLLERS = {
    "ppo": "sb3",
    "td3": "sb3",
    "neat": "neat",
    "zero": "zero",
    "random": "random",
    "recurrent_ppo": "recurrent_ppo",
}
"""Controller (evaluator policy) of each method: a kind of :mod:`evodevo.grn.controller`,
registered by :mod:`evodevo.baselines` (``sb3``, ``neat``, ``recurrent_ppo``) or by the GRN
package itself (``zero``, ``random``)."""

__all__ += ["CONTROLLERS"]
