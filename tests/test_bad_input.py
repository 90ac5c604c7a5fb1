"""every bad input gives one clear line and a non-zero exit, before any work,
and leaves no run directory; pool workers exit when their parent is killed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.errors import EvodevoError
from evodevo.grn.genome import load_arrays

pytestmark = pytest.mark.usefixtures("one_torch_thread")

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "configs" / "grn_pendulum.yaml"
TINY_BIARM = """
tasks:
  - {env_id: CartPole-v1, episodes: 2, max_steps: 20}
dqn: {batch_size: 8, learning_starts: 8}
eval: {episodes: 1}
"""
TINY_GRN = ["--config", str(PENDULUM), "--population", "2", "--generations", "1"]
runner = CliRunner()


def _one_line_error(args: list[str], match: str) -> None:
    """``args`` fail with one ``EvodevoError`` line naming ``match``."""
    res = runner.invoke(app, args)
    assert res.exit_code != 0, res.output
    assert isinstance(res.exception, EvodevoError), (res.output, res.exception)
    text = str(res.exception).strip()
    assert match in text, text
    assert "\n" not in text


@pytest.fixture()
def tiny_biarm(tmp_path: Path) -> Path:
    p = tmp_path / "tiny.yaml"
    p.write_text(TINY_BIARM)
    return p


@pytest.mark.parametrize("kind", ["missing", "empty", "not_a_run"])
def test_biarm_resume_needs_a_run(tmp_path, tiny_biarm, kind):
    out = tmp_path / "run"
    if kind != "missing":
        out.mkdir()
    if kind == "not_a_run":
        (out / "notes.txt").write_text("not a run")
    before = sorted(p.name for p in out.iterdir()) if out.exists() else None
    match = "does not exist" if kind == "missing" else "no config.json"
    _one_line_error(
        ["biarm", "train", "--resume", "--config", str(tiny_biarm), "--out", str(out)], match
    )
    assert (sorted(p.name for p in out.iterdir()) if out.exists() else None) == before


@pytest.mark.parametrize(
    "args, match",
    [
        (["biarm", "train", "--tasks", ""], "--tasks '' names nothing"),
        (["biarm", "train", "--tasks", " , "], "names nothing"),
        (["biarm", "train", "--seed", "-1"], "--seed -1 must be >= 0"),
        (["biarm", "compare", "--seeds", "-1"], "must be >= 0"),
        (["biarm", "compare", "--seeds", "0,-2"], "must be >= 0"),
        (["biarm", "compare", "--tasks", ""], "names nothing"),
        (["grn", "evolve", *TINY_GRN, "--seed", "-1"], "--seed -1 must be >= 0"),
        (["grn", "evolve", *TINY_GRN, "--blind", "--open-loop"], "contradict"),
        (["grn", "evolve", *TINY_GRN, "--blind", "--controller", "open_loop"], "contradict"),
        (["grn", "evolve", *TINY_GRN, "--resume"], "does not exist"),
        (["baselines", "kuka", "--method", "zero", "--seed", "-3"], "--seed -3"),
        (["reproduce", "--seed-offset", "-1"], "--seed-offset -1"),
    ],
)
def test_bad_options_leave_no_run_directory(tmp_path, args, match):
    out = tmp_path / "run"
    _one_line_error([*args, "--out", str(out)], match)
    assert not out.exists()


def test_negative_seed_in_a_config_file(tmp_path):
    cfg = tmp_path / "neg.yaml"
    cfg.write_text(PENDULUM.read_text().replace("seed: 0", "seed: -4"))
    out = tmp_path / "run"
    _one_line_error(["grn", "evolve", "--config", str(cfg), "--out", str(out)], "seed=-4")
    assert not out.exists()


def test_malformed_yaml_names_line_and_column(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("seed: 0\nevolution:\n  population: 4\n generations: 2\n")
    out = tmp_path / "run"
    _one_line_error(["grn", "evolve", "--config", str(bad), "--out", str(out)], "line 4, column")
    assert not out.exists()


@pytest.fixture(scope="module")
def evolved(tmp_path_factory) -> Path:
    """A finished 2-genome, 1-generation Pendulum run."""
    out = tmp_path_factory.mktemp("grn") / "run"
    res = runner.invoke(
        app, ["grn", "evolve", *TINY_GRN, "--episodes", "1", "--quiet", "--out", str(out)]
    )
    assert res.exit_code == 0, (res.output, res.exception)
    return out


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def test_truncated_genome_and_checkpoint(evolved, tmp_path):
    genome, ckpt = evolved / "best_genome.npz", evolved / "checkpoints" / "checkpoint.npz"
    saved = genome.read_bytes(), ckpt.read_bytes()
    try:
        _truncate(genome)
        _one_line_error(
            ["grn", "evaluate", str(evolved), "--objects", "train", "--no-baselines"],
            "truncated or corrupt",
        )
        _truncate(ckpt)
        _one_line_error(
            ["grn", "evolve", "--resume", "--quiet", "--out", str(evolved)],
            "truncated or corrupt",
        )
    finally:
        genome.write_bytes(saved[0])
        ckpt.write_bytes(saved[1])


def test_random_bytes_as_genome(tmp_path):
    path = tmp_path / "g.npz"
    path.write_bytes(np.random.default_rng(0).bytes(256))
    with pytest.raises(EvodevoError, match="not an .npz archive") as info:
        load_arrays(path)
    assert "pickle" not in str(info.value)
    path.write_bytes(b"")
    with pytest.raises(EvodevoError, match="is empty"):
        load_arrays(path)


def _session_pids(sid: int) -> set[int]:
    """Live (non-zombie) processes of session ``sid``."""
    pids = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[3]) == sid and fields[0] != "Z":
            pids.add(int(entry.name))
    return pids


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_sigkill_leaves_no_worker(tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "evodevo", "grn", "evolve", "--config", str(PENDULUM)]
    cmd += ["--population", "4", "--generations", "200", "--episodes", "2", "--workers", "2"]
    proc = subprocess.Popen(
        [*cmd, "--quiet", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not (out / "history.csv").is_file():  # the workers are up and evaluating
            assert proc.poll() is None, "evolution ended early"
            assert time.monotonic() < deadline, "no generation within 120 s"
            time.sleep(0.2)
        assert len(_session_pids(proc.pid)) >= 3  # main process and two workers
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 15
        while _session_pids(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _session_pids(proc.pid) == set()
    finally:
        for pid in _session_pids(proc.pid):
            os.kill(pid, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()


@pytest.mark.parametrize(
    "command",
    [
        ["biarm", "train", "--variant", "pnn", "--tasks", "CartPole-v1"],
        ["biarm", "compare", "--variants", "pnn", "--seeds", "0", "--tasks", "CartPole-v1"],
        ["grn", "evolve", *TINY_GRN, "--episodes", "1", "--quiet"],
    ],
)
def test_an_out_folder_that_cannot_be_created_is_one_line(tmp_path, command):
    blocker = tmp_path / "a_file"
    blocker.write_text("in the way")
    _one_line_error([*command, "--out", str(blocker / "run")], "cannot be created")


def test_zero_test_episodes_names_the_option_given(evolved):
    _one_line_error(
        ["grn", "evaluate", str(evolved), "--test-episodes", "0", "--no-baselines"],
        "--test-episodes 0",
    )


def test_each_video_command_points_to_the_other_for_the_other_kind_of_run(evolved, tmp_path):
    biarm_run = tmp_path / "biarm"
    (biarm_run).mkdir()
    (biarm_run / "config.json").write_text('{"kind": "biarm", "config": {}}')
    _one_line_error(
        ["grn", "video", str(biarm_run), "--out", str(tmp_path / "a.gif")], "evodevo biarm video"
    )
    _one_line_error(
        ["biarm", "video", str(evolved), "--task", "0", "--out", str(tmp_path / "b.gif")],
        "evodevo grn video",
    )


def test_evaluate_takes_set_for_what_a_run_is_tested_on_only(evolved, tmp_path):
    """``--set`` on a test: evaluation.* and env.* change what the run is tested on (their
    files get a suffix, so the plain test is never overwritten); anything else is refused."""
    import json

    args = ["grn", "evaluate", str(evolved), "--objects", "train", "--no-baselines"]
    res = runner.invoke(
        app, [*args, "--test-episodes", "1", "--set", "env.kwargs.max_episode_steps=5", "--json"]
    )
    assert res.exit_code == 0, (res.output, res.exception)
    result = json.loads(res.output.strip().splitlines()[-1])
    assert result["overrides"] == {"env": {"kwargs": {"max_episode_steps": 5}}}
    changed = sorted(p.name for p in evolved.glob("eval_train_0_set-*.json"))
    assert len(changed) == 1 and result["mean_steps"] <= 5
    _one_line_error([*args, "--set", "dynamics.dt=0.1"], "a test may change only")
