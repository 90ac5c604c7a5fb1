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

import multiprocessing as mp
import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from evodevo.errors import EvodevoError
from evodevo.ray_pool import RayPool
from evodevo.worker import (
    ProgressCallback,
    exit_with_parent,
    local_worker_setup,
    progress_callback,
    report_progress,
    set_single_thread,
    worker_setup,
)

__all__ = [
    "WorkerPool",
    "worker_setup",
    "set_single_thread",
    "exit_with_parent",
    "report_progress",
    "ProgressCallback",
]

T = TypeVar("T")
R = TypeVar("R")


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
            initializer=local_worker_setup,
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
        return RayPool(workers, initializer, initargs, max_retries, address)
    raise EvodevoError(f"unknown backend {backend!r}; choose local or ray")


__all__ += ["make_pool"]
