"""Worker pools: in-process for one worker, a process pool with retries for more.

Every worker process runs :func:`worker_setup` first: one torch thread per process (two threads
on two cores make small-network training 10-20x slower under load), then the caller's
initializer (e.g. building its own environment, which it then reuses for every task).

A worker process exits by itself when its parent dies, however the parent dies (SIGKILL
included, when no ``finally`` runs): :func:`exit_with_parent` watches the parent's pid from a
daemon thread, so killed runs leave no idle workers behind.

A worker process that dies (killed, segfault in the simulator) breaks the pool; the pool is
rebuilt and the unfinished items are submitted again, each at most ``max_retries`` times, after
which a clear :class:`~evodevo.errors.EvodevoError` says which item kept failing. Exceptions
raised by the task function itself are not retried: they are bugs or bad input and propagate.

>>> with WorkerPool(1) as pool:
...     pool.map(abs, [-1, 2, -3])
[1, 2, 3]
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextvars import ContextVar
from typing import Any, TypeVar

from evodevo.errors import EvodevoError

__all__ = [
    "WorkerPool",
    "worker_setup",
    "set_single_thread",
    "exit_with_parent",
    "report_progress",
    "ProgressCallback",
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


T = TypeVar("T")
R = TypeVar("R")


def set_single_thread() -> None:
    """Limit torch and BLAS to one thread in this process (call once per worker)."""
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    try:
        import torch

        torch.set_num_threads(1)
        if torch.get_num_interop_threads() != 1:
            with contextlib.suppress(RuntimeError):
                torch.set_num_interop_threads(1)
    except ImportError:  # pragma: no cover - torch is a hard dependency
        pass


#: Seconds between two looks at the parent's pid in :func:`exit_with_parent`.
PARENT_POLL_S = 0.5


def exit_with_parent(parent_pid: int, poll_s: float = PARENT_POLL_S) -> None:
    """End this process when ``parent_pid`` is no longer its parent (the parent died).

    A daemon thread compares ``os.getppid()`` with ``parent_pid`` every ``poll_s`` seconds and
    calls ``os._exit`` when they differ (the orphan was re-parented to init or a subreaper).
    Unlike ``prctl(PR_SET_PDEATHSIG)`` it works on every POSIX system and does not fire when
    merely the parent *thread* that spawned the worker ends.
    """
    import threading
    import time

    if os.getppid() != parent_pid:  # the parent died before we got here
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(poll_s)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="evodevo-parent-watch", daemon=True).start()


def _local_worker_setup(
    parent_pid: int, initializer: Callable[..., None] | None, initargs: tuple[Any, ...]
) -> None:
    """Initializer of a local pool worker: die with the parent, then :func:`worker_setup`."""
    exit_with_parent(parent_pid)
    worker_setup(initializer, initargs)


def worker_setup(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    """Process initializer: ignore SIGINT (the main process stops cleanly), single thread, then
    the caller's initializer."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    set_single_thread()
    if initializer is not None:
        initializer(*initargs)


class WorkerPool:
    """Ordered ``map`` over local worker processes, surviving dead workers.

    Args:
        workers: number of processes; 1 runs everything in this process.
        initializer: called once in each worker (and once in-process when ``workers == 1``).
        initargs: arguments of ``initializer``.
        max_retries: how often one item may be resubmitted after its worker died.
    """

    def __init__(
        self,
        workers: int = 1,
        initializer: Callable[..., None] | None = None,
        initargs: tuple[Any, ...] = (),
        max_retries: int = 1,
    ) -> None:
        if workers < 1:
            raise EvodevoError(f"workers={workers} must be at least 1")
        self.workers = workers
        self.initializer = initializer
        self.initargs = initargs
        self.max_retries = max_retries
        self._executor: ProcessPoolExecutor | None = None
        self._local_ready = False
        self.restarts = 0

    def _make_executor(self) -> ProcessPoolExecutor:
        ctx = mp.get_context("spawn")
        return ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=ctx,
            initializer=_local_worker_setup,
            initargs=(os.getpid(), self.initializer, self.initargs),
        )

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        """``[fn(x) for x in items]``, in order, spread over the workers."""
        seq: Sequence[T] = list(items)
        report = progress_callback()
        report(0, len(seq))
        if self.workers == 1:
            if not self._local_ready:
                if self.initializer is not None:
                    self.initializer(*self.initargs)
                self._local_ready = True
            out = []
            for x in seq:
                out.append(fn(x))
                report(len(out), len(seq))
            return out
        results: dict[int, R] = {}
        attempts = [0] * len(seq)
        pending = list(range(len(seq)))
        while pending:
            if self._executor is None:
                self._executor = self._make_executor()
            futures: dict[Future[R], int] = {}
            broken = False
            try:
                for i in pending:
                    futures[self._executor.submit(fn, seq[i])] = i
            except BrokenProcessPool:
                broken = True
            not_done = set(futures)
            while not_done and not broken:
                done, not_done = wait(not_done, return_when=FIRST_COMPLETED)
                for fut in done:
                    try:
                        results[futures[fut]] = fut.result()
                        report(len(results), len(seq))
                    except BrokenProcessPool:
                        broken = True
            pending = [i for i in range(len(seq)) if i not in results]
            if pending:
                if not broken:  # pragma: no cover - defensive
                    raise EvodevoError("worker pool lost results without failing")
                self._executor.shutdown(wait=False, cancel_futures=True)
                self._executor = None
                self.restarts += 1
                for i in pending:
                    attempts[i] += 1
                    if attempts[i] > self.max_retries:
                        raise EvodevoError(
                            f"a worker process died {attempts[i]} times while running item {i} "
                            f"({fn.__name__}); giving up after {self.max_retries} retries. "
                            "Check memory (dmesg) or run with --workers 1 to see the error."
                        )
        return [results[i] for i in range(len(seq))]


def make_pool(
    backend: str = "local",
    workers: int = 1,
    initializer: Callable[..., None] | None = None,
    initargs: tuple[Any, ...] = (),
    max_retries: int = 1,
    address: str | None = None,
) -> Any:
    """A :class:`WorkerPool` (``backend="local"``) or a :class:`~evodevo.ray_pool.RayPool`.

    Both have the same ``map``/``close``/context-manager interface and give the same results:
    items are seeded by the caller, never by the worker that happens to run them.
    """
    if backend == "local":
        if address is not None:
            raise EvodevoError("--address only goes with --backend ray")
        return WorkerPool(workers, initializer, initargs, max_retries)
    if backend == "ray":
        from evodevo.ray_pool import RayPool

        return RayPool(workers, initializer, initargs, max_retries, address)
    raise EvodevoError(f"unknown backend {backend!r}; choose local or ray")


__all__ += ["make_pool"]
