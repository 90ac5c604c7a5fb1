"""BIARM mid-task checkpoints, resume after a kill, SIGTERM, bad checkpoint files."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import torch

from evodevo.callbacks import FunctionCallback
from evodevo.config import from_dict
from evodevo.errors import CheckpointError, ConfigError
from evodevo.neuromod import train
from evodevo.neuromod.checkpoint import FORMAT, latest_resume_point, load_checkpoint
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.trainer import TIMING_KEYS
from evodevo.runs import RunDir
from evodevo.safe_io import save_state

pytestmark = pytest.mark.usefixtures("one_torch_thread")


TINY: dict[str, Any] = {
    "tasks": [
        {"env_id": "CartPole-v1", "episodes": 6, "max_steps": 60},
        {"env_id": "Acrobot-v1", "episodes": 4, "max_steps": 60},
    ],
    "dqn": {"batch_size": 16, "learning_starts": 16, "target_update": 25},
    "modules": {"sample_interval": 10},
    "eval": {"episodes": 3},
    "checkpoint_every": 2,
}


def tiny(**extra: Any) -> BiarmConfig:
    return from_dict(BiarmConfig, {**TINY, **extra})


def strip_timing(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: strip_timing(v) for k, v in obj.items() if k not in TIMING_KEYS}
    if isinstance(obj, list):
        return [strip_timing(v) for v in obj]
    return obj


class Killed(Exception):
    pass


def _kill_at(task: int, episode: int):
    def hook(info: Any) -> None:
        if info.task == task and info.episode == episode:
            raise Killed

    return hook


def _same_run(a: Path, b: Path) -> None:
    """Same summary (wall time aside), same CSV rows, bit-identical final networks."""
    sa, sb = RunDir(a).read_summary(), RunDir(b).read_summary()
    assert strip_timing(sa) == strip_timing(sb)
    for name in ("metrics.csv", "neuromod.csv"):
        assert RunDir(a).read_csv(name) == RunDir(b).read_csv(name), name
    last = len(sa["tasks"]) - 1
    na = load_checkpoint(a / "checkpoints" / f"task{last}.safetensors")["agent"]["net"]
    nb = load_checkpoint(b / "checkpoints" / f"task{last}.safetensors")["agent"]["net"]
    assert na.keys() == nb.keys()
    assert all(torch.equal(na[k], nb[k]) for k in na)


@pytest.mark.parametrize(
    ("variant", "learning", "task", "episode"),
    [("biarm", "learned", 0, 3), ("biarm", "fixed", 1, 2), ("pnn", "fixed", 1, 3)],
)
def test_killed_mid_task_resumes_to_the_uninterrupted_run(
    tmp_path, variant, learning, task, episode
):
    cfg = tiny(modules={"sample_interval": 10, "learning": learning})
    train(cfg, variant, 4, tmp_path / "full")
    with pytest.raises(Killed):
        train(
            cfg,
            variant,
            4,
            tmp_path / "cut",
            callback=FunctionCallback(on_episode=_kill_at(task, episode)),
        )
    point = latest_resume_point(tmp_path / "cut" / "checkpoints")
    assert point is not None and point.task == task and point.episodes == 2
    partials = sorted(p.name for p in (tmp_path / "cut" / "checkpoints").glob("*_ep*.safetensors"))
    assert partials == [f"task{task}_ep2.safetensors"]  # only the newest mid-task file is kept
    assert not (tmp_path / "cut" / "summary.json").exists()
    before = load_checkpoint(point.path)["elapsed"]
    assert before["cpu_seconds"] > 0 and before["timing_complete"]
    train(cfg, variant, 4, tmp_path / "cut", resume=True)
    _same_run(tmp_path / "full", tmp_path / "cut")
    # the summary's time covers both sessions, not only the resumed one
    after = RunDir(tmp_path / "cut").read_summary()
    assert after["cpu_seconds"] > before["cpu_seconds"] and after["timing_complete"]
    assert after["wall_seconds"] > before["wall_seconds"]
    # finished tasks supersede their mid-task files
    assert not list((tmp_path / "cut" / "checkpoints").glob("*_ep*.safetensors"))


def test_checkpoint_every_zero_writes_only_task_checkpoints(tmp_path):
    with pytest.raises(Killed):
        train(
            tiny(checkpoint_every=0),
            "biarm",
            1,
            tmp_path,
            callback=FunctionCallback(on_episode=_kill_at(0, 4)),
        )
    assert not (tmp_path / "checkpoints").is_dir() or not any((tmp_path / "checkpoints").iterdir())
    with pytest.raises(ConfigError, match="checkpoint_every=-1"):
        tiny(checkpoint_every=-1)


def _partial_run(tmp_path: Path) -> Path:
    with pytest.raises(Killed):
        train(tiny(), "biarm", 1, tmp_path, callback=FunctionCallback(on_episode=_kill_at(0, 3)))
    return tmp_path / "checkpoints" / "task0_ep2.safetensors"


def test_truncated_checkpoint_gives_one_clear_error(tmp_path):
    ckpt = _partial_run(tmp_path)
    data = ckpt.read_bytes()
    ckpt.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError) as err:
        train(tiny(), "biarm", 1, tmp_path, resume=True)
    msg = str(err.value)
    assert str(ckpt) in msg and "corrupt or truncated" in msg and "delete it" in msg
    assert "\n" not in msg


def test_foreign_checkpoints_are_refused(tmp_path):
    ckpt = _partial_run(tmp_path)
    torch.save({"weights": torch.zeros(3)}, ckpt)  # a pickle-based file is never opened
    with pytest.raises(CheckpointError, match="no longer opens"):
        train(tiny(), "biarm", 1, tmp_path, resume=True)
    save_state(ckpt, "other", {"weights": torch.zeros(3)})
    with pytest.raises(CheckpointError, match="not a 'evodevo-biarm' state"):
        train(tiny(), "biarm", 1, tmp_path, resume=True)
    save_state(ckpt, FORMAT, {"weights": torch.zeros(3)})
    with pytest.raises(CheckpointError, match="is not a BIARM checkpoint"):
        train(tiny(), "biarm", 1, tmp_path, resume=True)
    # a checkpoint of another seed copied into this run
    _partial_run(tmp_path / "other")
    other = tmp_path / "other" / "checkpoints" / "task0_ep2.safetensors"
    data = load_checkpoint(other)
    data["seed"] = 7
    save_state(ckpt, FORMAT, data)
    with pytest.raises(CheckpointError, match="belongs to a run with seed 7"):
        train(tiny(), "biarm", 1, tmp_path, resume=True)


def test_without_resume_an_existing_mid_task_checkpoint_is_not_overwritten(tmp_path):
    _partial_run(tmp_path)
    with pytest.raises(Exception, match="pass --resume"):
        train(tiny(), "biarm", 1, tmp_path)


# ---------------------------------------------------------------------------- the CLI
CLI_YAML = """
tasks:
  - {env_id: CartPole-v1, episodes: 80, max_steps: 40}
  - {env_id: Acrobot-v1, episodes: 2, max_steps: 40}
