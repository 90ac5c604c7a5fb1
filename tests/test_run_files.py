"""run files get the mode an ordinary write gives (0666 minus the umask), so a
group can read runs on shared storage; atomic writes used to leave them 0600."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from evodevo.runs import RunDir, atomic_write_bytes, current_umask, write_json


@pytest.fixture()
def umask_002() -> Iterator[None]:
    old = os.umask(0o002)
    try:
        yield
    finally:
        os.umask(old)


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


def test_current_umask_reads_without_changing(umask_002):
    assert current_umask() == 0o002
    assert current_umask() == 0o002


@pytest.mark.parametrize("mask", [0o002, 0o022, 0o077])
def test_atomic_writes_honour_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        atomic_write_bytes(tmp_path / "a.bin", b"x")
        write_json(tmp_path / "b.json", {"a": 1})
        run = RunDir(tmp_path / "run")
        run.write_csv("m.csv", [{"a": 1}])
        run.write_summary({"ok": True})
    finally:
        os.umask(old)
    want = 0o666 & ~mask
    for p in (tmp_path / "a.bin", tmp_path / "b.json", run / "m.csv", run / "summary.json"):
        assert _mode(p) == want, (p.name, oct(_mode(p)))


def test_a_whole_run_is_group_readable(tmp_path, umask_002):
    from typer.testing import CliRunner

    from evodevo.cli import app

    cfg = Path(__file__).resolve().parents[1] / "configs" / "grn_pendulum.yaml"
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["grn", "evolve", "--config", str(cfg), "--population", "2",
                                   "--generations", "1", "--episodes", "1", "--quiet",
                                   "--out", str(out)])  # fmt: skip
    assert res.exit_code == 0, (res.output, res.exception)
    files = [p for p in out.rglob("*") if p.is_file()]
    assert len(files) >= 5
    for p in files:
        assert _mode(p) & 0o040, f"{p.relative_to(out)} is not group-readable: {oct(_mode(p))}"
