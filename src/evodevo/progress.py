"""Progress with an ETA for long commands (Rich, on stderr; nothing at all when quiet).

:class:`CommandProgress` shows one bar for the work in flight: every ``map`` of a worker pool
inside its block (an evaluation of genomes, an ablation, a grid of training runs) reports its
items through :func:`evodevo.parallel.report_progress`, so the code that evaluates needs no
progress calls of its own. Each new ``map`` restarts the bar as the next phase; the columns
show items done, elapsed time and the time remaining for the phase. :class:`GenerationBar` adds
a bar over the generations of an evolution with the ETA of the whole run, and prints the
per-generation line above the bars. Machine-readable output (``--json``, tables) stays on
stdout, untouched.
"""

from __future__ import annotations

import sys
from typing import Any

from evodevo.parallel import report_progress

__all__ = ["CommandProgress", "GenerationBar", "generation_line"]


def _columns() -> list[Any]:
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

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
    """

    def __init__(self, description: str, quiet: bool = False) -> None:
        self.description = description
        self.quiet = quiet
        self.progress: Any = None
        self._task: Any = None
        self._phase = 0
        self._guard: Any = None

    def __enter__(self) -> CommandProgress:
        if self.quiet:
            return self
        from rich.console import Console
        from rich.progress import Progress

        self.progress = Progress(*_columns(), console=Console(file=sys.stderr))
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
        if self.progress is None:
            return
        if done == 0:  # a new map: the next phase
            self._phase += 1
            label = f"{self.description} (part {self._phase})"
            if self._task is None:
                self._task = self.progress.add_task(label, total=total)
            else:
                self.progress.reset(self._task, total=total, description=label)
            return
        self.progress.update(self._task, completed=done)

    def print(self, text: str) -> None:
        """A line above the bars (or on stderr when there are none and not quiet)."""
        if self.quiet:
            return
        if self.progress is not None:
            self.progress.console.print(text, markup=False, highlight=False, soft_wrap=True)
        else:
            print(text, file=sys.stderr, flush=True)


def generation_line(record: Any, generations: int) -> str:
    """The per-generation progress line (best/mean fitness, success, connections, speed)."""
    import math

    r = record
    retest = "" if math.isnan(r.retest_success) else f" retest {r.retest_success:.2f}"
    return (
        f"gen {r.generation + 1:>3}/{generations} best F {r.best_fitness:6.2f} "
        f"mean F {r.mean_fitness:6.2f} best success {r.best_success:.2f}{retest} "
        f"connections {r.best_connections} {r.evals_per_s:.2f} ep/s elapsed {r.elapsed_s:.0f}s"
    )


class GenerationBar:
    """An evolution hook: a bar over the generations (ETA of the run) and one line each.

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

    def on_generation(self, evo: Any, record: Any) -> None:
        self.cmd.print(generation_line(record, self.generations))
        if self._task is not None:
            self.cmd.progress.update(self._task, completed=evo.generation)

    def on_end(self, evo: Any) -> None:
        if self._task is not None:  # an early stop ends the bar where evolution ended
            self.cmd.progress.update(self._task, total=evo.generation, completed=evo.generation)
