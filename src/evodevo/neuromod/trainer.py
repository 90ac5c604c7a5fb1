"""Sequential multi-task DQN training of one run (Algorithm 1; SPEC §1.6-1.7).

:func:`train` runs the task sequence for one variant and seed into a run directory:
``config.json``, ``metrics.csv`` (one row per episode), ``neuromod.csv`` (one row every
``modules.sample_interval`` environment steps), ``checkpoints/task{i}.safetensors`` after
every task, ``checkpoints/task{i}_ep{k}.safetensors`` every ``checkpoint_every`` episodes within
a task (:mod:`evodevo.neuromod.checkpoint`), and ``summary.json`` at the end. Every random stream is
derived from the run seed and the task index (:mod:`evodevo.seeding`): the replay sampling and
exploration stream ``np_rng(seed, 1, i)``, the environment ``derive(seed, 2, i)`` (its first
reset; later resets continue the environment's own ``np_random``), column i
``derive(seed, 3, i)`` and the modules ``derive(seed, 4)``. A mid-task checkpoint stores the
states of the two streams live inside a task, so ``--resume`` from any checkpoint gives the
same numbers as an uninterrupted run. With a :class:`~evodevo.signals.GracefulStop`, SIGINT or
SIGTERM end the run after the current episode and its checkpoint.

One task, episode by episode, is :mod:`evodevo.neuromod.task_runner`. Per environment step: act,
environment step, module update (Eq. 3.1-3.6), store, one gradient step at the Eq. 3.7 rate.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.callbacks import Callback
from evodevo.config import from_dict
from evodevo.errors import CheckpointError
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.checkpoint import (
    ResumePoint,
    latest_checkpoint,
    latest_resume_point,
    load_checkpoint,
    save_checkpoint,
    save_partial_checkpoint,
)
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.evaluation import eval_seeds, evaluate_column, task_record
from evodevo.neuromod.forgetting import record_returns_after
from evodevo.neuromod.keep_best import VALIDATION_FIELDS
from evodevo.neuromod.resume import open_run, saved_config
from evodevo.neuromod.task_runner import (
    METRIC_FIELDS,
    NEUROMOD_FIELDS,
    EpisodeInfo,
    TaskRunner,
    train_task,
)
from evodevo.neuromod.tasks import TaskSpec, resolve_tasks
from evodevo.neuromod.variants import Variant, get_variant
from evodevo.run_clock import RunClock
from evodevo.runs import CsvAppender, RunDir
from evodevo.signals import GracefulStop
from evodevo.trainers import get_trainer

__all__ = [
    "train",
    "train_task",
    "TaskRunner",
    "EpisodeInfo",
    "METRIC_FIELDS",
    "NEUROMOD_FIELDS",
    "TIMING_KEYS",
    "load_agent",
    "saved_config",
    "resume_hint",
]

#: Summary keys that hold wall-clock measurements (excluded from reproducibility checks).
TIMING_KEYS = ("us_per_step", "wall_seconds", "cpu_seconds", "timing_complete")


def _truncate_csv(run: RunDir, name: str, fields: list[str], last_step: int) -> None:
    """Keep only the rows up to global step ``last_step`` (resume after a kill)."""
    if not (run / name).is_file():
        return
    rows = [
        r for r in run.read_csv(name) if r.get("step", "") != "" and int(r["step"]) <= last_step
    ]
    run.write_csv(name, rows, fields)


def _check_payload(ckpt: dict[str, Any], path: Path, variant: Variant, seed: int) -> None:
    """A checkpoint copied in from another run is refused (its variant or seed differs)."""
    for key, mine in (("variant", variant.name), ("seed", seed)):
        if key in ckpt and ckpt[key] != mine:
            raise CheckpointError(
                f"checkpoint {str(path)!r} belongs to a run with {key} {ckpt[key]!r}, not "
                f"{mine!r}; remove it or resume with the run's own options"
            )


def resume_hint(out: str | Path) -> str:
    """The command that continues a stopped run."""
    return f"continue with: evodevo biarm train --resume --out {out}"


def train(
    cfg: BiarmConfig,
    variant: str | Variant,
    seed: int,
    out: str | Path,
    resume: bool = False,
    callback: Callback | None = None,
    stop: GracefulStop | None = None,
) -> dict[str, Any]:
    """Run the whole task sequence for one variant and seed; returns the summary.

    All input checks (environment ids, spaces, ``d_max``, variant, scale) happen before the
    first environment step.

    Args:
        cfg: the resolved config (``checkpoint_every`` sets the mid-task checkpoints).
        variant: variant name or object.
        seed: run seed.
        out: run directory.
        resume: continue from the newest checkpoint in ``out`` (finished task or mid-task);
            the rows of ``metrics.csv``/``neuromod.csv`` written after it are dropped, and the
            run ends with the same ``summary.json`` (wall-time fields aside) as an
            uninterrupted one.
        callback: told when a task starts (or resumes) and after every training episode
            (:class:`~evodevo.callbacks.Callback`: ``on_task``, ``on_episode``, ``on_end``).
        stop: a :class:`~evodevo.signals.GracefulStop`; when it reports a signal, the run
            finishes the current episode, checkpoints and raises
            :class:`~evodevo.signals.StopRequested`.
    """
    var = get_variant(variant) if isinstance(variant, str) else variant
    other = get_trainer(var.architecture)  # e.g. sb3: an SB3 DQN per task, same run files
    if other is not None:
        return other(cfg, var, seed, out, resume, callback, stop)
    run, specs, d_max, point = _open_run(cfg, var, seed, out, resume)
    agent = BiarmAgent(cfg, var, d_max, seed)
    if callback is not None:
        callback.init(agent)
    state = _restore(run, agent, var, seed, point if resume else None)
    seeds = eval_seeds(cfg.eval.seed, cfg.eval.episodes)
    ctx = _RunContext(run, agent, var, seed, cfg.checkpoint_every, RunClock(state.before), stop)
    with (
        CsvAppender(run / "metrics.csv", METRIC_FIELDS) as metrics,
        CsvAppender(run / "neuromod.csv", NEUROMOD_FIELDS) as neuromod,
        (
            CsvAppender(run / "validation.csv", VALIDATION_FIELDS)
            if any(cfg.dqn.for_task(s.env_id).keep == "best" for s in specs)
            else contextlib.nullcontext()
        ) as validation,
    ):
        for i in range(state.start, len(specs)):
            spec = specs[i]
            if callback is not None:
                callback.on_task(i, spec)
            runner = TaskRunner(
                agent, spec, i, seed, state.step, metrics, neuromod, callback, resume=state.partial
            )
            state.partial = None
            _train_task(ctx, runner, state.results, validation)
            state.step = runner.step
            state.results.append(_task_result(agent, runner, state.results, seeds))
            agent.end_task(runner.buf)  # EWC: this task's Fisher (a no-op for other variants)
            record_returns_after(agent, specs, i, state.results, seeds)  # Acc_{j,i} of Eq. 1.4
            save_checkpoint(
                run.checkpoints, i, ctx.payload(agent.state(), state.results, state.step)
            )
            if stop is not None and i + 1 < len(specs):
                stop.check(f"task {i} ({spec.env_id})", ctx.hint)
    agent.end_training()
    if callback is not None:
        callback.on_end()
    summary = _summary(cfg, ctx, specs, state.results, seeds, d_max)
    run.write_summary(summary)
    return summary


def _summary(
    cfg: BiarmConfig,
    ctx: _RunContext,
    specs: list[TaskSpec],
    results: list[dict[str, Any]],
    seeds: list[int],
    d_max: int,
) -> dict[str, Any]:
    """``summary.json``: every column evaluated again after the whole sequence ("final
    performance", SPEC §1.7) beside its saved results, the settings and the run's cost."""
    agent = ctx.agent
    tasks = [
        task_record(res, evaluate_column(agent, i, spec, seeds))
        for i, (spec, res) in enumerate(zip(specs, results, strict=True))
    ]
    return {
        "variant": ctx.var.name,
        "seed": ctx.seed,
        "module_learning": cfg.modules.learning,
        "adapter_dim": cfg.network.adapter_dim,
        "lateral_kernel": getattr(agent.net, "kernel", None),
        "d_max": d_max,
        "eval_seeds": seeds,
        "tasks": tasks,
        "final_states": agent.modules.states.tolist() if agent.modules is not None else None,
        **ctx.clock(),  # summed over resumed sessions (see RunClock)
    }


def _open_run(
    cfg: BiarmConfig, var: Variant, seed: int, out: str | Path, resume: bool
) -> tuple[RunDir, list[TaskSpec], int, ResumePoint | None]:
    """Check the tasks, open the run folder and its newest checkpoint; a new run writes its
    config, a resumed one must match the saved config."""
    specs, d_max = resolve_tasks(cfg)
    point = latest_resume_point(Path(out) / "checkpoints")
    run = open_run(cfg, var, seed, out, resume, started=point is not None)
    return run, specs, d_max, point


@dataclass
class _ResumeState:
    """Where a run (re)starts: the finished tasks' results, the environment step, the first
    task to train, a mid-task runner state, and the time spent before the checkpoint."""

    results: list[dict[str, Any]] = field(default_factory=list)
    step: int = 0
    start: int = 0
    partial: dict[str, Any] | None = None
    before: Mapping[str, Any] | None = None


def _restore(
    run: RunDir, agent: BiarmAgent, var: Variant, seed: int, point: ResumePoint | None
) -> _ResumeState:
    """Load the checkpoint at ``point`` into ``agent`` (and drop the CSV rows written after
    it), or start afresh without one."""
    if point is None:
        for name in ("metrics.csv", "neuromod.csv", "validation.csv"):
            (run / name).unlink(missing_ok=True)
        return _ResumeState()
    ckpt = load_checkpoint(point.path)
    _check_payload(ckpt, point.path, var, seed)
    state = _ResumeState(
        results=list(ckpt["results"]),
        step=int(ckpt["step"]),
        # time spent before the resume point (checkpoints carry it; older ones do not)
        before=ckpt.get("elapsed", RunClock.UNKNOWN),
    )
    if point.finished_task:
        agent.load_state(ckpt["agent"])
        state.start = point.task + 1
    else:
        agent.load_train_state(ckpt["agent"])
        state.start = point.task
        state.partial = ckpt["runner"]
    _truncate_csv(run, "metrics.csv", METRIC_FIELDS, state.step)
    _truncate_csv(run, "neuromod.csv", NEUROMOD_FIELDS, state.step)
    _truncate_csv(run, "validation.csv", VALIDATION_FIELDS, state.step)
    return state


@dataclass
class _RunContext:
    """What every checkpoint of a run carries besides the agent, and how it stops."""

    run: RunDir
    agent: BiarmAgent
    var: Variant
    seed: int
    every: int
    clock: RunClock
    stop: GracefulStop | None

    @property
    def hint(self) -> str:
        return resume_hint(self.run.path)

    def payload(
        self, agent_state: dict[str, Any], results: list[dict[str, Any]], step: int
    ) -> dict[str, Any]:
        return {
            "agent": agent_state,
            "results": results,
            "step": step,
            "variant": self.var.name,
            "seed": self.seed,
            "elapsed": self.clock(),
        }


def _train_task(
    ctx: _RunContext, runner: TaskRunner, results: list[dict[str, Any]], validation: Any
) -> None:
    """Train task ``runner.index`` to its episode budget, validating after each episode and
    checkpointing every ``checkpoint_every`` episodes (and when a stop was requested)."""
    spec, i, stop = runner.spec, runner.index, ctx.stop
    try:
        while runner.episodes_done < spec.episodes:
            runner.episode()
            runner.validate(validation)
            k = runner.episodes_done
            stopping = stop is not None and stop.requested
            if k < spec.episodes and ((ctx.every and k % ctx.every == 0) or stopping):
                save_partial_checkpoint(
                    ctx.run.checkpoints,
                    i,
                    k,
                    {
                        **ctx.payload(ctx.agent.train_state(), results, runner.step),
                        "runner": runner.state(),
                    },
                )
                if stop is not None:
                    stop.check(f"episode {k} of task {i} ({spec.env_id})", ctx.hint)
    finally:
        runner.close()


def _task_result(
    agent: BiarmAgent, runner: TaskRunner, results: list[dict[str, Any]], seeds: list[int]
) -> dict[str, Any]:
    """The finished task's record: the kept column's greedy returns on the evaluation seeds
    ("initial performance"), its validation record, training steps and time per step."""
    spec, i, step, per_step = runner.spec, runner.index, runner.step, runner.per_step
    # dqn.keep: best loads the best validated parameters; the last network's returns on
    # the evaluation seeds are recorded beside (reporting only, never for selection)
    last = evaluate_column(agent, i, spec, seeds) if runner.keeper is not None else None
    kept = runner.keep()
    if kept is not None:
        kept["last_network_returns"] = last
    initial = evaluate_column(agent, i, spec, seeds)
    return {
        **({"validation": kept} if kept is not None else {}),
        "env_id": spec.env_id,
        "episodes": spec.episodes,
        "max_steps": spec.max_steps,
        "train_steps": step - (results[-1]["end_step"] if results else 0),
        "end_step": step,
        "eval_returns_initial": initial,
        "us_per_step": 1e6 * float(np.median(per_step)) if per_step else math.nan,
    }


def load_agent(run_dir: str | Path) -> BiarmAgent:
    """Rebuild the trained agent of a run directory from its last checkpoint."""
    run = RunDir(run_dir, create=False)
    saved = saved_config(run.read_config()["config"])
    variant = saved.pop("variant")
    seed = int(saved.pop("seed"))
    cfg = from_dict(BiarmConfig, saved)
    last = latest_checkpoint(run.path / "checkpoints")
    if last is None:
        raise CheckpointError(f"{str(run.path)!r} has no checkpoints; was the run started?")
    _, d_max = resolve_tasks(cfg)
    agent = BiarmAgent(cfg, get_variant(variant), d_max, seed)
    agent.load_state(load_checkpoint(last[1])["agent"])
    return agent
