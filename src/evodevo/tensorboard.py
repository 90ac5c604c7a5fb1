"""TensorBoard as an optional sink beside the CSV files (which stay the source of truth).

``--tensorboard DIR`` on ``biarm train``, ``biarm compare``, ``grn evolve`` and
``baselines kuka`` writes the numbers of ``metrics.csv``, ``history.csv`` and
``learning_curve.csv`` as TensorBoard scalars (``tensorboard --logdir DIR``), through
``torch.utils.tensorboard`` (needs the ``tensorboard`` package:
``pip install 'evodevo[tensorboard]'``). Nothing is written inside a hot loop: one event per
training episode (BIARM), per generation (evolution) or per learning-curve point (baselines),
flushed as TensorBoard does.

:class:`EpisodeScalars` is a BIARM episode callback, :class:`GenerationScalars` an evolution callback,
:class:`CurveScalars` a baseline-training callback; all wrap a :func:`writer`. :class:`RunsExporter`
copies the ``metrics.csv`` of every finished run of a ``biarm compare`` grid (whose runs train in
worker processes) into ``DIR/<run>``, as each run finishes.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from evodevo.callbacks import Callback
from evodevo.errors import EvodevoError
from evodevo.runs import make_dir

__all__ = [
    "writer",
    "EpisodeScalars",
    "GenerationScalars",
    "CurveScalars",
    "RunsExporter",
    "read_scalars",
]


def _summary_writer() -> Any:
    """``SummaryWriter``, or a one-line error naming the missing package."""
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        raise EvodevoError(
            "--tensorboard needs the tensorboard package: pip install 'evodevo[tensorboard]' "
            "(or pip install tensorboard)"
        ) from None
    return SummaryWriter


def writer(logdir: str | Path) -> Any:
    """A ``SummaryWriter`` for ``logdir``, or a one-line error naming the missing package."""
    summary_writer = _summary_writer()
    return summary_writer(log_dir=str(make_dir(logdir, "--tensorboard")))


class EpisodeScalars(Callback):
    """BIARM callback: after every training episode, ``task{i}_{env}/return|length|epsilon|lr``.

    The step is the episode's index within its task.
    """

    def __init__(self, logdir: str | Path) -> None:
        self.tb = writer(logdir)

    def on_episode(self, e: Any) -> None:
        prefix = f"task{e.task}_{e.env_id}"
        for name, value in (
            ("return", e.ret),
            ("length", e.length),
            ("epsilon", e.epsilon),
            ("lr", e.lr),
        ):
            self.tb.add_scalar(f"{prefix}/{name}", float(value), e.episode)

    def close(self) -> None:
        self.tb.close()


class GenerationScalars(Callback):
    """Evolution callback: the ``history.csv`` row of every generation as scalars (step:
    generation)."""

    FIELDS = (
        "best_fitness",
        "mean_fitness",
        "best_success",
        "mean_success",
        "best_connections",
        "retest_success",
        "evals_per_s",
        "episodes_saved",
    )

    def __init__(self, logdir: str | Path) -> None:
        self.tb = writer(logdir)

    def on_generation(self, record: Any) -> None:
        for name in self.FIELDS:
            value = float(getattr(record, name))
            if not math.isnan(value):
                self.tb.add_scalar(f"evolution/{name}", value, record.generation)
        self.tb.flush()

    def on_end(self) -> None:
        self.tb.close()


class CurveScalars(Callback):
    """Baseline-training callback (:class:`~evodevo.callbacks.Callback`).

    Every ``learning_curve.csv`` row as ``baseline/success``, ``baseline/mean_reward`` and
    ``baseline/train_s`` (step: env steps), and NEAT's ``history.csv`` rows as
    ``neat/best_fitness`` etc. (step: generation).
    """

    CURVE = ("success", "mean_reward", "train_s")
    NEAT = ("best_fitness", "mean_fitness", "best_success", "mean_success", "best_connections")

    def __init__(self, logdir: str | Path) -> None:
        self.tb = writer(logdir)

    def _add(self, tag: str, value: Any, step: int) -> None:
        v = float(value)
        if not math.isnan(v):
            self.tb.add_scalar(tag, v, step)

    def on_curve_row(self, row: dict[str, Any]) -> None:
        for name in self.CURVE:
            self._add(f"baseline/{name}", row[name], int(row["env_steps"]))
        self.tb.flush()

    def on_generation(self, row: dict[str, Any]) -> None:
        for name in self.NEAT:
            self._add(f"neat/{name}", row[name], int(row["generation"]))
        self.tb.flush()

    def close(self) -> None:
        self.tb.close()


class RunsExporter:
    """``metrics.csv`` of every finished run under ``runs`` into ``logdir/<run folder>``.

    Tags as :class:`EpisodeScalars` (``task{i}_{env}/return|length|epsilon|lr``, step: episode).
    A run is exported once: when ``summary.json`` exists and its log folder holds no events yet
    (so a resumed grid does not write a finished run twice).
    """

    FIELDS = ("return", "length", "epsilon", "lr")

    def __init__(self, runs: str | Path, logdir: str | Path) -> None:
        _summary_writer()  # fail before any training, in one line, when tensorboard is missing
        self.runs = Path(runs)
        self.logdir = make_dir(logdir, "--tensorboard")

    def on_item(self, done: int, total: int) -> None:
        """A :class:`~evodevo.progress.CommandProgress` callback: a run of the grid finished."""
        self.export_finished()

    def export_finished(self) -> list[str]:
        """Export the runs finished since the last call; returns their folder names."""
        import csv

        done: list[str] = []
        if not self.runs.is_dir():
            return done
        for run in sorted(self.runs.iterdir()):
            target = self.logdir / run.name
            if not (run / "summary.json").is_file() or not (run / "metrics.csv").is_file():
                continue
            if any(target.glob("events.out.tfevents.*")):
                continue
            tb = writer(target)
            try:
                with (run / "metrics.csv").open() as fh:
                    for r in csv.DictReader(fh):
                        prefix = f"task{r['task']}_{r['env_id']}"
                        for name in self.FIELDS:
                            if r.get(name) not in (None, ""):
                                tb.add_scalar(f"{prefix}/{name}", float(r[name]), int(r["episode"]))
            finally:
                tb.close()
            done.append(run.name)
        return done


def read_scalars(logdir: str | Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar series under ``logdir`` as ``{tag: [(step, value), ...]}`` (for tests)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    out: dict[str, list[tuple[int, float]]] = {}
    for run in sorted({p.parent for p in Path(logdir).rglob("events.out.tfevents.*")}):
        acc = EventAccumulator(str(run))
        acc.Reload()
        for tag in acc.Tags()["scalars"]:
            out.setdefault(tag, []).extend((e.step, e.value) for e in acc.Scalars(tag))
    return out
