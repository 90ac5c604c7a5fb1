"""a run killed with SIGKILL mid-generation and resumed ends as an uninterrupted run.

SIGKILL cannot be caught, so nothing is flushed or checkpointed at the kill: what survives is the
last generation's atomic checkpoint (``checkpoints/checkpoint.npz``). The victim is killed while
it evaluates a generation (half a generation's evaluation time after ``history.csv`` grew), the
checkpoint is checked to be readable and consistent, and ``evolve --resume`` must then give the
same ``history.csv`` and ``summary.json`` histories as the reference run, wall-time fields aside.
With ``--workers 2`` the whole process group (main process and pool workers) is killed.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from evodevo.grn.genome import load_arrays

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "grn_pendulum.yaml"
GENERATIONS = 5
# 6 genomes x 10 Pendulum episodes: a generation takes a few tenths of a second, long enough to
# be killed in the middle of one
ARGS = [
    "--config",
    str(CONFIG),
    "--population",
    "6",
    "--generations",
    str(GENERATIONS),
    "--episodes",
    "10",
    "--seed",
    "3",
    "--quiet",
]
WALL_COLUMNS = {"eval_s", "evals_per_s", "elapsed_s"}
WALL_SUMMARY = {"wall_s", "machine"}
TIMEOUT = 240


def _evolve(out: Path, *extra: str, new_session: bool = False) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "evodevo", "grn", "evolve", *ARGS, *extra, "--out", str(out)]
    return subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=new_session,
    )


def _rows(run: Path) -> list[dict[str, str]]:
    path = run / "history.csv"
    if not path.is_file():
        return []
    with path.open() as fh:
        return list(csv.DictReader(fh))


def _history(run: Path) -> list[dict[str, str]]:
    """``history.csv`` without its wall-time columns."""
    return [{k: v for k, v in r.items() if k not in WALL_COLUMNS} for r in _rows(run)]


def _summary(run: Path) -> dict[str, object]:
    s = json.loads((run / "summary.json").read_text())
    return {k: v for k, v in s.items() if k not in WALL_SUMMARY}


def _kill_mid_generation(proc: subprocess.Popen[str], run: Path, kill: Callable[[], None]) -> int:
    """Wait for a new ``history.csv`` row, then kill half a generation later; rows at the kill."""
    start = len(_rows(run))
    # a generation to spare where there is room: on a loaded machine the generation after the
    # kill's trigger can finish before the kill lands, and then it must not be the last one;
    # and a fresh run's wait is timed on its second generation, not on the first (which pays
    # for starting the worker pool and would let every later generation finish first)
    last = GENERATIONS - 1 if start < GENERATIONS - 2 else GENERATIONS
    first = 2 if start == 0 else start + 1
    deadline = time.time() + TIMEOUT
    while time.time() < deadline and proc.poll() is None:
        rows = _rows(run)
        if first <= len(rows) < last:
            time.sleep(0.5 * float(rows[-1]["eval_s"]))  # mid-way through the next generation
            kill()
            proc.wait(timeout=60)
            return len(rows)
        time.sleep(0.01)
    out = proc.communicate(timeout=60)[0] if proc.poll() is not None else ""
    pytest.fail(f"the victim finished or stalled before it could be killed:\n{out}")


def _check_checkpoint(run: Path, seen: int) -> int:
    """The checkpoint left by the kill loads, matches history.csv and is not the last one.

    ``seen`` generations were in history.csv when the kill was sent: the checkpoint holds at
    least those (a generation in history.csv is never lost; more may have finished before the
    kill landed, e.g. after a slow first generation that paid for starting the workers).
    """
    _, meta = load_arrays(run / "checkpoints" / "checkpoint.npz", "grn_checkpoint")
    generation = int(meta["generation"])
    assert seen <= generation < GENERATIONS
    assert not meta["stopped_early"]
    assert len(meta["history"]) == generation
    rows = _rows(run)
    # history.csv is written right after the checkpoint: a kill in between leaves it one behind
    assert len(rows) in (generation, generation - 1)
    for row, rec in zip(rows, meta["history"], strict=False):
        assert float(row["best_fitness"]) == rec["best_fitness"]
    assert not (run / "summary.json").is_file() or not _summary_done(run)
    return generation


def _summary_done(run: Path) -> bool:
    return bool(json.loads((run / "summary.json").read_text()).get("done"))


def _resume(run: Path, *extra: str) -> None:
    proc = _evolve(run, "--resume", *extra)
    out = proc.communicate(timeout=TIMEOUT)[0]
    assert proc.returncode == 0, out


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Callable[[], Path]]:
    """The uninterrupted run, started once for both tests (it runs while they do)."""
    run = tmp_path_factory.mktemp("reference") / "run"
    proc = _evolve(run)
    box: dict[str, Path] = {}

    def wait() -> Path:
        if "run" not in box:
            out = proc.communicate(timeout=TIMEOUT)[0]
            assert proc.returncode == 0, out
            box["run"] = run
        return box["run"]

    yield wait
    if proc.poll() is None:
        proc.kill()
        proc.wait()


def _assert_same_as_reference(run: Path, ref: Path) -> None:
    assert len(_history(ref)) == GENERATIONS
    assert _history(run) == _history(ref)
    a, b = _summary(ref), _summary(run)
    assert b["fitness_history"] == a["fitness_history"]
    assert b["success_history"] == a["success_history"]
    assert b == a  # every other field too (episodes_run, env_steps, budget, ...)
    assert (run / "best_genome.npz").read_bytes() == (ref / "best_genome.npz").read_bytes()


def test_sigkill_mid_generation_then_resume_matches_uninterrupted(tmp_path, reference):
    run = tmp_path / "victim"
    proc = _evolve(run)
    seen = _kill_mid_generation(proc, run, proc.kill)
    assert proc.returncode == -signal.SIGKILL
    first = _check_checkpoint(run, seen)
    # killed again, mid-generation of the resumed run
    proc = _evolve(run, "--resume")
    seen = _kill_mid_generation(proc, run, proc.kill)
    if proc.returncode == -signal.SIGKILL:
        assert _check_checkpoint(run, seen) >= first
    _resume(run)
    _assert_same_as_reference(run, reference())


def _group_alive(pgid: int) -> list[int]:
    """Processes of group ``pgid`` that are still running (zombies excluded)."""
    alive = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(entry.name))
    return alive


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs /proc (Linux)")
def test_sigkill_of_process_group_with_workers_then_resume_matches(tmp_path, reference):
    run = tmp_path / "victim"
    proc = _evolve(run, "--workers", "2", new_session=True)
    pgid = proc.pid  # start_new_session: the main process leads its own group
    seen = _kill_mid_generation(proc, run, lambda: os.killpg(pgid, signal.SIGKILL))
    assert proc.returncode == -signal.SIGKILL
    deadline = time.time() + 30
    while _group_alive(pgid) and time.time() < deadline:
        time.sleep(0.1)
    assert not _group_alive(pgid), "pool workers survived the kill of their process group"
    _check_checkpoint(run, seen)
    _resume(run, "--workers", "2")
    _assert_same_as_reference(run, reference())