dqn: {batch_size: 16, learning_starts: 16, target_update: 50}
modules: {sample_interval: 25}
eval: {episodes: 2, validation_episodes: 2, validation_every: 20}
checkpoint_every: 5
"""


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> tuple[Path, Path]:
    """The config file and an uninterrupted run of it (seed 3)."""
    root = tmp_path_factory.mktemp("ref")
    cfg_file = root / "tiny.yaml"
    cfg_file.write_text(CLI_YAML)
    from evodevo.config import load_config

    train(load_config(BiarmConfig, cfg_file), "biarm", 3, root / "full")
    return cfg_file, root / "full"


def _cli_train(cfg_file: Path | None, out: Path, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "evodevo", "biarm", "train", "--quiet", "--out", str(out)]
    if cfg_file is not None:
        cmd += ["--config", str(cfg_file), "--seed", "3"]
    return subprocess.Popen(
        [*cmd, *extra], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )


def _wait_for_checkpoint(proc: subprocess.Popen, out: Path, mid_task: bool = False) -> None:
    """Until the run has a checkpoint (with ``mid_task``: one taken inside a task)."""
    deadline = time.time() + 60
    while time.time() < deadline and proc.poll() is None:
        point = latest_resume_point(out / "checkpoints")
        if point is not None and (not mid_task or point.episodes is not None):
            return
        time.sleep(0.005)
    raise AssertionError(f"no checkpoint appeared (exit {proc.poll()})")


def test_sigkill_mid_task_then_resume_matches(tmp_path, reference):
    cfg_file, full = reference
    out = tmp_path / "cut"
    proc = _cli_train(cfg_file, out)
    _wait_for_checkpoint(proc, out, mid_task=True)
    # die a little after the first mid-task checkpoint (episode 5 of 80): a fixed longer sleep
    # let a fast run reach the end of the task first (seen under load on 2026-12-07)
    time.sleep(0.01)
    proc.kill()
    proc.communicate(timeout=30)
    assert not (out / "summary.json").exists(), "the run ended before it was killed"
    point = latest_resume_point(out / "checkpoints")
    assert point is not None and point.task == 0 and point.episodes is not None
    resumed = _cli_train(None, out, "--resume")  # variant, seed and config from config.json
    text, _ = resumed.communicate(timeout=60)
    assert resumed.returncode == 0, text
    _same_run(full, out)


def test_sigterm_finishes_the_episode_checkpoints_and_says_how_to_resume(tmp_path, reference):
    cfg_file, full = reference
    out = tmp_path / "cut"
    proc = _cli_train(cfg_file, out)
    _wait_for_checkpoint(proc, out)
    proc.send_signal(signal.SIGTERM)
    text, _ = proc.communicate(timeout=30)
    assert proc.returncode == 2, text
    assert "stopped on SIGTERM after episode" in text
    assert f"evodevo biarm train --resume --out {out}" in text
    point = latest_resume_point(out / "checkpoints")
    assert point is not None and point.episodes is not None
    # the checkpoint is the stopping point: the log ends exactly there
    rows = RunDir(out).read_csv("metrics.csv")
    assert len(rows) == point.episodes and int(rows[-1]["episode"]) == point.episodes - 1
    resumed = _cli_train(cfg_file, out, "--resume")
    text, _ = resumed.communicate(timeout=60)
    assert resumed.returncode == 0, text
    _same_run(full, out)
    assert json.loads((out / "summary.json").read_text())["seed"] == 3


def test_cli_reports_a_corrupt_checkpoint_in_one_line(tmp_path):
    ckpt = _partial_run(tmp_path)
    ckpt.write_bytes(b"not a checkpoint")
    proc = subprocess.run(
        [sys.executable, "-m", "evodevo", "biarm", "train", "--resume", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: checkpoint") and str(ckpt) in lines[0]
