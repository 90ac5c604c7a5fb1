"""Stable-Baselines3 callbacks of the Kuka baselines' training (SPEC §4): the training clock
(wall time minus the time spent estimating success), the budget stop, the timed success
estimate that writes ``learning_curve.csv``, the env-step reports to evodevo's callbacks, the
checkpoint clock and pruning, and the ``validated`` return rule's candidates
(:mod:`evodevo.grn.return_rule`).
"""

from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

from evodevo.baselines.policies import Sb3Model
from evodevo.baselines.sb3_files import MODEL_SUFFIX, save_sb3
from evodevo.callbacks import Callback
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.return_rule import STATE_FILE as VALIDATION_FILE
from evodevo.grn.return_rule import ValidatedBest
from evodevo.runs import RunDir, read_json, write_json

__all__ = [
    "CKPT_PREFIX",
    "CANDIDATE_PREFIX",
    "CLOCK_FILE",
    "CURVE_FIELDS",
    "TrainClock",
    "BudgetCallback",
    "TimedEvalCallback",
    "StepsCallback",
    "ClockCallback",
    "ValidationCallback",
    "write_clock",
    "checkpoint_steps",
    "prune_checkpoints",
]

CKPT_PREFIX = "rl_model"
CANDIDATE_PREFIX = "candidate"
CLOCK_FILE = "clock.json"
CURVE_FIELDS = ["env_steps", "train_s", "success", "mean_reward", "episodes"]


@dataclass
class TrainClock:
    """Training seconds (wall time minus the time of the success estimates), across resumes."""

    offset_s: float = 0.0
    eval_s: float = 0.0
    start: float = 0.0

    def begin(self) -> None:
        self.start = time.perf_counter()

    @property
    def train_s(self) -> float:
        return self.offset_s + (time.perf_counter() - self.start) - self.eval_s


class BudgetCallback(BaseCallback):
    """Stop training at ``max_steps`` env steps or ``max_s`` training seconds."""

    def __init__(self, clock: TrainClock, max_steps: int | None, max_s: float | None) -> None:
        super().__init__()
        self.clock = clock
        self.max_steps = max_steps
        self.max_s = max_s
        self.stopped_by = "steps"

    def _on_step(self) -> bool:
        if self.max_steps is not None and self.num_timesteps >= self.max_steps:
            self.stopped_by = "steps"
            return False
        if self.max_s is not None and self.clock.train_s >= self.max_s:
            self.stopped_by = "time"
            return False
        return True


