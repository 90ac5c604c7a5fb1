"""One task of a BIARM run, episode by episode (Algorithm 1; SPEC §1.6).

:class:`TaskRunner` owns a task's environment, replay buffer, exploration and validation
(``dqn.keep: best``) and runs one episode per call: act, environment step, module update
(Eq. 3.1-3.6), store, one gradient step at the Eq. 3.7 rate, with no printing and no
allocation beyond what NumPy and torch need. It writes a row of ``metrics.csv`` per episode and
of ``neuromod.csv`` every ``modules.sample_interval`` steps; its state (the exploration and
replay streams, the buffer, the episode counter) goes into mid-task checkpoints.
:mod:`evodevo.neuromod.trainer` runs the sequence of tasks.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from evodevo.callbacks import Callback
from evodevo.errors import CheckpointError
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.config import MODULE_NAMES
from evodevo.neuromod.keep_best import BestColumn
from evodevo.neuromod.replay import ReplayBuffer
from evodevo.neuromod.tasks import TaskSpec, make_env
from evodevo.runs import CsvAppender
from evodevo.seeding import derive, np_rng

__all__ = [
    "METRIC_FIELDS",
    "NEUROMOD_FIELDS",
    "EpisodeInfo",
    "TaskRunner",
    "train_task",
]

METRIC_FIELDS = ["task", "env_id", "episode", "return", "length", "epsilon", "lr", "step"]
NEUROMOD_FIELDS = ["step", "task", *[f"s_{m}" for m in MODULE_NAMES], "n_task", "lr", "gate"]


@dataclass(frozen=True)
class EpisodeInfo:
    """What a callback's ``on_episode`` receives after every training episode."""

    task: int
    env_id: str
    episode: int
    episodes: int
    ret: float
    length: int
    epsilon: float
    lr: float


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

    ``resume`` is the :meth:`state` of a runner checkpointed mid-task; the agent must then
    already hold that task's column (:meth:`BiarmAgent.load_train_state`), and the runner
    continues with exactly the episodes an uninterrupted runner would have run.
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
        callback: Callback | None = None,
        resume: dict[str, Any] | None = None,
    ) -> None:
        self.agent, self.spec, self.index = agent, spec, index
        self.metrics, self.neuromod, self.callback = metrics, neuromod, callback
        agent.dqn = agent.cfg.dqn.for_task(spec.env_id)  # dqn.per_task (SPEC §1.6)
        if resume is None:
            agent.begin_task(spec.n_actions)
        self.rng = np_rng(seed, 1, index)
        if not agent.cfg.network.stale_padding:
            # phi (Eq. 3.10) zero-pads: the input row is shared across tasks, and a task with a
            # smaller observation writes only its first spec.obs_dim entries
            agent.obs_np[:] = 0.0
        self.env = make_env(spec.env_id, spec.max_steps)
        self.buf = ReplayBuffer(agent.dqn.replay_size, agent.obs_dim)
        self.nxt = np.zeros(agent.obs_dim, dtype=np.float32)
        self.eps = agent.dqn.eps_start
        self.step = step0
        self.task_steps = 0
        self.episodes_done = 0
        self.per_step: list[float] = []
        self.keeper = BestColumn(agent.cfg, spec.episodes) if agent.dqn.keep == "best" else None
        if resume is None:
            self._obs, _ = self.env.reset(seed=derive(seed, 2, index))
        else:
            self._load_state(resume)

    def state(self) -> dict[str, Any]:
        """Everything of this runner a mid-task checkpoint needs (between episodes)."""
        buf = self.buf
        return {
            "task": self.index,
            "rng": self.rng.bit_generator.state,
            "env_rng": self.env.unwrapped.np_random.bit_generator.state,
            "replay": {"data": buf.data[: buf.size].copy(), "pos": buf.pos, "size": buf.size},
            "eps": self.eps,
            "step": self.step,
            "task_steps": self.task_steps,
            "episodes_done": self.episodes_done,
            "per_step": list(self.per_step),
            **({"keeper": self.keeper.state()} if self.keeper is not None else {}),
        }

    def _load_state(self, data: dict[str, Any]) -> None:
        if int(data["task"]) != self.index:
            raise CheckpointError(
                f"mid-task checkpoint of task {data['task']} given to task {self.index}"
            )
        self.rng.bit_generator.state = data["rng"]
        env_rng = data["env_rng"]
        bit_gen = getattr(np.random, env_rng["bit_generator"])()
        bit_gen.state = env_rng
        self.env.unwrapped.np_random = np.random.Generator(bit_gen)
        rep = data["replay"]
        size = int(rep["size"])
        if rep["data"].shape != (size, self.buf.data.shape[1]) or size > self.buf.capacity:
            raise CheckpointError(
                f"the checkpoint's replay buffer has shape {tuple(rep['data'].shape)}, "
                f"this run's holds rows of {self.buf.data.shape[1]} values "
                f"(capacity {self.buf.capacity}); resume with the run's own config"
            )
        self.buf.data[:size] = rep["data"]
        self.buf.pos, self.buf.size = int(rep["pos"]), size
        self.eps = float(data["eps"])
        self.step = int(data["step"])
        self.task_steps = int(data["task_steps"])
        self.episodes_done = int(data["episodes_done"])
        self.per_step = [float(x) for x in data["per_step"]]
        if self.keeper is not None:
            if "keeper" not in data:
                raise CheckpointError(
                    "the mid-task checkpoint holds no validation state but this run keeps the "
                    "best column (dqn.keep: best); resume with the run's own config"
                )
            self.keeper.load_state(data["keeper"])

    def validate(self, writer: CsvAppender | None = None) -> None:
        """``dqn.keep: best``: the validation check due after the episode just run, if any
        (:mod:`evodevo.neuromod.keep_best`)."""
        if self.keeper is None or not self.keeper.due(self.episodes_done):
            return
        row = self.keeper.check(self.agent, self.index, self.spec, self.episodes_done, self.step)
        if writer is not None:
            writer.write(row)

    def keep(self) -> dict[str, Any] | None:
        """End of the task: load the column it keeps (best by validation, or the last)."""
        return self.keeper.restore(self.agent) if self.keeper is not None else None

    def episode(self, max_env_steps: int | None = None) -> int:
        """Run one training episode (stopping early at ``max_env_steps`` task steps)."""
        agent, spec, index = self.agent, self.spec, self.index
        cfg = agent.cfg
        dqn = agent.dqn
        rng, buf, nxt = self.rng, self.buf, self.nxt
        row = agent.obs_np
        n = spec.obs_dim
        eps = self.eps
        interval = cfg.modules.sample_interval
        decay = cfg.modules.novelty_decay
        mods = agent.modules
        neuromod = self.neuromod
        bs, starts, every = dqn.batch_size, dqn.learning_starts, dqn.train_every
        per_step = dqn.eps_unit == "step"
        eps_decay, eps_min = dqn.eps_decay, dqn.eps_min
        eps0 = eps
        step, task_steps = self.step, self.task_steps
        ep = self.episodes_done
        obs = self._obs if ep == 0 else self.env.reset()[0]
        row[:n] = obs.reshape(-1)
        ret, length, updates = 0.0, 0, 0
        warm = buf.size + 1 >= starts  # every step of this episode trains (timing below)
        t0 = time.perf_counter()
        while True:
            a = agent.act(eps, rng)
            obs, r, term, trunc, _ = self.env.step(a)
            r = float(r)
            nxt[:n] = obs.reshape(-1)
            n_task = mods.n_task if mods is not None else decay**task_steps
            agent.observe(row, r)
            buf.add(row, a, r, nxt, term, n_task)
            # SPEC §1.6: a gradient step every dqn.train_every environment steps of the task
            if buf.size >= starts and (every == 1 or task_steps % every == every - 1):
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
            if per_step:  # SPEC §1.6: "rate 0.995" read per environment step
                eps = max(eps_min, eps * eps_decay)
            if term or trunc or (max_env_steps is not None and task_steps >= max_env_steps):
                break
        dt = time.perf_counter() - t0
        self.step, self.task_steps = step, task_steps
        if warm and updates:
            self.per_step.append(dt / length)
        if self.metrics is not None:
            self.metrics.write(
                {
                    "task": index,
                    "env_id": spec.env_id,
                    "episode": ep,
                    "return": ret,
                    "length": length,
                    "epsilon": f"{eps0:.6g}",
                    "lr": f"{agent.lr():.6g}",
                    "step": step,
                }
            )
        if self.callback is not None:
            self.callback.on_episode(
                EpisodeInfo(index, spec.env_id, ep, spec.episodes, ret, length, eps0, agent.lr())
            )
        self.eps = eps if per_step else max(dqn.eps_min, eps * dqn.eps_decay)
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
    callback: Callback | None = None,
    max_env_steps: int | None = None,
) -> tuple[int, list[float]]:
    """Train column ``index`` on ``spec``; returns (global step, per-episode seconds/step).

    ``max_env_steps`` stops early after that many environment steps (benchmarks).
    """
    runner = TaskRunner(agent, spec, index, seed, step0, metrics, neuromod, callback)
    try:
        for _ in range(spec.episodes):
            runner.episode(max_env_steps)
            if max_env_steps is not None and runner.task_steps >= max_env_steps:
                break
    finally:
        runner.close()
    return runner.step, runner.per_step
