"""Stable-Baselines3 DQN, one fresh model per task: the ``sb3-dqn`` BIARM baseline.

What a standard library gets on the task sequence of SPEC §1 without any continual-learning
machinery: for every task a new :class:`stable_baselines3.DQN` is built and trained on that
task alone, then evaluated greedily with the fixed evaluation seeds of SPEC §1.7 right after
its task ("initial") and, reloaded from its saved file, after the whole sequence ("final").
Nothing is shared between tasks, so **retention is 1.0 by construction** (deterministic
environments, fixed seeds, an unchanged model); the baseline is there for the final returns
each task reaches, not for forgetting.

Settings (SPEC §1.6, the ``dqn`` section of the run config; the same for every variant):

* network: SB3's ``MlpPolicy`` with ``net_arch=[hidden, hidden]`` ReLU (2x128) on the task's
  own observation (a model per task needs no padding), SB3's default initialisation;
* Adam at ``dqn.lr`` (1e-3), batch ``dqn.batch_size`` (64), buffer ``dqn.replay_size``
  (10,000), ``learning_starts`` ``dqn.learning_starts``, one gradient step per environment
  step, gamma ``dqn.gamma`` (0.99), Huber loss (SB3's smooth L1), gradient-norm clip
  ``dqn.grad_clip`` (10), hard target update every ``dqn.target_update`` (500) environment
  steps (SB3 counts environment steps, our trainer gradient steps: they differ by the
  ``learning_starts`` warm-up only); truncated episodes bootstrap (SB3's
  ``handle_timeout_termination``);
* exploration exactly as SPEC §1.6: epsilon starts at ``dqn.eps_start`` and is multiplied by
  ``dqn.eps_decay`` after each environment step (``dqn.eps_unit: step``) or each episode
  (``episode``, the v1 protocol), floor ``dqn.eps_min``. SB3's own schedule is linear in
  the fraction of ``total_timesteps``; we replace ``model.exploration_schedule`` by
  :class:`EpisodeEpsilon`, which the callback decays. (Before ``learning_starts`` SB3
  acts uniformly at random, as our trainer does with epsilon 1.)
* the closest SB3 settings to the rest of the protocol: ``dqn.target_mode: soft`` is SB3's
  ``tau`` with ``target_update_interval=1`` (a Polyak update every environment step, ours every
  gradient step: the same after ``learning_starts``); ``hard`` is ``tau=1`` every
  ``dqn.target_update`` steps; ``dqn.train_every`` is SB3's ``train_freq`` (and scales the
  target interval, which SB3 counts in environment steps). SB3's DQN has no double Q-learning: with ``dqn.double_q`` the
  baseline still uses the plain max target (its summary says ``sb3_double_q: false``).
  ``dqn.keep: best`` validates the model every ``eval.validation_every`` episodes and after the
  last on the validation seeds, as SB3's ``EvalCallback`` does, and the task keeps the best
  policy parameters (:class:`~evodevo.neuromod.keep_best.BestColumn`'s rule).
* budget: the task's episode count (after ``episodes_scale``); :class:`TaskCallback` stops
  ``learn`` when it is reached (``total_timesteps`` is only an upper bound).

Run files are those of :func:`evodevo.neuromod.trainer.train`: ``config.json``,
``metrics.csv`` (one row per episode), ``neuromod.csv`` (no modules: blank states, the novelty
``n_task`` and the constant learning rate, every ``modules.sample_interval`` steps),
``summary.json`` with the same keys, plus ``checkpoints/sb3_task{i}.safetensors`` (the model
without pickle, :mod:`evodevo.baselines.sb3_files`; reloaded as its policy, whose ``predict`` is
the model's) and ``checkpoints/sb3_progress.json`` after every task. ``--resume`` continues after
the last finished task; an interrupted task is re-run from its start, which gives the same
numbers because each task is seeded on its own. The summary's ``wall_seconds`` and
``cpu_seconds`` are summed over the sessions (:class:`evodevo.run_clock.RunClock`; the progress
file carries them); summaries written before 2026-12-06 hold the wall time only.

Seeding: SB3 draws from the global ``random``/NumPy/torch generators (exploration, replay
sampling, initialisation) and seeds them itself (``seed=``). To keep library code free of
global RNG side effects, each task's construction and training run inside
:func:`scoped_global_rng`, which saves the three global states, lets SB3 seed them from
``derive(seed, 6, i)`` and restores them afterwards. SB3's logger is replaced by one with no
output formats, so nothing is written to ``/tmp`` (its default ``SB3-<date>`` folders) or the
working directory.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any, cast

import numpy as np
import stable_baselines3
import torch
from stable_baselines3 import DQN
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import Logger

from evodevo.baselines.sb3_files import MODEL_SUFFIX, load_sb3_policy, save_sb3
from evodevo.callbacks import Callback
from evodevo.neuromod.config import MODULE_NAMES, BiarmConfig
from evodevo.neuromod.evaluation import eval_seeds, greedy_returns, task_record
from evodevo.neuromod.keep_best import BestColumn
from evodevo.neuromod.resume import open_run
from evodevo.neuromod.tasks import TaskSpec, make_env, resolve_tasks
from evodevo.neuromod.trainer import METRIC_FIELDS, NEUROMOD_FIELDS, EpisodeInfo, resume_hint
from evodevo.neuromod.variants import Variant
from evodevo.run_clock import RunClock
from evodevo.runs import CsvAppender, RunDir, read_json, write_json
from evodevo.seeding import derive
from evodevo.signals import GracefulStop

__all__ = [
    "EpisodeEpsilon",
    "TaskCallback",
    "scoped_global_rng",
    "build_dqn",
    "evaluate_model",
    "train_sb3_tasks",
    "PROGRESS_FILE",
]

#: Key of the per-task SB3 seed: ``derive(seed, SB3_SEED_KEY, task)``.
SB3_SEED_KEY = 6
#: Progress file in ``checkpoints/`` (results of the finished tasks).
PROGRESS_FILE = "sb3_progress.json"


def _model_path(run: RunDir, index: int) -> Path:
    return run.checkpoints / f"sb3_task{index}{MODEL_SUFFIX}"


def _load_model(run: RunDir, index: int) -> Any:
    """Task ``index``'s saved policy (acts as the model's ``predict``)."""
    return load_sb3_policy("dqn", _model_path(run, index))


@contextmanager
def scoped_global_rng() -> Iterator[None]:
    """Run a block that seeds the global ``random``/NumPy/torch RNGs, then restore them."""
    py_state = random.getstate()
    np_state = np.random.get_state()
    with torch.random.fork_rng(devices=[]):
        try:
            yield
        finally:
            random.setstate(py_state)
            np.random.set_state(np_state)


class EpisodeEpsilon:
    """SB3 exploration schedule holding SPEC §1.6's per-episode epsilon (not a time schedule).

    >>> e = EpisodeEpsilon(1.0, 0.5, 0.2)
    >>> e(0.3), e.decay(), e.decay(), e(0.0)
    (1.0, 0.5, 0.25, 0.25)
    >>> e.decay()
    0.2
    """

    def __init__(self, start: float, decay: float, floor: float) -> None:
        self.eps = float(start)
        self.factor = float(decay)
        self.floor = float(floor)

    def __call__(self, progress_remaining: float) -> float:
        return self.eps

    def decay(self) -> float:
        """After an episode: ``eps <- max(floor, decay * eps)``; returns the new value."""
        self.eps = max(self.floor, self.eps * self.factor)
        return self.eps


class TaskCallback(BaseCallback):
    """Per episode: metrics row, callback, epsilon decay, stop at the budget or on a signal."""

    def __init__(
        self,
        spec: TaskSpec,
        index: int,
        cfg: BiarmConfig,
        epsilon: EpisodeEpsilon,
        step0: int,
        metrics: CsvAppender | None,
        neuromod: CsvAppender | None,
        callback: Callback | None,
        stop: GracefulStop | None,
    ) -> None:
        super().__init__(verbose=0)
        self.spec, self.index, self.cfg, self.epsilon = spec, index, cfg, epsilon
        self.step = step0
        self.task_steps = 0
        self.episodes = 0
        self.metrics, self.neuromod, self.stop = metrics, neuromod, stop
        self.episode_callback = callback
        self.per_step: list[float] = []
        self.stopped = False
        self._ep_start_step = 0
        self._t0 = time.perf_counter()
        self._per_step = cfg.dqn.eps_unit == "step"
        self._ep_eps = epsilon.eps  # epsilon of the episode's first action (metrics.csv)
        # dqn.keep: best -- the same selection rule and record as our trainer's
        self.keep_best = cfg.dqn.keep == "best"
        self.keeper = BestColumn(cfg, spec.episodes)

    def _validate(self) -> None:
        """``dqn.keep: best``: greedy episodes on the validation seeds; keep the best policy."""
        model = cast(DQN, self.model)
        mean = float(np.mean(evaluate_model(model, self.spec, self.keeper.seeds)))
        self.keeper.offer(mean, self.episodes, model.policy)

    def keep(self, model: DQN) -> dict[str, Any] | None:
        """End of the task: load the best validated parameters into ``model`` (keep: best)."""
        return self.keeper.restore_into(model.policy) if self.keep_best else None

    def _on_step(self) -> bool:
        cfg = self.cfg
        self.step += 1
        self.task_steps += 1
        if self._per_step:
            self.epsilon.decay()
        if self.neuromod is not None and self.step % cfg.modules.sample_interval == 0:
            row: dict[str, Any] = {f"s_{m}": "" for m in MODULE_NAMES}
            n_task = cfg.modules.novelty_decay**self.task_steps
            row.update(step=self.step, task=self.index, n_task=f"{n_task:.6g}", gate="")
            row["lr"] = f"{cfg.dqn.lr:.6g}"
            self.neuromod.write(row)
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done and "episode" in info:
                self._end_episode(float(info["episode"]["r"]), int(info["episode"]["l"]))
        if self.episodes >= self.spec.episodes:
            return False
        if self.stop is not None and self.stop.requested:
            self.stopped = True
            return False
        return True

    def _end_episode(self, ret: float, length: int) -> None:
        now = time.perf_counter()
        eps = self._ep_eps
        if self._ep_start_step >= self.cfg.dqn.learning_starts:  # every step trained
            self.per_step.append((now - self._t0) / max(length, 1))
        self._t0, self._ep_start_step = now, self.task_steps
        lr = self.cfg.dqn.lr
        if self.metrics is not None:
            self.metrics.write(
                {
                    "task": self.index,
                    "env_id": self.spec.env_id,
                    "episode": self.episodes,
                    "return": ret,
                    "length": length,
                    "epsilon": f"{eps:.6g}",
                    "lr": f"{lr:.6g}",
                    "step": self.step,
                }
            )
        if self.episode_callback is not None:
            self.episode_callback.on_episode(
                EpisodeInfo(
                    self.index,
                    self.spec.env_id,
                    self.episodes,
                    self.spec.episodes,
                    ret,
                    length,
                    eps,
                    lr,
                )  # fmt: skip
            )
        if not self._per_step:
            self.epsilon.decay()
        self._ep_eps = self.epsilon.eps
        self.episodes += 1
        if self.keep_best and self.keeper.due(self.episodes):
            self._validate()


def build_dqn(cfg: BiarmConfig, env: Any, seed: int) -> DQN:
    """A fresh SB3 DQN with the settings of SPEC §1.6 (see the module docstring).

    Call inside :func:`scoped_global_rng` (``seed=`` seeds SB3's global generators).
    """
    d = cfg.dqn
    model = DQN(
        "MlpPolicy",
        env,
        learning_rate=d.lr,
        buffer_size=d.replay_size,
        learning_starts=d.learning_starts,
        batch_size=d.batch_size,
        gamma=d.gamma,
        train_freq=d.train_every,
        gradient_steps=1,
        # SB3 counts environment steps; ours are gradient steps (one per dqn.train_every)
        target_update_interval=d.train_every * (1 if d.target_mode == "soft" else d.target_update),
        tau=d.tau if d.target_mode == "soft" else 1.0,
        exploration_initial_eps=d.eps_start,
        exploration_final_eps=d.eps_min,
        max_grad_norm=d.grad_clip,
        policy_kwargs={"net_arch": [cfg.network.hidden, cfg.network.hidden]},
        seed=seed,
        device="cpu",
        verbose=0,
    )
    # SB3's default logger creates /tmp/SB3-<date> on learn(); this one records nothing.
    model.set_logger(Logger(folder=None, output_formats=[]))
    return model


def evaluate_model(model: Any, spec: TaskSpec, seeds: list[int]) -> list[float]:
    """Undiscounted returns of greedy episodes of ``model`` (a DQN or its saved policy), one
    per evaluation seed."""
    return greedy_returns(spec, seeds, lambda obs: int(model.predict(obs, deterministic=True)[0]))


def _train_one(
    cfg: BiarmConfig,
    spec: TaskSpec,
    index: int,
    seed: int,
    step0: int,
    metrics: CsvAppender,
    neuromod: CsvAppender,
    callback: Callback | None,
    stop: GracefulStop | None,
) -> tuple[DQN, TaskCallback]:
    """Build and train task ``index``'s model until its episode budget is spent."""
    cfg = cfg.for_task(spec.env_id)  # dqn.per_task
    d = cfg.dqn
    env = make_env(spec.env_id, spec.max_steps)
    try:
        with scoped_global_rng():
            model = build_dqn(cfg, env, derive(seed, SB3_SEED_KEY, index))
            epsilon = EpisodeEpsilon(d.eps_start, d.eps_decay, d.eps_min)
            model.exploration_schedule = epsilon
            model.exploration_rate = epsilon.eps
            task_cb = TaskCallback(
                spec, index, cfg, epsilon, step0, metrics, neuromod, callback, stop
            )
            limit = spec.max_steps or 100_000
            model.learn(spec.episodes * limit + 1, callback=task_cb)
    finally:
        env.close()
    return model, task_cb


def _keep_rows(run: RunDir, name: str, fields: list[str], tasks_done: int) -> None:
    """Drop the rows of tasks that did not finish (resume)."""
    if (run / name).is_file():
        rows = [r for r in run.read_csv(name) if int(r["task"]) < tasks_done]
        run.write_csv(name, rows, fields)


def _progress(
    run: RunDir, resume: bool
) -> tuple[list[dict[str, Any]], int, Mapping[str, Any] | None]:
    """Where a run stands: the finished tasks' results, the env step and the time of earlier
    sessions (None for a fresh start, whose old ``metrics.csv``/``neuromod.csv`` go; a resumed
    run keeps their rows of the finished tasks)."""
    path = run.checkpoints / PROGRESS_FILE
    if resume and path.is_file():
        saved = read_json(path)
        for name, fields in (("metrics.csv", METRIC_FIELDS), ("neuromod.csv", NEUROMOD_FIELDS)):
            _keep_rows(run, name, fields, len(saved["results"]))
        before = saved.get("elapsed", RunClock.UNKNOWN)  # older progress files lack it
        return list(saved["results"]), int(saved["step"]), before
    for name in ("metrics.csv", "neuromod.csv"):
        (run / name).unlink(missing_ok=True)
    return [], 0, None


def _finish_task(
    run: RunDir, model: DQN, cb: TaskCallback, spec: TaskSpec, index: int, seeds: list[int]
) -> dict[str, Any]:
    """After task ``index``'s training: keep its model (``dqn.keep``), save it, evaluate it on
    the evaluation seeds ("initial"); returns its entry of the progress file."""
    last = evaluate_model(model, spec, seeds) if cb.keep_best else None
    kept = cb.keep(model)
    if kept is not None:
        kept["last_network_returns"] = last
    save_sb3(model, _model_path(run, index))
    initial = evaluate_model(model, spec, seeds)
    return {
        **({"validation": kept} if kept is not None else {}),
        "env_id": spec.env_id,
        "episodes": spec.episodes,
        "max_steps": spec.max_steps,
        "train_steps": cb.task_steps,
        "end_step": cb.step,
        "eval_returns_initial": initial,
        "us_per_step": 1e6 * float(np.median(cb.per_step)) if cb.per_step else math.nan,
        "returns_after": [float(np.mean(initial))],
    }


def _returns_after(
    run: RunDir, specs: list[TaskSpec], results: list[dict[str, Any]], seeds: list[int]
) -> None:
    """Acc_{j,i} of Eq. 1.4: every earlier task's model, reloaded, evaluated again (``specs``:
    the tasks before the one just finished)."""
    for j, spec in enumerate(specs):
        old = _load_model(run, j)
        results[j]["returns_after"].append(float(np.mean(evaluate_model(old, spec, seeds))))


def train_sb3_tasks(
    cfg: BiarmConfig,
    variant: Variant,
    seed: int,
    out: str | Path,
    resume: bool = False,
    callback: Callback | None = None,
    stop: GracefulStop | None = None,
) -> dict[str, Any]:
    """Train one SB3 DQN per task into ``out``; the arguments and the returned summary are
    those of :func:`evodevo.neuromod.trainer.train`."""
    specs, d_max = resolve_tasks(cfg)
    started = (Path(out) / "checkpoints" / PROGRESS_FILE).is_file()
    run = open_run(cfg, variant, seed, out, resume, started)
    results, step, before = _progress(run, resume)
    seeds = eval_seeds(cfg.eval.seed, cfg.eval.episodes)
    hint = resume_hint(run.path)
    elapsed = RunClock(before)
    with (
        CsvAppender(run / "metrics.csv", METRIC_FIELDS) as metrics,
        CsvAppender(run / "neuromod.csv", NEUROMOD_FIELDS) as neuromod,
    ):
        for i in range(len(results), len(specs)):
            spec = specs[i]
            if callback is not None:
                callback.on_task(i, spec)
            model, cb = _train_one(cfg, spec, i, seed, step, metrics, neuromod, callback, stop)
            if cb.stopped and stop is not None:
                stop.check(
                    f"episode {cb.episodes} of task {i} ({spec.env_id}); the unfinished task "
                    "re-runs from its start",
                    hint,
                )
            results.append(_finish_task(run, model, cb, spec, i, seeds))
            step = cb.step
            if i < len(specs) - 1:
                _returns_after(run, specs[:i], results, seeds)
            progress = {"results": results, "step": step, "elapsed": elapsed()}
            write_json(run.checkpoints / PROGRESS_FILE, progress)
            if stop is not None and i + 1 < len(specs):
                stop.check(f"task {i} ({spec.env_id})", hint)
    tasks = [
        task_record(res, evaluate_model(_load_model(run, i), spec, seeds))
        for i, (spec, res) in enumerate(zip(specs, results, strict=True))
    ]
    # the time is summed over resumed sessions; an interrupted task's time is not counted
    summary = _summary(cfg, specs, variant.name, seed, d_max, seeds, tasks, elapsed())
    run.write_summary(summary)
    return summary


def _summary(
    cfg: BiarmConfig,
    specs: list[TaskSpec],
    variant: str,
    seed: int,
    d_max: int,
    seeds: list[int],
    tasks: list[dict[str, Any]],
    elapsed: dict[str, Any],
) -> dict[str, Any]:
    """``summary.json``, with the keys of :func:`evodevo.neuromod.trainer.train`'s (no modules,
    no adapters) and SB3's version."""
    return {
        "variant": variant,
        "seed": seed,
        "module_learning": None,
        "adapter_dim": None,
        "d_max": d_max,
        "eval_seeds": seeds,
        "tasks": tasks,
        "final_states": None,
        **elapsed,
        "sb3_version": stable_baselines3.__version__,
        **(
            {"sb3_double_q": False}
            if any(cfg.dqn.for_task(s.env_id).double_q for s in specs)
            else {}
        ),
    }