class TimedEvalCallback(EvalCallback):
    """SB3's EvalCallback, timed (excluded from training time) and logged to a CSV row each time."""

    def __init__(
        self,
        eval_env: Any,
        clock: TrainClock,
        run: RunDir,
        quiet: bool,
        callback: Callback | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(eval_env, **kwargs)
        self.clock = clock
        self.run = run
        self.quiet = quiet
        self.run_callback = callback if callback is not None else Callback()
        self.rows: list[dict[str, Any]] = []

    def _on_step(self) -> bool:
        if not (self.eval_freq > 0 and self.n_calls % self.eval_freq == 0):
            return True
        t0 = time.perf_counter()
        out = super()._on_step()
        self.clock.eval_s += time.perf_counter() - t0
        success = float(np.mean(self._is_success_buffer)) if self._is_success_buffer else 0.0
        row = {
            "env_steps": int(self.num_timesteps),
            "train_s": self.clock.train_s,
            "success": success,
            "mean_reward": float(self.last_mean_reward),
            "episodes": int(self.n_eval_episodes),
        }
        self.rows.append(row)
        self.run.write_csv("learning_curve.csv", self.rows, CURVE_FIELDS)
        self.run_callback.on_curve_row(row)
        if not self.quiet:
            print(
                f"steps {row['env_steps']:>7} success {success:.2f} training {row['train_s']:.0f}s",
                file=sys.stderr,
                flush=True,
            )
        return out


class StepsCallback(BaseCallback):
    """Tells the training callbacks the env steps done after every step (progress bars)."""

    def __init__(self, callback: Callback) -> None:
        super().__init__()
        self.run_callback = callback

    def _on_step(self) -> bool:
        self.run_callback.on_steps(int(self.num_timesteps))
        return True


class ClockCallback(BaseCallback):
    """Beside each SB3 checkpoint: its training time in ``clock.json``; older checkpoints removed."""

    def __init__(self, clock: TrainClock, save_freq: int, folder: Path) -> None:
        super().__init__()
        self.clock = clock
        self.save_freq = save_freq
        self.folder = folder

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            write_clock(self.folder, self.num_timesteps, self.clock)
            prune_checkpoints(self.folder, keep=self.num_timesteps)
        return True


class ValidationCallback(BaseCallback):
    """``keep.rule: validated``: every ``every`` env steps, a candidate snapshot of the model.

    The snapshot is saved for acting (``checkpoints/candidate_{n}_steps.safetensors``), scored
    by the keeper on the validation episodes through ``evaluator`` (timed: not training time)
    and kept if it has the most successes so far; the keeper's state is saved at once. It must
    run before the checkpoint callback of the same step (a resume from a checkpoint drops the
    candidates after it). :meth:`candidate` also serves the final model after training.
    """

    def __init__(
        self,
        keeper: ValidatedBest,
        evaluator: Evaluator,
        every: int,
        clock: TrainClock,
        run: RunDir,
        algo: str,
    ) -> None:
        super().__init__()
        self.keeper = keeper
        self.algo = algo
        self.evaluator = evaluator
        self.every = every
        self.clock = clock
        self.run = run

    def _on_step(self) -> bool:
        if self.num_timesteps % self.every == 0:
            self.candidate(self.model)
        return True

    def candidate(self, model: Any) -> None:
        """Score ``model`` as the candidate at its env steps (once per step count)."""
        steps = int(model.num_timesteps)
        rows = self.keeper.rows
        if rows and int(rows[-1]["at"]) >= steps:
            return
        t0 = time.perf_counter()
        folder = self.run.checkpoints
        name = f"{CANDIDATE_PREFIX}_{steps}_steps{MODEL_SUFFIX}"
        save_sb3(model, folder / name, training=False)
        ref = Sb3Model(self.algo, str((folder / name).resolve()))
        if not self.keeper.check(self.evaluator, ref, steps, {"file": name}):
            (folder / name).unlink(missing_ok=True)
        done = checkpoint_steps(folder)
        for state in self.keeper.prune(upto=done[-1] if done else None):
            (folder / str(state["file"])).unlink(missing_ok=True)
        self.keeper.save(folder / VALIDATION_FILE)
        self.keeper.write_csv(self.run)
        self.clock.eval_s += time.perf_counter() - t0


def write_clock(folder: Path, steps: int, clock: TrainClock) -> None:
    """Record (steps → training and evaluation seconds) in ``clock.json``."""
    path = folder / CLOCK_FILE
    data = read_json(path) if path.is_file() else {}
    data[str(int(steps))] = {"train_s": clock.train_s, "eval_s": clock.eval_s}
    write_json(path, data)


def checkpoint_steps(folder: Path) -> list[int]:
    """Env steps of the model checkpoints in ``folder``, ascending."""
    pat = re.compile(rf"^{CKPT_PREFIX}_(\d+)_steps\{MODEL_SUFFIX}$")
    return sorted(
        int(m.group(1)) for p in folder.glob(f"*{MODEL_SUFFIX}") if (m := pat.match(p.name))
    )


def prune_checkpoints(folder: Path, keep: int) -> None:
    """Delete the model and replay-buffer checkpoints of every step count but ``keep``."""
    for steps in checkpoint_steps(folder):
        if steps != keep:
            for name in (
                f"{CKPT_PREFIX}_{steps}_steps{MODEL_SUFFIX}",
                f"{CKPT_PREFIX}_replay_buffer_{steps}_steps.npz",
            ):
                (folder / name).unlink(missing_ok=True)
