"""One callback protocol for every training loop (STYLE.md point 4; Stable-Baselines3's
``BaseCallback`` idea).

A loop calls :meth:`Callback.init` once with itself (the BIARM trainer's agent, the GRN's
:class:`~evodevo.grn.evolution.Evolution`, a Kuka baseline's run), then the methods that fit
what it does; a callback overrides the ones it needs, the others do nothing. Progress bars,
TensorBoard exporters, checkpoints and graceful stops are callbacks, so loops stay short. The
run directory's CSV files are written before any callback is called and stay the source of
truth.

>>> seen = []
>>> class Steps(Callback):
...     def on_steps(self, env_steps: int) -> None:
...         seen.append(env_steps)
>>> CallbackList([Steps(), Callback()]).on_steps(64)
>>> seen
[64]

A plain function serves as well (here on the BIARM trainer's episodes, e.g. to log them elsewhere):

>>> CallbackList([FunctionCallback(on_episode=seen.append)]).on_episode("episode info")
>>> seen
[64, 'episode info']
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["Callback", "CallbackList", "FunctionCallback"]


class Callback:
    """Callbacks of a training loop; override what you need.

    Attributes:
        owner: the loop this callback watches (set by :meth:`init`), e.g. the GRN evolution
            whose state a checkpoint callback saves.
    """

    owner: Any = None

    def init(self, owner: Any) -> None:
        """The loop ``owner`` starts with this callback."""
        self.owner = owner

    def on_task(self, index: int, spec: Any) -> None:
        """BIARM: task ``index`` (a :class:`~evodevo.neuromod.tasks.TaskSpec`) starts or resumes."""

    def on_episode(self, info: Any) -> None:
        """BIARM: a training episode finished (an :class:`~evodevo.neuromod.task_runner.EpisodeInfo`)."""

    def on_steps(self, env_steps: int) -> None:
        """Kuka baselines: training env steps so far (SB3: every step; NEAT: every generation)."""

    def on_curve_row(self, row: dict[str, Any]) -> None:
        """Kuka baselines: a new row of ``learning_curve.csv``."""

    def on_generation(self, record: Any) -> None:
        """Evolution: a generation was evaluated (the GRN's
        :class:`~evodevo.grn.evolution.GenerationRecord`, NEAT's ``history.csv`` row)."""

    def on_end(self) -> None:
        """The loop ends (budget spent, early stop)."""


class CallbackList(Callback):
    """Several callbacks called in order (what a loop holds)."""

    def __init__(self, callbacks: Iterable[Callback | None] = ()) -> None:
        self.callbacks = [c for c in callbacks if c is not None]

    def init(self, owner: Any) -> None:
        super().init(owner)
        for c in self.callbacks:
            c.init(owner)

    def on_task(self, index: int, spec: Any) -> None:
        for c in self.callbacks:
            c.on_task(index, spec)

    def on_episode(self, info: Any) -> None:
        for c in self.callbacks:
            c.on_episode(info)

    def on_steps(self, env_steps: int) -> None:
        for c in self.callbacks:
            c.on_steps(env_steps)

    def on_curve_row(self, row: dict[str, Any]) -> None:
        for c in self.callbacks:
            c.on_curve_row(row)

    def on_generation(self, record: Any) -> None:
        for c in self.callbacks:
            c.on_generation(record)

    def on_end(self) -> None:
        for c in self.callbacks:
            c.on_end()


class FunctionCallback(Callback):
    """Plain functions as callbacks, by event name: ``FunctionCallback(on_episode=fn)`` calls
    ``fn(info)`` after every BIARM training episode; the events not named do nothing.

    Raises:
        TypeError: a name that is not an event of :class:`Callback` (``on_task``,
            ``on_episode``, ``on_steps``, ``on_curve_row``, ``on_generation``, ``on_end``).
    """

    EVENTS = ("on_task", "on_episode", "on_steps", "on_curve_row", "on_generation", "on_end")

    def __init__(self, **functions: Callable[..., Any]) -> None:
        unknown = sorted(set(functions) - set(self.EVENTS))
        if unknown:
            raise TypeError(
                f"FunctionCallback: unknown event(s) {', '.join(unknown)}; the events are "
                f"{', '.join(self.EVENTS)}"
            )
        for name, fn in functions.items():
            setattr(self, name, fn)
