"""long commands show a progress bar with an ETA on stderr (none with --quiet);
stdout (e.g. --json) is unchanged."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.parallel import WorkerPool, report_progress

pytestmark = pytest.mark.usefixtures("one_torch_thread")

PENDULUM = Path(__file__).resolve().parents[1] / "configs" / "grn_pendulum.yaml"
runner = CliRunner()


def _square(x: int) -> int:
    return x * x


@pytest.mark.parametrize("workers", [1, 2])
def test_pools_report_every_item(workers):
    seen: list[tuple[int, int]] = []
    with report_progress(lambda d, t: seen.append((d, t))), WorkerPool(workers) as pool:
        assert pool.map(_square, range(5)) == [0, 1, 4, 9, 16]
    assert seen == [(i, 5) for i in range(6)]
    with WorkerPool(1) as pool:  # outside the block nothing is reported
        pool.map(_square, range(2))
    assert len(seen) == 6


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("progress") / "run"
    res = runner.invoke(app, ["grn", "evolve", "--config", str(PENDULUM), "--population", "2",
                              "--generations", "2", "--episodes", "1", "--out", str(out)])  # fmt: skip
    assert res.exit_code == 0, (res.output, res.exception)
    assert "gen   2/2" in res.stderr and "generations" in res.stderr and "ETA" in res.stderr
    assert "gen " not in res.stdout
    return out


def test_evaluate_shows_a_bar_on_stderr_only(run):
    args = ["grn", "evaluate", str(run), "--objects", "train", "--test-episodes", "3"]
    res = runner.invoke(app, [*args, "--no-baselines", "--json"])
    assert res.exit_code == 0, (res.output, res.exception)
    assert "evaluate (part 1)" in res.stderr and "ETA" in res.stderr and "1/1" in res.stderr
    assert json.loads(res.stdout.strip().splitlines()[-1])["episodes"] == 3
    quiet = runner.invoke(app, [*args, "--no-baselines", "--json", "--quiet"])
    assert quiet.exit_code == 0 and quiet.stderr == ""
    assert json.loads(quiet.stdout.strip().splitlines()[-1])["episodes"] == 3


def test_reproduce_shows_a_bar_over_its_steps(tmp_path, monkeypatch):
    from evodevo.reproduce import pipeline, report

    steps = [pipeline.Step(f"step-{i}", ["--version"], [tmp_path / f"{i}.out"]) for i in range(2)]
    ran: list[str] = []
    monkeypatch.setattr(pipeline, "plan", lambda cfg, out: steps)
    monkeypatch.setattr(pipeline, "run_step", lambda step, logs: ran.append(step.name))
    monkeypatch.setattr(report, "write_report", lambda out, cfg, **kw: out / "report.md")
    res = runner.invoke(app, ["reproduce", "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, (res.output, res.exception)
    assert ran == ["step-0", "step-1"]
    assert "reproduce" in res.stderr and "2/2" in res.stderr and "ETA" in res.stderr
    assert "[2/2] step-1" in res.stdout  # the step lines stay on stdout
    quiet = runner.invoke(app, ["reproduce", "--out", str(tmp_path / "out"), "--quiet"])
    assert quiet.exit_code == 0 and quiet.stderr == ""


def test_biarm_sweep_shows_a_bar_over_its_runs(tmp_path):
    cfg = tmp_path / "sweep.yaml"
    cfg.write_text(
        "protocols:\n"
        "  v1: {dqn: {batch_size: 8, learning_starts: 8}, eval: {episodes: 1}}\n"
        "tasks: [CartPole-v1]\nvariants: [pnn]\nseeds: '0'\nepisodes_scale: 0.005\n"
    )
    args = ["biarm", "sweep", "--config", str(cfg), "--out", str(tmp_path / "sweep")]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, (res.output, res.exception)
    assert "training runs (part 1)" in res.stderr and "1/1" in res.stderr and "ETA" in res.stderr
    assert "trained 1 run(s)" in res.stdout
    quiet = runner.invoke(app, [*args, "--quiet"])
    assert quiet.exit_code == 0 and quiet.stderr == ""


def test_progress_into_a_log_prints_plain_lines(capsys, monkeypatch):
    """Not on a terminal (nohup, the steps of `evodevo reproduce`), Rich shows no live bar, so
    every item also gets a plain line with the ETA (throttled; the last item always prints)."""
    from evodevo import progress
    from evodevo.progress import CommandProgress

    with CommandProgress("training runs"), WorkerPool(1) as pool:
        pool.map(_square, range(3))
    err = capsys.readouterr().err
    assert "training runs (part 1): 1/3 done" in err  # the first line is due at once
    assert "training runs (part 1): 3/3 done" in err and "ETA 0:00:00" in err
    assert "2/3 done" not in err  # within 30 s of the previous line
    monkeypatch.setattr(progress, "PLAIN_EVERY_S", 0.0)
    with CommandProgress("training runs"), WorkerPool(1) as pool:
        pool.map(_square, range(3))
    assert "training runs (part 1): 2/3 done" in capsys.readouterr().err
    with CommandProgress("training runs", quiet=True), WorkerPool(1) as pool:
        pool.map(_square, range(3))
    assert capsys.readouterr().err == ""
