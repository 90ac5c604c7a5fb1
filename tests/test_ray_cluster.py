"""the README's cluster recipe against a head started with `ray start` (token
authentication on, Ray's default): `--address` joins it with the head's token, and the results
equal the local pool's."""

from __future__ import annotations

import contextlib
import csv
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow
ray = pytest.importorskip("ray")

ROOT = Path(__file__).resolve().parents[1]
ARGS = ["--config", str(ROOT / "configs" / "grn_pendulum.yaml"), "--population", "3",
        "--generations", "2", "--episodes", "2", "--workers", "2", "--quiet"]  # fmt: skip
WALL = {"eval_s", "evals_per_s", "elapsed_s"}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _history(run: Path) -> list[dict[str, str]]:
    with (run / "history.csv").open() as fh:
        return [{k: v for k, v in r.items() if k not in WALL} for r in csv.DictReader(fh)]


@pytest.mark.parametrize("head_auth", ["token", "disabled"])
def test_join_a_ray_start_head(tmp_path, head_auth):
    """The head finds a token in ~/.ray and requires it, or runs without authentication
    (RAY_AUTH_MODE=disabled) although the token file exists: both joins work."""
    home = Path(tempfile.mkdtemp(prefix="rh", dir="/tmp"))  # short: Ray's socket paths
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    env.update(HOME=str(home), RAY_USAGE_STATS_ENABLED="0")
    port = _free_port()
    exe = Path(sys.executable).parent
    # the token a private local Ray (any earlier `--backend ray` run) leaves in ~/.ray, which
    # makes the next `ray start --head` require it
    subprocess.run([str(exe / "ray"), "get-auth-token", "--generate"], env=env, check=True,
                   capture_output=True, timeout=120)  # fmt: skip
    head = subprocess.Popen(
        [
            str(exe / "ray"),
            "start",
            "--head",
            "--block",
            "--port",
            str(port),
            "--node-ip-address",
            "127.0.0.1",
            "--num-cpus",
            "2",
            "--include-dashboard=false",
            "--disable-usage-stats",
            "--temp-dir",
            str(home / "t"),
        ],  # fmt: skip
        env={**env, "RAY_AUTH_MODE": "disabled"} if head_auth == "disabled" else env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 120
        seen = []
        assert head.stdout is not None
        for line in head.stdout:
            seen.append(line)
            if "Ray runtime started" in line:
                break
            assert time.monotonic() < deadline, "".join(seen)
        if head_auth == "token":
            assert "Token authentication is enabled" in "".join(seen), "".join(seen)
        cmd = [str(exe / "evodevo"), "grn", "evolve", *ARGS]
        local = subprocess.run([*cmd, "--out", str(tmp_path / "local")], env=env,
                               capture_output=True, text=True, timeout=300)  # fmt: skip
        assert local.returncode == 0, local.stderr
        joined = subprocess.run(
            [
                *cmd,
                "--backend",
                "ray",
                "--address",
                f"127.0.0.1:{port}",
                "--out",
                str(tmp_path / "ray"),
            ],  # fmt: skip
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert joined.returncode == 0, joined.stderr[-2000:]
        assert "Connected to Ray cluster" in joined.stderr
        assert _history(tmp_path / "ray") == _history(tmp_path / "local")
    finally:
        os.killpg(head.pid, signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            head.wait(timeout=30)
        time.sleep(2)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(head.pid, signal.SIGKILL)
