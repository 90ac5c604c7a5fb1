"""Progress with an ETA for long commands (Rich, on stderr; nothing at all when quiet).

:class:`CommandProgress` shows one bar for the work in flight: every ``map`` of a worker pool
inside its block (an evaluation of genomes, an ablation, a grid of training runs) reports its
items through :func:`evodevo.parallel.report_progress`, so the code that evaluates needs no
progress calls of its own. Each new ``map`` restarts the bar as the next phase; the columns
show items done, elapsed time and the time remaining for the phase. :class:`GenerationBar` adds
a bar over the generations of an evolution with the ETA of the whole run, and prints the
per-generation line above the bars. :class:`TrainingBar` is a Kuka baseline's training callback (a
bar over its env-step budget or NEAT's generations), :class:`StepBar` a bar over the steps of a
script (``evodevo reproduce``). Machine-readable output (``--json``, tables) stays on
stdout, untouched.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import Any

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from evodevo.callbacks import Callback
from evodevo.parallel import report_progress

__all__ = [
    "CommandProgress",
    "GenerationBar",
    "TrainingBar",
    "StepBar",
    "TaskBars",
    "generation_line",
    "plain_line",
]


def _columns() -> list[Any]:
    return [
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
    ]


class CommandProgress:
    """A context manager: a progress bar on stderr for the pool work inside it.

    Args:
        description: what the command does ("evaluate", "ablate", ...).
        quiet: show nothing.
        on_item: also told ``(done, total)`` after every finished item, quiet or not (e.g. to
            export a finished run's metrics to TensorBoard).
    """

    def __init__(
        self,
        description: str,
        quiet: bool = False,
        on_item: Callable[[int, int], None] | None = None,
    ) -> None:
        self.description = description
        self.quiet = quiet
        self.on_item = on_item
        self.progress: Any = None
        self._task: Any = None
        self._phase = 0
        self._guard: Any = None
        self._plain = False
        self._phase_start = self._last_line = time.monotonic()

    def __enter__(self) -> CommandProgress:
        if self.quiet:
            if self.on_item is not None:
                self._guard = report_progress(self._on_map)
                self._guard.__enter__()
            return self

        console = Console(file=sys.stderr)
        # Rich draws a live bar only on a terminal; into a log file or a pipe (nohup, the
        # steps of `evodevo reproduce`) it would show nothing until the end, so there the
        # items also get a plain line each (at most one per PLAIN_EVERY_S seconds).
        self._plain = not console.is_terminal
        self.progress = Progress(*_columns(), console=console)
        self.progress.start()
        self._guard = report_progress(self._on_map)
        self._guard.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._guard is not None:
            self._guard.__exit__(*exc)
            self._guard = None
        if self.progress is not None:
            self.progress.stop()
            self.progress = None

    def _on_map(self, done: int, total: int) -> None:
        if self.on_item is not None and done > 0:
            self.on_item(done, total)
        if self.progress is None:
            return
        if done == 0:  # a new map: the next phase
            self._phase += 1
            label = f"{self.description} (part {self._phase})"
            if self._task is None:
                self._task = self.progress.add_task(label, total=total)
            else:
                self.progress.reset(self._task, total=total, description=label)
            self._phase_start = time.monotonic()
            self._last_line = -math.inf  # the phase's first item prints at once
            return
        self.progress.update(self._task, completed=done)
        now = time.monotonic()
        if self._plain and (done == total or now - self._last_line >= PLAIN_EVERY_S):
            self._last_line = now
            self.print(plain_line(f"{self.description} (part {self._phase})", done, total,
                                  now - self._phase_start))  # fmt: skip

    def print(self, text: str) -> None:
        """A line above the bars (or on stderr when there are none and not quiet)."""
        if self.quiet:
            return
        if self.progress is not None:
            self.progress.console.print(text, markup=False, highlight=False, soft_wrap=True)
        else:
            print(text, file=sys.stderr, flush=True)


PLAIN_EVERY_S = 30.0
"""Least seconds between two plain progress lines of one phase (the last item always prints)."""


def _hms(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def plain_line(label: str, done: int, total: int, elapsed_s: float) -> str:
    """One progress line for logs, with the ETA of the phase from its mean time per item.

    >>> plain_line("training runs (part 1)", 3, 12, 1800.0)
    'training runs (part 1): 3/12 done, 0:30:00 elapsed, ETA 1:30:00'
    """
    eta_text = _hms(elapsed_s / done * (total - done)) if done > 0 else "?"
    return f"{label}: {done}/{total} done, {_hms(elapsed_s)} elapsed, ETA {eta_text}"


def generation_line(record: Any, generations: int) -> str:
    """The per-generation progress line (best/mean fitness, success, connections, speed)."""
    r = record
    retest = "" if math.isnan(r.retest_success) else f" retest {r.retest_success:.2f}"
    return (
        f"gen {r.generation + 1:>3}/{generations} best F {r.best_fitness:6.2f} "
        f"mean F {r.mean_fitness:6.2f} best success {r.best_success:.2f}{retest} "
        f"connections {r.best_connections} {r.evals_per_s:.2f} ep/s elapsed {r.elapsed_s:.0f}s"
    )


class GenerationBar(Callback):
    """An evolution callback: a bar over the generations (ETA of the run) and one line each.

    Use inside a :class:`CommandProgress` (it draws on the same display).
    """

    def __init__(self, progress: CommandProgress, generations: int, start: int = 0) -> None:
        self.cmd = progress
        self.generations = generations
        self._task = None
        if progress.progress is not None:
            self._task = progress.progress.add_task(
                "generations", total=generations, completed=start
            )

    def on_generation(self, record: Any) -> None:
        self.cmd.print(generation_line(record, self.generations))
        if self._task is not None:
            self.cmd.progress.update(self._task, completed=self.owner.generation)

    def on_end(self) -> None:
        if self._task is not None:  # an early stop ends the bar where evolution ended
            gen = self.owner.generation
            self.cmd.progress.update(self._task, total=gen, completed=gen)


class _Bar:
    """One Rich bar on stderr (nothing when quiet); a context manager."""

    def __init__(self, description: str, total: int | None, quiet: bool, completed: int = 0):
        self.description = description
        self.total = total
        self.quiet = quiet
        self.completed = completed
        self.progress: Any = None
        self._task: Any = None

    def __enter__(self) -> Any:
        if self.quiet:
            return self

        self.progress = Progress(*_columns(), console=Console(file=sys.stderr))
        self.progress.start()
        self._task = self.progress.add_task(
            self.description, total=self.total, completed=self.completed
        )
        return self

    def __exit__(self, *exc: object) -> None:
        if self.progress is not None:
            self.progress.stop()
            self.progress = None

    def update(self, completed: int, description: str | None = None) -> None:
        self.completed = completed
        if self.progress is not None:
            shown = min(completed, self.total) if self.total is not None else completed
            kwargs = {} if description is None else {"description": description}
            self.progress.update(self._task, completed=shown, **kwargs)


class TrainingBar(_Bar, Callback):
    """A Kuka baseline's training callback (:class:`~evodevo.callbacks.Callback`): a bar
    with ETA over the env-step budget (``total`` steps), or over NEAT's generations
    (``by_generation``); ``total`` None (a wall-clock budget) shows the count and elapsed time.
    """

    def __init__(
        self, description: str, total: int | None, quiet: bool = False, by_generation: bool = False
    ) -> None:
        super().__init__(description, total, quiet)
        self.by_generation = by_generation

    def on_steps(self, env_steps: int) -> None:
        if not self.by_generation:
            self.update(int(env_steps))

    def on_generation(self, row: dict[str, Any]) -> None:
        if self.by_generation:
            self.update(int(row["generation"]) + 1)


class TaskBars(Callback):
    """The BIARM trainer's progress: one bar per task over its episodes, with the last
    episode's return, epsilon and learning rate (a callback of
    :func:`evodevo.neuromod.trainer.train`); nothing when quiet. A context manager.

    >>> with TaskBars(quiet=True) as bars:
    ...     bars.on_task(0, type("Spec", (), {"env_id": "CartPole-v1", "episodes": 3})())
    >>> bars.progress is None
    True
    """

    def __init__(self, quiet: bool = False) -> None:
        self.quiet = quiet
        self.progress: Any = None
        self._bars: dict[int, Any] = {}

    def __enter__(self) -> TaskBars:
        if not self.quiet:
            columns = [*_columns(), TextColumn("{task.fields[info]}")]
            self.progress = Progress(*columns, console=Console(file=sys.stderr))
            self.progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self.progress is not None:
            self.progress.stop()
            self.progress = None

    def on_task(self, index: int, spec: Any) -> None:
        """Task ``index`` (a :class:`~evodevo.neuromod.tasks.TaskSpec`) starts."""
        if self.progress is not None:
            self._bars[index] = self.progress.add_task(
                f"[{index + 1}] {spec.env_id}", total=spec.episodes, info=""
            )

    def on_episode(self, info: Any) -> None:
        """An episode finished (an :class:`~evodevo.neuromod.task_runner.EpisodeInfo`)."""
        if self.progress is not None and info.task in self._bars:
            self.progress.update(
                self._bars[info.task],
                completed=info.episode + 1,
                info=f"return {info.ret:8.1f}  eps {info.epsilon:.3f}  lr {info.lr:.2e}",
            )


class StepBar(_Bar):
    """A bar over the steps of a script (``evodevo reproduce``), with the running step's name.

    >>> with StepBar("reproduce", 2, quiet=True) as bar:
    ...     bar.step(0, "grn evolve")
    ...     bar.step(1, "report")
    ...     bar.update(2)
    >>> bar.completed
    2
    """

    def step(self, done: int, name: str) -> None:
        """Step ``name`` starts; ``done`` steps are finished (or skipped)."""
        self.update(done, f"{self.description} [{done + 1}/{self.total}] {name}")
