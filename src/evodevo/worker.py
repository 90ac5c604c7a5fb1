"""What every worker process runs first, and how a pool reports progress (SPEC §2.1, §1.6).

:func:`worker_setup` is the initializer of every worker, local or Ray: it ignores SIGINT (the
main process stops cleanly), limits torch and BLAS to one thread (two threads on two cores make
small-network training 10-20x slower under load), then runs the caller's initializer.
:func:`exit_with_parent` ends a local worker whose parent died. :func:`report_progress` lets a
command watch every pool ``map`` inside a block without the code that calls ``map`` knowing.

>>> seen = []
>>> with report_progress(lambda done, total: seen.append((done, total))):
...     progress_callback()(1, 2)
>>> seen
[(1, 2)]
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from typing import Any

import torch

__all__ = [
    "ProgressCallback",
    "report_progress",
    "progress_callback",
    "set_single_thread",
    "PARENT_POLL_S",
    "exit_with_parent",
    "worker_setup",
    "local_worker_setup",
]

#: Told ``(done, total)`` after every finished item of a ``map`` (``done == 0`` when it starts).
ProgressCallback = Callable[[int, int], None]
_PROGRESS: ContextVar[ProgressCallback | None] = ContextVar("evodevo_progress", default=None)


@contextlib.contextmanager
def report_progress(callback: ProgressCallback | None) -> Iterator[None]:
    """Within the block, every pool ``map`` reports its items to ``callback`` (e.g. a bar).

    The pools know how far a ``map`` is; the code that calls ``map`` (an evaluator, a grid of
    runs) needs no change for a command to show progress.
    """
    token = _PROGRESS.set(callback)
    try:
        yield
    finally:
        _PROGRESS.reset(token)


def progress_callback() -> ProgressCallback:
    """The active callback of :func:`report_progress` (a no-op outside one)."""
    return _PROGRESS.get() or (lambda done, total: None)


def set_single_thread() -> None:
    """Limit torch and BLAS to one thread in this process (call once per worker)."""
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    torch.set_num_threads(1)
    if torch.get_num_interop_threads() != 1:
        with contextlib.suppress(RuntimeError):
            torch.set_num_interop_threads(1)


#: Seconds between two looks at the parent's pid in :func:`exit_with_parent`.
PARENT_POLL_S = 0.5


def exit_with_parent(parent_pid: int, poll_s: float = PARENT_POLL_S) -> None:
    """End this process when ``parent_pid`` is no longer its parent (the parent died).

    A daemon thread compares ``os.getppid()`` with ``parent_pid`` every ``poll_s`` seconds and
    calls ``os._exit`` when they differ (the orphan was re-parented to init or a subreaper).
    Unlike ``prctl(PR_SET_PDEATHSIG)`` it works on every POSIX system and does not fire when
    merely the parent *thread* that spawned the worker ends.
    """
    if os.getppid() != parent_pid:  # the parent died before we got here
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(poll_s)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="evodevo-parent-watch", daemon=True).start()


def local_worker_setup(
    parent_pid: int, initializer: Callable[..., None] | None, initargs: tuple[Any, ...]
) -> None:
    """Initializer of a local pool worker: die with the parent, then :func:`worker_setup`."""
    exit_with_parent(parent_pid)
    worker_setup(initializer, initargs)


def worker_setup(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    """Process initializer: ignore SIGINT (the main process stops cleanly), single thread, then
    the caller's initializer."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    set_single_thread()
    if initializer is not None:
        initializer(*initargs)
