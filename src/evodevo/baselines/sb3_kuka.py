"""PPO and TD3 of Stable-Baselines3 on the Kuka image (SPEC §4, thesis Table 4.1).

Nothing here is an RL algorithm: SB3's PPO and TD3 learn, SB3's callbacks add the rest. The
same loop trains sb3-contrib's RecurrentPPO (:mod:`evodevo.baselines.recurrent_ppo`).

* :class:`~evodevo.baselines.kuka_cnn.KukaCnn` — the Table 4.1 image encoder (Conv
  3→16→32(→32), a linear layer), trained with the policy (SB3 scales the uint8 image to [0, 1]
  and moves channels first).
* :class:`Td3TwoRates` — SB3's TD3 with the thesis' two learning rates (actor 1e-4, critic 1e-3):
  only the learning-rate update is overridden.
* Callbacks (:mod:`evodevo.baselines.sb3_callbacks`): SB3's :class:`~stable_baselines3.common.callbacks.EvalCallback` (success on
  training objects every ``budget.eval_every_steps``, timed so training time excludes it),
  :class:`~evodevo.baselines.sb3_files.SafeCheckpointCallback` (SB3's checkpoint callback
  writing the model, and TD3's replay buffer, without pickle), :class:`ClockCallback` (training time of each checkpoint, older checkpoints pruned),
  :class:`BudgetCallback` (stops at the env-step or wall-clock budget) and, with
  ``keep.rule: validated``, :class:`ValidationCallback` (a candidate snapshot every ``N`` env
  steps scored on the validation episodes by the GRN's evaluator, :mod:`evodevo.grn.return_rule`).

:func:`train_sb3` writes ``model.safetensors``, ``learning_curve.csv`` (env steps, training
seconds, success), ``summary.json`` and ``checkpoints/`` (with ``keep.rule: validated`` also
``validation.csv`` and ``last_model.safetensors``, the final model, while ``model.safetensors`` is
the kept candidate); with ``resume`` it continues from the last checkpoint: the model is built from the run's config and its weights, optimiser states and
counters are loaded (:mod:`evodevo.baselines.sb3_files`; no pickle is read), and training goes on
from a reset environment.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3 import PPO, TD3
from stable_baselines3.common.callbacks import CallbackList
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.vec_env import DummyVecEnv, VecTransposeImage

from evodevo.baselines.feature_env import FeatureObservation
from evodevo.baselines.kuka_cnn import KukaCnn
from evodevo.baselines.kuka_config import CnnConfig, KukaBaselineConfig
from evodevo.baselines.policies import blob_frontend
from evodevo.baselines.recurrent_ppo import build_recurrent_ppo
from evodevo.baselines.sb3_callbacks import (
    CANDIDATE_PREFIX,
    CKPT_PREFIX,
    CLOCK_FILE,
    CURVE_FIELDS,
    BudgetCallback,
    ClockCallback,
    StepsCallback,
    TimedEvalCallback,
    TrainClock,
    ValidationCallback,
    checkpoint_steps,
    write_clock,
)
from evodevo.baselines.sb3_files import (
    MODEL_SUFFIX,
    SafeCheckpointCallback,
    load_replay_buffer,
    restore_sb3,
    save_sb3,
)
from evodevo.callbacks import Callback
from evodevo.callbacks import CallbackList as RunCallbacks
from evodevo.errors import EvodevoError
from evodevo.grn.evaluator import Evaluator, make_env
from evodevo.grn.return_rule import STATE_FILE as VALIDATION_FILE
from evodevo.grn.return_rule import VALIDATED, ValidatedBest, candidate_every, summary_fields
from evodevo.runs import RunDir, atomic_write_bytes, machine_info, read_json, write_json
from evodevo.safe_io import refuse_legacy
from evodevo.seeding import derive

__all__ = [
    "KukaCnn",
    "Td3TwoRates",
    "TrainClock",
    "BudgetCallback",
    "TimedEvalCallback",
    "ClockCallback",
    "StepsCallback",
    "ValidationCallback",
    "train_sb3",
    "CURVE_FIELDS",
    "MODEL_FILE",
]

EVAL_ENV_KEY = 11
"""Seed stream of the training-time success estimates (EvalCallback's env)."""
MODEL_FILE = f"model{MODEL_SUFFIX}"
"""The returned model of a PPO/TD3 run (:func:`evodevo.baselines.sb3_files.save_sb3`)."""
LAST_MODEL_FILE = f"last_model{MODEL_SUFFIX}"
"""``keep.rule: validated``: the final model, beside the kept candidate in :data:`MODEL_FILE`."""
_LEGACY = (f"{CKPT_PREFIX}_*_steps.zip", f"{CKPT_PREFIX}_replay_buffer_*_steps.pkl")
REFILLS_FILE = "refills.json"
_UNLIMITED_STEPS = 10**12


class Td3TwoRates(TD3):
    """SB3's TD3 with separate actor and critic learning rates (Table 4.1).

    Args:
        actor_lr: actor Adam learning rate.
        critic_lr: critic Adam learning rate.
        *args: those of :class:`stable_baselines3.TD3`.
        **kwargs: those of :class:`stable_baselines3.TD3`.
    """

    def __init__(self, *args: Any, actor_lr: float = 1e-4, critic_lr: float = 1e-3, **kwargs: Any):
        self.actor_lr = float(actor_lr)
        self.critic_lr = float(critic_lr)
        super().__init__(*args, **kwargs)

    def _update_learning_rate(self, optimizers: Any) -> None:
        self.logger.record("train/actor_lr", self.actor_lr)
        self.logger.record("train/critic_lr", self.critic_lr)
        for opt, lr in (
            (self.actor.optimizer, self.actor_lr),
            (self.critic.optimizer, self.critic_lr),
        ):
            for group in opt.param_groups:
                group["lr"] = lr


def _vec_env(cfg: KukaBaselineConfig) -> VecTransposeImage | DummyVecEnv:
    env = make_env(cfg.env.id, cfg.env.kwargs, test_objects=False)
    if uses_blob(cfg):  # the vision preset's features, not the image
        wrapped = FeatureObservation(env, blob_frontend(cfg.env.id, dict(cfg.env.kwargs)))
        return DummyVecEnv([lambda: Monitor(wrapped)])
    return VecTransposeImage(DummyVecEnv([lambda: Monitor(env)]))


def uses_blob(cfg: KukaBaselineConfig) -> bool:
    """Whether this SB3 run reads the blob front-end's features (``ppo.encoder: blob``;
    RecurrentPPO always)."""
    return cfg.method == "recurrent_ppo" or (cfg.method == "ppo" and cfg.ppo.encoder == "blob")


def _policy_kwargs(cnn: CnnConfig, net_arch: list[int]) -> dict[str, Any]:
    return {
        "features_extractor_class": KukaCnn,
        "features_extractor_kwargs": {
            "channels": list(cnn.channels),
            "features_dim": cnn.features_dim,
        },
        "net_arch": list(net_arch),
    }


def build_model(cfg: KukaBaselineConfig, env: Any) -> Any:
    """A fresh PPO or TD3 model for ``cfg`` (seeded by SB3's ``seed=``)."""
    if cfg.method == "ppo":
        p = cfg.ppo
        blob = uses_blob(cfg)
        return PPO(
            "MlpPolicy" if blob else "CnnPolicy",
            env,
            **p.sb3_kwargs(),
            policy_kwargs={"net_arch": list(p.net_arch)}
            if blob
            else _policy_kwargs(p.cnn, p.net_arch),
            seed=cfg.seed,
            device="cpu",
            verbose=0,
        )
    if cfg.method == "td3":
        t = cfg.td3
        n_act = int(env.action_space.shape[0])
        return Td3TwoRates(
            "CnnPolicy",
            env,
            actor_lr=t.actor_lr,
            critic_lr=t.critic_lr,
            learning_rate=t.critic_lr,
            buffer_size=t.buffer_size,
            learning_starts=t.learning_starts,
            batch_size=t.batch_size,
            tau=t.tau,
            gamma=t.gamma,
            train_freq=t.train_freq,
            gradient_steps=t.gradient_steps,
            action_noise=NormalActionNoise(np.zeros(n_act), t.action_noise * np.ones(n_act)),
            optimize_memory_usage=False,
            policy_kwargs=_policy_kwargs(t.cnn, t.net_arch),
            seed=cfg.seed,
            device="cpu",
            verbose=0,
        )
    if cfg.method == "recurrent_ppo":
        return build_recurrent_ppo(cfg, env)
    raise EvodevoError(
        f"method {cfg.method!r} is not an SB3 baseline; use ppo, td3 or recurrent_ppo"
    )


def _resume_state(
    run: RunDir, cfg: KukaBaselineConfig, env: Any
) -> tuple[Any, TrainClock, list[dict[str, Any]]]:
    folder = run.path / "checkpoints"
    steps = checkpoint_steps(folder) if folder.is_dir() else []
    if not steps:
        raise EvodevoError(
            f"--resume: {str(folder)!r} holds no checkpoint yet; start the run again without --resume"
        )
    last = steps[-1]
    model = build_model(cfg, env)
    restore_sb3(model, folder / f"{CKPT_PREFIX}_{last}_steps{MODEL_SUFFIX}")
    buffer = folder / f"{CKPT_PREFIX}_replay_buffer_{last}_steps.npz"
    if cfg.method == "td3":
        if buffer.is_file():
            load_replay_buffer(model, buffer)
        else:
            refill_replay_buffer(model, folder, cfg.td3.learning_starts)
    clocks = read_json(folder / CLOCK_FILE) if (folder / CLOCK_FILE).is_file() else {}
    known = [int(k) for k in clocks if int(k) <= last]
    entry = clocks[str(max(known))] if known else {"train_s": 0.0, "eval_s": 0.0}
    clock = TrainClock(offset_s=float(entry["train_s"]))
    rows: list[dict[str, Any]] = []
    if (run.path / "learning_curve.csv").is_file():
        rows = [
            {
                k: float(v) if k in ("train_s", "success", "mean_reward") else int(float(v))
                for k, v in r.items()
            }
            for r in run.read_csv("learning_curve.csv")
            if int(float(r["env_steps"])) <= last
        ]
    return model, clock, rows


def refill_replay_buffer(model: Any, folder: Path, warmup_steps: int) -> None:
    """Continue a TD3 checkpoint whose replay buffer is gone (never committed: ~0.7 GB).

    The buffer starts empty and SB3 refills it exactly as at the start of a run: for
    ``warmup_steps`` (``td3.learning_starts``) env steps it takes uniform random actions and
    makes no gradient update; then training goes on from the checkpoint's networks. This is a
    deviation from an uninterrupted run, so it is announced and recorded: the step counts at
    which it happened go to ``checkpoints/refills.json`` and the summary's
    ``replay_buffer_refilled_at``, and the report names them.
    """
    steps = int(model.num_timesteps)
    model.learning_starts = steps + int(warmup_steps)
    write_json(folder / REFILLS_FILE, sorted(set(buffer_refills(folder)) | {steps}))
    print(
        f"warning: the replay buffer of the {steps}-step checkpoint in {str(folder)!r} is "
        f"missing; TD3 continues with an empty buffer refilled by {warmup_steps} random-action "
        "steps (recorded as replay_buffer_refilled_at in summary.json)",
        file=sys.stderr,
    )


def buffer_refills(folder: Path) -> list[int]:
    """Env steps at which a resumed TD3 run refilled a lost replay buffer (ascending)."""
    path = folder / REFILLS_FILE
    return sorted(int(x) for x in read_json(path)) if path.is_file() else []


@dataclass
class _Limits:
    """A run's budget and, with ``keep.rule: validated``, its candidates' spacing."""

    max_steps: int | None
    """Env steps (None: no step budget)."""
    max_s: float | None
    """Training seconds (None: no time budget)."""
    every: int
    """Env steps between validated candidates (0: ``keep.rule`` is not ``validated``)."""


def _limits(cfg: KukaBaselineConfig) -> _Limits:
    b = cfg.budget
    max_steps = (
        b.env_steps if b.env_steps is not None else (None if b.minutes else b.default_env_steps)
    )
    max_s = b.minutes * 60.0 if b.minutes is not None else None
    every = (
        candidate_every(max_steps, cfg.keep.candidates, cfg.keep.every_steps)
        if cfg.keep.rule == VALIDATED
        else 0
    )
    return _Limits(max_steps, max_s, every)


@dataclass
class _Trained:
    """What a training session leaves for ``summary.json``."""

    env_steps: int
    train_s: float
    eval_s: float
    rows: list[dict[str, Any]]
    stopped_by: str
    keeper: ValidatedBest | None


def train_sb3(
    cfg: KukaBaselineConfig,
    run: RunDir,
    resume: bool = False,
    quiet: bool = False,
    callback: Callback | None = None,
) -> dict[str, Any]:
    """Train PPO or TD3 per ``cfg`` in run directory ``run``; returns ``summary.json``'s dict.

    ``callback`` hears the env steps after every step and every ``learning_curve.csv`` row.
    """
    run_cb: Callback = callback if callback is not None else RunCallbacks()
    run_cb.init(run)
    if resume:  # a pickle-based checkpoint is refused unopened, not silently started over
        refuse_legacy(run.path / "checkpoints", *_LEGACY)
    limits = _limits(cfg)
    env = _vec_env(cfg)
    eval_env = _vec_env(cfg)
    eval_env.seed(derive(cfg.seed, EVAL_ENV_KEY))
    folder = run.checkpoints
    scorer = Evaluator(cfg.evaluator_config(), None) if cfg.keep.rule == VALIDATED else None
    try:
        # A run killed before its first checkpoint has nothing to continue: start it.
        resume = resume and bool(checkpoint_steps(folder) if folder.is_dir() else [])
        done = _train(cfg, run, (env, eval_env), scorer, limits, resume, quiet, run_cb)
    finally:
        env.close()
        eval_env.close()
        if scorer is not None:
            scorer.close()
    summary = summarise(cfg, done.env_steps, done.train_s, done.eval_s, done.rows, done.stopped_by)
    summary |= summary_fields(cfg.keep.rule, done.keeper)
    if refills := buffer_refills(folder):
        summary["replay_buffer_refilled_at"] = refills
    run.write_summary(summary)
    return summary


def _train(
    cfg: KukaBaselineConfig,
    run: RunDir,
    envs: tuple[Any, Any],
    scorer: Evaluator | None,
    limits: _Limits,
    resume: bool,
    quiet: bool,
    run_cb: Callback,
) -> _Trained:
    """One session: build or restore the model, learn to the budget, save the returned model.

    ``envs`` are the training env and EvalCallback's; ``scorer`` scores the validated
    candidates (None without ``keep.rule: validated``).
    """
    env, eval_env = envs
    folder = run.checkpoints
    if resume:
        model, clock, rows = _resume_state(run, cfg, env)
    else:
        model, clock, rows = build_model(cfg, env), TrainClock(), []
    # SB3's default logger creates an empty /tmp/SB3-<date> folder on every learn();
    # ours records nothing outside the run directory.
    model.set_logger(Logger(folder=None, output_formats=[]))
    done_steps = int(model.num_timesteps)
    validator: ValidationCallback | None = None
    if scorer is not None:
        keeper = _keeper(cfg, folder, done_steps)
        validator = ValidationCallback(keeper, scorer, limits.every, clock, run, cfg.method)
    evaluator, budget, callbacks = _callbacks(
        cfg, run, eval_env, clock, rows, validator, limits, quiet, run_cb
    )
    run_cb.on_steps(done_steps)
    remaining = (
        (limits.max_steps - done_steps) if limits.max_steps is not None else _UNLIMITED_STEPS
    )
    clock.begin()
    if remaining > 0 and (limits.max_s is None or clock.train_s < limits.max_s):
        model.learn(remaining, callback=callbacks, reset_num_timesteps=not resume)
    train_s = clock.train_s
    if validator is not None:
        validator.candidate(model)  # the final model is the last candidate
        save_sb3(model, run / LAST_MODEL_FILE)
        _return_kept(validator.keeper, folder, run / MODEL_FILE)
    else:
        save_sb3(model, run / MODEL_FILE)
    write_clock(folder, model.num_timesteps, clock)
    keeper_out = validator.keeper if validator else None
    return _Trained(
        int(model.num_timesteps),
        train_s,
        clock.eval_s,
        evaluator.rows,
        budget.stopped_by,
        keeper_out,
    )


def _callbacks(
    cfg: KukaBaselineConfig,
    run: RunDir,
    eval_env: Any,
    clock: TrainClock,
    rows: list[dict[str, Any]],
    validator: ValidationCallback | None,
    limits: _Limits,
    quiet: bool,
    run_cb: Callback,
) -> tuple[TimedEvalCallback, BudgetCallback, CallbackList]:
    """SB3's callbacks of a session, in the order they run, and the two read after it.

    ``rows``: the learning curve so far (a resumed run's).
    """
    b = cfg.budget
    evaluator = TimedEvalCallback(
        eval_env,
        clock,
        run,
        quiet,
        run_cb,
        n_eval_episodes=b.eval_episodes,
        eval_freq=b.eval_every_steps,
        deterministic=True,
        verbose=0,
        warn=False,
    )
    evaluator.rows = rows
    budget = BudgetCallback(clock, limits.max_steps, limits.max_s)
    callbacks = CallbackList(
        [
            *([validator] if validator is not None else []),  # before the checkpoint
            SafeCheckpointCallback(
                b.checkpoint_every_steps,
                str(run.checkpoints),
                name_prefix=CKPT_PREFIX,
                save_replay_buffer=cfg.method == "td3",
            ),
            ClockCallback(clock, b.checkpoint_every_steps, run.checkpoints),
            evaluator,
            budget,
            StepsCallback(run_cb),
        ]
    )
    return evaluator, budget, callbacks


def _keeper(cfg: KukaBaselineConfig, folder: Path, upto: int) -> ValidatedBest:
    """The validation state of a run continuing from env step ``upto`` (0: a fresh start).

    Candidates after ``upto`` are dropped (they are validated again), with their files.
    """
    v = cfg.evaluation
    keeper = ValidatedBest.load(
        folder / VALIDATION_FILE, v.validation_seed, v.validation_episodes, "env_steps", upto
    )
    keep = {str(state["file"]) for _, state in keeper.kept}
    for path in folder.glob(f"{CANDIDATE_PREFIX}_*_steps{MODEL_SUFFIX}"):
        if path.name not in keep:
            path.unlink()
    return keeper


def _return_kept(keeper: ValidatedBest, folder: Path, out: Path) -> None:
    """Copy the kept candidate's file to ``out`` (the returned model); drop superseded ones."""
    for state in keeper.prune():
        (folder / str(state["file"])).unlink(missing_ok=True)
    keeper.save(folder / VALIDATION_FILE)
    kept = keeper.best_state
    if kept is None:  # pragma: no cover - the final model is always a candidate
        raise EvodevoError("keep.rule=validated: no candidate was validated")
    atomic_write_bytes(out, (folder / str(kept["file"])).read_bytes())


def first_reach(rows: list[dict[str, Any]], target: float) -> tuple[float | None, int | None]:
    """Training seconds and env steps at which ``success`` first reached ``target``."""
    for r in rows:
        if float(r["success"]) >= target:
            return float(r["train_s"]), int(r["env_steps"])
    return None, None


def summarise(
    cfg: KukaBaselineConfig,
    env_steps: int,
    train_s: float,
    eval_s: float,
    rows: list[dict[str, Any]],
    stopped_by: str,
) -> dict[str, Any]:
    """The ``summary.json`` of a baseline run (shared by every method)."""
    t_s, t_steps = first_reach(rows, cfg.budget.target_success)
    return {
        "kind": "baseline_kuka",
        "method": cfg.method,
        "seed": cfg.seed,
        "env_steps": int(env_steps),
        "wall_s": float(train_s),
        "eval_wall_s": float(eval_s),
        "stopped_by": stopped_by,
        "target_success": cfg.budget.target_success,
        "time_to_target_s": t_s,
        "steps_to_target": t_steps,
        "success_history": [float(r["success"]) for r in rows],
        "best_training_success": max((float(r["success"]) for r in rows), default=None),
        "budget": {"env_steps": cfg.budget.env_steps, "minutes": cfg.budget.minutes},
        "machine": machine_info(),
    }
