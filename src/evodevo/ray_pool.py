"""Ray backend for :class:`~evodevo.parallel.WorkerPool`'s interface (Ray is an optional extra).

Each Ray actor runs :func:`~evodevo.parallel.worker_setup` once (one torch thread, then the
caller's initializer, e.g. building its own environment) and is reused for every item. Items are
dealt to idle actors; an actor that dies is replaced and its item resubmitted, at most
``max_retries`` times. ``address=None`` starts a local Ray instance with ``workers`` CPUs;
``address="auto"`` or ``"HOST:PORT"`` joins a running cluster (``ray start --head``).

Ray is imported only when a :class:`RayPool` is created.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable, Iterable
from typing import Any, TypeVar

from evodevo.errors import EvodevoError
from evodevo.worker import progress_callback, worker_setup

__all__ = ["RayPool", "local_ray_options", "use_cluster_token"]

T = TypeVar("T")
R = TypeVar("R")


def _import_ray() -> Any:
    try:
        import ray  # optional dependency: ray
    except ImportError:
        raise EvodevoError(
            "--backend ray needs Ray: pip install 'evodevo[ray]' (or use --backend local)"
        ) from None
    return ray


class _Runner:
    """The actor body: set up once, then run items."""

    def __init__(self, initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
        worker_setup(initializer, initargs)

    def run(self, fn: Callable[[Any], Any], item: Any) -> Any:
        return fn(item)

    def pid(self) -> int:
        return os.getpid()


def local_ray_options(num_cpus: int) -> dict[str, Any]:
    """``ray.init`` options of a private local Ray instance (also used by the benchmarks).

    Loopback only; workers see the driver's ``sys.path`` (as the spawn-based local pool does),
    so functions from any importable module run. Ray renices its workers to 15 by default:
    beside any other busy process (e.g. a second experiment) they then get a few per cent of a
    core (measured: 2 Ray actors took 518 s where 2 pool workers took 49 s on a loaded
    machine). Our workers are the job, so they run at the driver's priority.
    """
    return {
        "num_cpus": num_cpus,
        "_node_ip_address": "127.0.0.1",
        "runtime_env": {"env_vars": {"PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}},
        "_system_config": {"worker_niceness": 0},
    }


def use_cluster_token() -> bool:
    """After a refused join: switch token authentication on if this machine has a token.

    ``ray start --head`` enables token authentication when a token exists (``~/.ray/auth_token``
    is written by any private local Ray, e.g. an earlier ``--backend ray`` run), but a driver
    joining with ``ray.init(address=...)`` sends it only with ``RAY_AUTH_MODE=token``; without
    it the head answers "Missing authorization header". So a join is tried as configured first
    (token mode on a head without authentication breaks its workers' calls back to the driver),
    and only when refused, with ``RAY_AUTH_MODE`` unset and a token found (that file,
    ``RAY_AUTH_TOKEN`` or ``RAY_AUTH_TOKEN_PATH``), token mode is switched on for this process
    and the join retried. Returns True if it switched token mode on.
    """
    if os.environ.get("RAY_AUTH_MODE") is not None:  # explicit: respected as it is
        return False
    try:  # optional dependency: ray
        from ray._private.authentication.authentication_token_setup import (
            maybe_enable_token_auth_if_token_available,
        )
    except ImportError:  # a Ray without token authentication
        return False
    return bool(maybe_enable_token_auth_if_token_available(warn_if_disabled=False))


class RayPool:
    """Ordered ``map`` over Ray actors that each own their environment.

    Args:
        workers: number of actors.
        initializer: called once in each actor.
        initargs: its arguments.
        max_retries: how often one item may be resubmitted after its actor died.
        address: ``None`` for a local instance, ``"auto"`` or ``"HOST:PORT"`` for a cluster.
    """

    def __init__(
        self,
        workers: int = 2,
        initializer: Callable[..., None] | None = None,
        initargs: tuple[Any, ...] = (),
        max_retries: int = 1,
        address: str | None = None,
    ) -> None:
        if workers < 1:
            raise EvodevoError(f"workers={workers} must be at least 1")
        self.ray = _import_ray()
        self.workers = workers
        self.initializer = initializer
        self.initargs = initargs
        self.max_retries = max_retries
        self.restarts = 0
        self._owns_ray = False
        if not self.ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            if address is None:
                kwargs.update(local_ray_options(workers))
            else:
                kwargs["address"] = address
            try:
                try:
                    self.ray.init(**kwargs)
                except ConnectionError:
                    # a head with token authentication refuses a driver without the token
                    if address is None or not use_cluster_token():
                        raise
                    self.ray.init(**kwargs)
            except ConnectionError as exc:
                raise EvodevoError(
                    f"cannot reach a Ray cluster at {address!r} ({exc}); start one with "
                    "'ray start --head'. A head started with token authentication (Ray's "
                    "default) needs its token here: ~/.ray/auth_token, RAY_AUTH_TOKEN or "
                    f"RAY_AUTH_TOKEN_PATH, with RAY_AUTH_MODE=token (now "
                    f"{os.environ.get('RAY_AUTH_MODE', 'unset')}); or use --backend local"
                ) from None
            self._owns_ray = True
        self._actor_cls = self.ray.remote(num_cpus=1)(_Runner)
        self.actors = [self._new_actor() for _ in range(workers)]

    def _new_actor(self) -> Any:
        return self._actor_cls.remote(self.initializer, self.initargs)

    def __enter__(self) -> RayPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        for a in self.actors:
            with contextlib.suppress(Exception):  # the actor may already be gone
                self.ray.kill(a)
        self.actors = []
        if self._owns_ray:
            self.ray.shutdown()
            self._owns_ray = False

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        """``[fn(x) for x in items]`` in order, one item per idle actor at a time."""
        ray = self.ray
        from ray.exceptions import RayActorError  # optional dependency: ray

        seq = list(items)
        report = progress_callback()
        report(0, len(seq))
        results: dict[int, R] = {}
        attempts = [0] * len(seq)
        queue = list(range(len(seq)))
        running: dict[Any, tuple[int, int]] = {}  # ref -> (item, actor slot)
        idle = list(range(len(self.actors)))
        while queue or running:
            while queue and idle:
                slot = idle.pop()
                i = queue.pop(0)
                running[self.actors[slot].run.remote(fn, seq[i])] = (i, slot)
            done, _ = ray.wait(list(running), num_returns=1)
            for ref in done:
                i, slot = running.pop(ref)
                try:
                    results[i] = ray.get(ref)
                    report(len(results), len(seq))
                except RayActorError:
                    self.restarts += 1
                    attempts[i] += 1
                    if attempts[i] > self.max_retries:
                        raise EvodevoError(
                            f"a Ray actor died {attempts[i]} times while running item {i} "
                            f"({getattr(fn, '__name__', fn)}); giving up after {self.max_retries} retries"
                        ) from None
                    self.actors[slot] = self._new_actor()
                    queue.insert(0, i)
                idle.append(slot)
        return [results[i] for i in range(len(seq))]
