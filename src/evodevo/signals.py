"""Graceful stop on SIGINT/SIGTERM: finish the current unit, checkpoint, exit cleanly.

Inside :class:`GracefulStop` the first SIGINT or SIGTERM only sets :attr:`GracefulStop.requested`;
a training loop checks it after each unit of work (a generation, an episode, a task) — after
that unit's checkpoint — and raises :class:`StopRequested`, which the CLI reports as a clean
stop with the command to resume. A second signal interrupts at once (KeyboardInterrupt).

Worker processes ignore SIGINT (see :func:`evodevo.parallel.worker_setup`), so Ctrl-C in a
terminal stops the main process cleanly instead of killing the pool mid-task.

>>> with GracefulStop() as stop:
...     stop.requested
False
"""

from __future__ import annotations

import signal
import threading
from types import FrameType
from typing import Any

from evodevo.errors import EvodevoError

__all__ = ["GracefulStop", "StopRequested"]


class StopRequested(EvodevoError):
    """Raised by a loop that stopped cleanly at a signal's request (state is checkpointed)."""


class GracefulStop:
    """Context manager turning the first SIGINT/SIGTERM into a flag (main thread only)."""

    def __init__(self) -> None:
        self.requested = False
        self.signal_name = ""
        self._old: dict[int, Any] = {}

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        self.signal_name = signal.Signals(signum).name
        print(
            f"\n{self.signal_name}: finishing the current unit and checkpointing "
            "(send again to stop at once)",
            flush=True,
        )

    def __enter__(self) -> GracefulStop:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._old[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()

    def check(self, what: str, resume_hint: str) -> None:
        """Raise :class:`StopRequested` if a stop was requested (call after a checkpoint)."""
        if self.requested:
            raise StopRequested(f"stopped on {self.signal_name} after {what}; {resume_hint}")
