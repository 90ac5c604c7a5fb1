"""TensorBoard as an optional sink beside the CSV files (which stay the source of truth).

``--tensorboard DIR`` on ``biarm train`` and ``grn evolve`` writes the numbers of
``metrics.csv`` and ``history.csv`` as TensorBoard scalars
(``tensorboard --logdir DIR``), through ``torch.utils.tensorboard`` (needs the ``tensorboard``
package: ``pip install 'evodevo[tensorboard]'``). Nothing is written inside a hot loop: one
event per training episode (BIARM) or per generation (evolution), flushed as TensorBoard does.

:class:`EpisodeScalars` is a BIARM episode hook, :class:`GenerationScalars` an evolution hook;
both wrap a :func:`writer`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from evodevo.errors import EvodevoError

__all__ = ["writer", "EpisodeScalars", "GenerationScalars", "read_scalars"]


def writer(logdir: str | Path) -> Any:
    """A ``SummaryWriter`` for ``logdir``, or a one-line error naming the missing package."""
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        raise EvodevoError(
            "--tensorboard needs the tensorboard package: pip install 'evodevo[tensorboard]' "
            "(or pip install tensorboard)"
        ) from None
    Path(logdir).mkdir(parents=True, exist_ok=True)
    return SummaryWriter(log_dir=str(logdir))


class EpisodeScalars:
    """BIARM hook: after every training episode, ``task{i}_{env}/return|length|epsilon|lr``.

    The step is the episode's index within its task. Chain it with another hook through
    ``then`` (e.g. the progress bar).
    """

    def __init__(self, logdir: str | Path, then: Callable[[Any], None] | None = None) -> None:
        self.tb = writer(logdir)
        self.then = then

    def __call__(self, e: Any) -> None:
        prefix = f"task{e.task}_{e.env_id}"
        for name, value in (
            ("return", e.ret),
            ("length", e.length),
            ("epsilon", e.epsilon),
            ("lr", e.lr),
        ):
            self.tb.add_scalar(f"{prefix}/{name}", float(value), e.episode)
        if self.then is not None:
            self.then(e)

    def close(self) -> None:
        self.tb.close()


class GenerationScalars:
    """Evolution hook: the ``history.csv`` row of every generation as scalars (step: generation)."""

    FIELDS = (
        "best_fitness",
        "mean_fitness",
        "best_success",
        "mean_success",
        "best_connections",
        "retest_success",
        "evals_per_s",
    )

    def __init__(self, logdir: str | Path) -> None:
        self.tb = writer(logdir)

    def on_generation(self, evo: Any, record: Any) -> None:
        for name in self.FIELDS:
            value = float(getattr(record, name))
            if not math.isnan(value):
                self.tb.add_scalar(f"evolution/{name}", value, record.generation)
        self.tb.flush()

    def on_end(self, evo: Any) -> None:
        self.tb.close()


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
