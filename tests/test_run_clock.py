"""The run clock: wall and CPU time summed over the sessions of a resumed run."""

from __future__ import annotations

import time

from evodevo.run_clock import RunClock


def _burn(seconds: float) -> None:
    end = time.process_time() + seconds
    x = 0
    while time.process_time() < end:
        x += 1


def test_a_fresh_clock_counts_this_session_only():
    clock = RunClock()
    _burn(0.05)
    t = clock()
    assert t["timing_complete"] is True
    assert t["cpu_seconds"] >= 0.05 and t["wall_seconds"] >= t["cpu_seconds"] * 0.5
    assert t["wall_seconds"] < 30.0


def test_a_resumed_clock_adds_the_saved_time():
    clock = RunClock({"wall_seconds": 100.0, "cpu_seconds": 40.0, "timing_complete": True})
    _burn(0.05)
    t = clock()
    assert 100.0 < t["wall_seconds"] < 130.0
    assert 40.05 <= t["cpu_seconds"] < 70.0
    assert t["timing_complete"] is True
    later = clock()
    assert later["cpu_seconds"] >= t["cpu_seconds"]  # the clock runs on


def test_a_checkpoint_without_time_marks_the_total_incomplete():
    t = RunClock(RunClock.UNKNOWN)()
    assert t["timing_complete"] is False
    assert t["wall_seconds"] < 30.0
