"""Shared test fixtures."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
import pytest
import torch


@pytest.fixture(scope="module")
def one_torch_thread() -> Iterator[None]:
    """One torch thread, as the CLI and workers use (two threads on 2 cores make DQN many times
    slower under load); restored afterwards. Use with
    ``pytestmark = pytest.mark.usefixtures("one_torch_thread")``."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


try:  # property tests draw the same examples on every run: a CI failure reproduces locally
    from hypothesis import settings

    settings.register_profile("evodevo", derandomize=True, deadline=None)
    settings.load_profile("evodevo")
except ImportError:  # pragma: no cover - hypothesis is a dev dependency
    pass


@pytest.fixture(scope="session", autouse=True)
def fused_kernel_built() -> None:
    """Build (or load) the fused BIARM lateral kernel once, before any test: on a fresh machine
    the first build takes ~30-60 s and prints a notice, which must not land in the stderr of a
    CLI test that checks its one error line (those subprocesses then load the cached build)."""
    from evodevo.neuromod import kernels

    kernels.load()


GridRuns = Callable[..., dict]


@pytest.fixture
def grid_runs() -> GridRuns:
    """Build a synthetic BIARM grid ``{variant: {seed: {"tasks": [...]}}}`` whose final returns
    are −100 + the variant's offset per task + N(0, 1) noise: ``grid_runs(tasks, offsets,
    seeds=10)``."""

    def make(tasks: list[str], offsets: dict[str, list[float]], seeds: int = 10) -> dict:
        rng = np.random.default_rng(0)
        return {
            v: {
                s: {
                    "tasks": [
                        {"env_id": t, "final_return": -100.0 + off + rng.normal()}
                        for t, off in zip(tasks, per, strict=True)
                    ]
                }
                for s in range(seeds)
            }
            for v, per in offsets.items()
        }

    return make
