"""SIGTERM stops an evolution after a checkpointed generation; --resume ends identically."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "grn_pendulum.yaml"
ARGS = [
    "--config",
    str(CONFIG),
    "--population",
    "4",
    "--generations",
    "6",
    "--episodes",
    "2",
    "--seed",
    "3",
]


def _evolve(out: Path, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "evodevo", "grn", "evolve", *ARGS, *extra, "--out", str(out)]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def test_sigterm_checkpoints_and_resume_matches_uninterrupted(tmp_path):
    full = _evolve(tmp_path / "full")
    part = _evolve(tmp_path / "part")
    history = tmp_path / "part" / "history.csv"
    deadline = time.time() + 240
    while time.time() < deadline and part.poll() is None:
        if (
            history.is_file() and len(history.read_text().splitlines()) >= 2
        ):  # header + 1 generation
            part.send_signal(signal.SIGTERM)
            break
        time.sleep(0.05)
    out, _ = part.communicate(timeout=240)
    assert part.returncode == 2, out
    assert "stopped on SIGTERM after generation" in out and "--resume" in out
    resumed = _evolve(tmp_path / "part", "--resume")
    out2, _ = resumed.communicate(timeout=300)
    assert resumed.returncode == 0, out2
    full.communicate(timeout=300)
    a = json.loads((tmp_path / "full" / "summary.json").read_text())
    b = json.loads((tmp_path / "part" / "summary.json").read_text())
    assert a["fitness_history"] == b["fitness_history"] and len(a["fitness_history"]) == 6
