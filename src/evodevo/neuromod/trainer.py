"""Sequential multi-task DQN training of one run (Algorithm 1; SPEC §1.6-1.7).

:func:`train` runs the task sequence for one variant and seed into a run directory:
``config.json``, ``metrics.csv`` (one row per episode), ``neuromod.csv`` (one row every
``modules.sample_interval`` environment steps), ``checkpoints/task{i}.pt`` after every task,
and ``summary.json`` at the end. Every random stream is derived from the run seed and the task
index (:mod:`evodevo.seeding`): the replay sampling and exploration stream
``np_rng(seed, 1, i)``, the environment ``derive(seed, 2, i)``, column i ``derive(seed, 3, i)``
and the modules ``derive(seed, 4)``; so ``--resume`` after task i gives the same numbers as an
uninterrupted run.

Per environment step (no printing, no allocation beyond what NumPy/torch need): act,
environment step, module update (Eq. 3.1-3.6), store, one gradient step at the Eq. 3.7 rate.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.config import from_dict, to_dict
from evodevo.errors import CheckpointError, EvodevoError
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.checkpoint import latest_checkpoint, load_checkpoint, save_checkpoint
from evodevo.neuromod.config import MODULE_NAMES, BiarmConfig
from evodevo.neuromod.evaluation import eval_seeds, evaluate_column, retention
from evodevo.neuromod.replay import ReplayBuffer
from evodevo.neuromod.tasks import TaskSpec, make_env, resolve_tasks
from evodevo.neuromod.variants import Variant, get_variant
from evodevo.runs import CsvAppender, RunDir
from evodevo.seeding import derive, np_rng

__all__ = [
    "train",
    "train_task",
    "TaskRunner",
    "EpisodeInfo",
    "METRIC_FIELDS",
    "NEUROMOD_FIELDS",
    "TIMING_KEYS",
    "load_agent",
]

METRIC_FIELDS = ["task", "env_id", "episode", "return", "length", "epsilon", "lr", "step"]
NEUROMOD_FIELDS = ["step", "task", *[f"s_{m}" for m in MODULE_NAMES], "n_task", "lr", "gate"]
#: Summary keys that hold wall-clock measurements (excluded from reproducibility checks).
TIMING_KEYS = ("us_per_step", "wall_seconds")


@dataclass(frozen=True)
class EpisodeInfo:
    """What a progress hook receives after every training episode."""

    task: int
    env_id: str
    episode: int
    episodes: int
    ret: float
    length: int
    epsilon: float
    lr: float


EpisodeHook = Callable[[EpisodeInfo], None]


def _neuromod_row(agent: BiarmAgent, step: int, task: int, n_task: float) -> dict[str, Any]:
    row: dict[str, Any] = {"step": step, "task": task, "n_task": f"{n_task:.6g}"}
    if agent.modules is not None:
        for name, v in zip(MODULE_NAMES, agent.modules.states, strict=True):
            row[f"s_{name}"] = f"{float(v):.6g}"
    else:  # PNN: no modules run; states are not defined
        for name in MODULE_NAMES:
            row[f"s_{name}"] = ""
    row["lr"] = f"{agent.lr():.6g}"
    g = agent.gate()
    row["gate"] = "" if math.isnan(g) else f"{g:.6g}"
    return row


class TaskRunner:
    """Training of column ``index`` on one task, one episode per :meth:`episode` call.

    Holds the task's environment, replay buffer, exploration stream and epsilon. The
    benchmark interleaves episodes of several agents through this class; :func:`train_task`
    runs all episodes of a task.
    """

    def __init__(
        self,
        agent: BiarmAgent,
        spec: TaskSpec,
        index: int,
        seed: int,
        step0: int = 0,
        metrics: CsvAppender | None = None,
        neuromod: CsvAppender | None = None,
        hook: EpisodeHook | None = None,
    ) -> None:
        self.agent, self.spec, self.index = agent, spec, index
        self.metrics, self.neuromod, self.hook = metrics, neuromod, hook
        agent.begin_task(spec.n_actions)
        self.rng = np_rng(seed, 1, index)
        self.env = make_env(spec.env_id, spec.max_steps)
        self.buf = ReplayBuffer(agent.cfg.dqn.replay_size, agent.obs_dim)
        self.nxt = np.zeros(agent.obs_dim, dtype=np.float32)
        self.eps = agent.cfg.dqn.eps_start
        self.step = step0
        self.task_steps = 0
        self.episodes_done = 0
        self.per_step: list[float] = []
        self._obs, _ = self.env.reset(seed=derive(seed, 2, index))

    def episode(self, max_env_steps: int | None = None) -> int:
        """Run one training episode (stopping early at ``max_env_steps`` task steps)."""
        agent, spec, index = self.agent, self.spec, self.index
        cfg = agent.cfg
        dqn = cfg.dqn
        rng, buf, nxt = self.rng, self.buf, self.nxt
        row = agent.obs_np
        n = spec.obs_dim
        eps = self.eps
        interval = cfg.modules.sample_interval
        decay = cfg.modules.novelty_decay
        mods = agent.modules
        neuromod = self.neuromod
        bs, starts = dqn.batch_size, dqn.learning_starts
        step, task_steps = self.step, self.task_steps
        ep = self.episodes_done
        obs = self._obs if ep == 0 else self.env.reset()[0]
        row[:n] = obs.reshape(-1)
        ret, length, updates = 0.0, 0, 0
        t0 = time.perf_counter()
        while True:
            a = agent.act(eps, rng)
            obs, r, term, trunc, _ = self.env.step(a)
            r = float(r)
            nxt[:n] = obs.reshape(-1)
            n_task = mods.n_task if mods is not None else decay**task_steps
            agent.observe(row, r)
            buf.add(row, a, r, nxt, term, n_task)
            if buf.size >= starts:
                agent.update(buf.sample(rng, bs))
                updates += 1
            step += 1
            task_steps += 1
            if neuromod is not None and step % interval == 0:
                nt = mods.n_task if mods is not None else decay**task_steps
                neuromod.write(_neuromod_row(agent, step, index, nt))
            ret += r
            length += 1
            row[:n] = nxt[:n]
            if term or trunc or (max_env_steps is not None and task_steps >= max_env_steps):
                break
        dt = time.perf_counter() - t0
        self.step, self.task_steps = step, task_steps
        if updates == length:
            self.per_step.append(dt / length)
        if self.metrics is not None:
            self.metrics.write(
                {
                    "task": index,
                    "env_id": spec.env_id,
                    "episode": ep,
                    "return": ret,
                    "length": length,
                    "epsilon": f"{eps:.6g}",
                    "lr": f"{agent.lr():.6g}",
                    "step": step,
                }
            )
        if self.hook is not None:
            self.hook(
                EpisodeInfo(index, spec.env_id, ep, spec.episodes, ret, length, eps, agent.lr())
            )
        self.eps = max(dqn.eps_min, eps * dqn.eps_decay)
        self.episodes_done += 1
        return length

    def close(self) -> None:
        self.env.close()


def train_task(
    agent: BiarmAgent,
    spec: TaskSpec,
    index: int,
    seed: int,
    step0: int,
    metrics: CsvAppender | None,
    neuromod: CsvAppender | None,
    hook: EpisodeHook | None = None,
    max_env_steps: int | None = None,
) -> tuple[int, list[float]]:
    """Train column ``index`` on ``spec``; returns (global step, per-episode seconds/step).

    ``max_env_steps`` stops early after that many environment steps (benchmarks).
    """
    runner = TaskRunner(agent, spec, index, seed, step0, metrics, neuromod, hook)
    try:
        for _ in range(spec.episodes):
            runner.episode(max_env_steps)
            if max_env_steps is not None and runner.task_steps >= max_env_steps:
                break
    finally:
        runner.close()
    return runner.step, runner.per_step


def _truncate_csv(run: RunDir, name: str, fields: list[str], last_task: int) -> None:
    """Keep only the rows of tasks ``<= last_task`` (resume after a kill mid-task)."""
    if not (run / name).is_file():
        return
    rows = [
        r for r in run.read_csv(name) if r.get("task", "") != "" and int(r["task"]) <= last_task
    ]
    run.write_csv(name, rows, fields)


def _check_resume(run: RunDir, variant: Variant, seed: int, cfg: BiarmConfig) -> None:
    saved = run.read_config()
    mine = {"variant": variant.name, "seed": seed, **to_dict(cfg)}
    theirs = saved.get("config", {})
    for key in ("variant", "seed", "tasks", "episodes_scale", "dqn", "network", "modules"):
        if theirs.get(key) != mine.get(key):
            raise CheckpointError(
                f"--resume: {key} of {str(run.path)!r} ({theirs.get(key)!r}) differs from this "
                f"run's ({mine.get(key)!r}); use the same options or another --out"
            )


def train(
    cfg: BiarmConfig,
    variant: str | Variant,
    seed: int,
    out: str | Path,
    resume: bool = False,
    hook: EpisodeHook | None = None,
    on_task: Callable[[int, TaskSpec], None] | None = None,
) -> dict[str, Any]:
    """Run the whole task sequence for one variant and seed; returns the summary.

    All input checks (environment ids, spaces, ``d_max``, variant, scale) happen before the
    first environment step.
    """
    var = get_variant(variant) if isinstance(variant, str) else variant
    specs, d_max = resolve_tasks(cfg)
    run = RunDir(out)
    last = latest_checkpoint(run.path / "checkpoints")
    if last is not None and not resume:
        raise EvodevoError(
            f"{str(run.path)!r} already holds checkpoints of a run; pass --resume to continue "
            "it or choose another --out"
        )
    if resume and (run / "config.json").is_file():
        _check_resume(run, var, seed, cfg)
    else:
        run.write_config({"variant": var.name, "seed": seed, **to_dict(cfg)}, kind="biarm")
    agent = BiarmAgent(cfg, var, d_max, seed)
    results: list[dict[str, Any]] = []
    step = 0
    start = 0
    if resume and last is not None:
        ckpt = load_checkpoint(last[1])
        agent.load_state(ckpt["agent"])
        results = list(ckpt["results"])
        step = int(ckpt["step"])
        start = last[0] + 1
        _truncate_csv(run, "metrics.csv", METRIC_FIELDS, last[0])
        _truncate_csv(run, "neuromod.csv", NEUROMOD_FIELDS, last[0])
    elif not resume or last is None:
        for name in ("metrics.csv", "neuromod.csv"):
            (run / name).unlink(missing_ok=True)
    seeds = eval_seeds(cfg.eval.seed, cfg.eval.episodes)
    t_start = time.perf_counter()
    with (
        CsvAppender(run / "metrics.csv", METRIC_FIELDS) as metrics,
        CsvAppender(run / "neuromod.csv", NEUROMOD_FIELDS) as neuromod,
    ):
        for i in range(start, len(specs)):
            spec = specs[i]
            if on_task is not None:
                on_task(i, spec)
            step, per_step = train_task(agent, spec, i, seed, step, metrics, neuromod, hook)
            initial = evaluate_column(agent, i, spec, seeds)
            results.append(
                {
                    "env_id": spec.env_id,
                    "episodes": spec.episodes,
                    "max_steps": spec.max_steps,
                    "train_steps": step - (results[-1]["end_step"] if results else 0),
                    "end_step": step,
                    "eval_returns_initial": initial,
                    "us_per_step": 1e6 * float(np.median(per_step)) if per_step else math.nan,
                }
            )
            save_checkpoint(
                run.checkpoints,
                i,
                {"agent": agent.state(), "results": results, "step": step, "variant": var.name},
            )
    agent.end_training()
    tasks = []
    for i, (spec, res) in enumerate(zip(specs, results, strict=True)):
        final = evaluate_column(agent, i, spec, seeds)
        ini_mean = float(np.mean(res["eval_returns_initial"]))
        fin_mean = float(np.mean(final))
        tasks.append(
            {
                **res,
                "initial_return": ini_mean,
                "final_return": fin_mean,
                "retention": retention(ini_mean, fin_mean),
                "eval_returns_final": final,
            }
        )
    summary = {
        "variant": var.name,
        "seed": seed,
        "module_learning": cfg.modules.learning,
        "adapter_dim": cfg.network.adapter_dim,
        "d_max": d_max,
        "eval_seeds": seeds,
        "tasks": tasks,
        "final_states": agent.modules.states.tolist() if agent.modules is not None else None,
        "wall_seconds": time.perf_counter() - t_start,
    }
    run.write_summary(summary)
    return summary


def load_agent(run_dir: str | Path) -> BiarmAgent:
    """Rebuild the trained agent of a run directory from its last checkpoint."""
    run = RunDir(run_dir, create=False)
    saved = run.read_config()["config"]
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
