"""``evodevo biarm`` commands at a tiny budget, and every bad input (SPEC §1)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from evodevo.cli.biarm import app
from evodevo.errors import ConfigError, EvodevoError
from evodevo.runs import RunDir

pytestmark = pytest.mark.usefixtures("one_torch_thread")


TINY_YAML = """
tasks:
  - {env_id: CartPole-v1, episodes: 3, max_steps: 40}
  - {env_id: Acrobot-v1, episodes: 2, max_steps: 40}
dqn: {batch_size: 16, learning_starts: 16}
modules: {sample_interval: 10}
eval: {episodes: 2}
"""

runner = CliRunner()


@pytest.fixture()
def tiny_cfg(tmp_path: Path) -> Path:
    p = tmp_path / "tiny.yaml"
    p.write_text(TINY_YAML)
    return p


def _ok(args: list[str]) -> str:
    res = runner.invoke(app, args)
    assert res.exit_code == 0, (res.output, res.exception)
    return res.output


def _fails(args: list[str], exc: type[Exception], match: str) -> None:
    res = runner.invoke(app, args)
    assert res.exit_code != 0
    assert isinstance(res.exception, exc), (res.output, res.exception)
    assert match in str(res.exception), str(res.exception)
    assert "\n" not in str(res.exception).strip()


def test_train_writes_every_file(tmp_path, tiny_cfg):
    out = tmp_path / "run"
    text = _ok(
        ["train", "--variant", "biarm", "--config", str(tiny_cfg), "--seed", "1", "--out", str(out)]
    )
    assert "retention" in text
    run = RunDir(out, create=False)
    s = run.read_summary()
    assert s["variant"] == "biarm" and s["seed"] == 1
    assert [t["env_id"] for t in s["tasks"]] == ["CartPole-v1", "Acrobot-v1"]
    for t in s["tasks"]:
        assert {
            "env_id",
            "episodes",
            "initial_return",
            "final_return",
            "retention",
            "us_per_step",
        } <= set(t)
        assert len(t["eval_returns_final"]) == 2
    assert run.read_config()["config"]["variant"] == "biarm"
    metrics = run.read_csv("metrics.csv")
    assert len(metrics) == 5 and {"task", "episode", "return", "length", "epsilon", "lr"} <= set(
        metrics[0]
    )
    nm = run.read_csv("neuromod.csv")
    assert {"step", "task", "s_DA", "s_5HT", "s_NE", "s_ACh", "n_task", "lr", "gate"} <= set(nm[0])
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "task0.safetensors",
        "task1.safetensors",
    ]
    # a second train into the same folder needs --resume; with it, nothing is retrained
    _fails(
        ["train", "--config", str(tiny_cfg), "--seed", "1", "--out", str(out)],
        EvodevoError,
        "--resume",
    )
    _ok(
        [
            "train",
            "--config",
            str(tiny_cfg),
            "--seed",
            "1",
            "--resume",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    _fails(
        ["train", "--config", str(tiny_cfg), "--seed", "2", "--resume", "--out", str(out)],
        EvodevoError,
        "seed",
    )


def test_tasks_and_episodes_scale_options(tmp_path, tiny_cfg):
    out = tmp_path / "r"
    _ok(
        [
            "train",
            "--variant",
            "pnn",
            "--config",
            str(tiny_cfg),
            "--tasks",
            "Acrobot-v1",
            "--episodes-scale",
            "0.01",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    s = json.loads((out / "summary.json").read_text())
    assert [(t["env_id"], t["episodes"]) for t in s["tasks"]] == [("Acrobot-v1", 1)]


def test_compare_and_report(tmp_path, tiny_cfg):
    out = tmp_path / "cmp"
    args = [
        "compare",
        "--variants",
        "biarm,pnn,no-da",
        "--seeds",
        "0-1",
        "--workers",
        "1",
        "--config",
        str(tiny_cfg),
        "--out",
        str(out),
    ]
    _ok(args)
    for name in ("table_3_2", "table_3_3", "table_3_4", "table_3_5"):
        assert (out / f"{name}.md").is_file() and (out / f"{name}.csv").is_file()
    for fig in ("fig_3_3_learning_curves.png", "fig_3_4_ablation.png", "fig_3_5_Acrobot-v1.png"):
        assert (out / fig).stat().st_size > 1000
    t32 = (out / "table_3_2.md").read_text()
    assert "491.00 ± 11.94" in t32 and "(n=2)" in t32
    assert len(list((out / "runs").iterdir())) == 6
    # finished runs are skipped: a second compare trains nothing
    assert "trained 0 run(s)" in _ok(args)
    (out / "table_3_5.md").unlink()
    _ok(["report", str(out), "--no-figures"])
    assert "Retention" in (out / "table_3_5.md").read_text()
    # a run without its module log (runs taken over from a sweep's lanes): Fig. 3.5 is drawn
    # from the next modulated run that has one, and the report does not stop
    (out / "runs" / "biarm__s0" / "neuromod.csv").unlink()
    (out / "fig_3_5_Acrobot-v1.png").unlink()
    _ok(["report", str(out)])
    assert (out / "fig_3_5_Acrobot-v1.png").stat().st_size > 1000
    text = _ok(["contrast", "--runs", f"a={out},b={out}", "--variant", "pnn"])
    assert "| CartPole-v1 |" in text and "seeds 0-1" in text
    _fails(["contrast", "--runs", f"a{out}"], EvodevoError, "label=DIR")


def test_config_command_lists_keys():
    text = _ok(["config"])
    assert "modules.tau_5ht" in text and "dqn.target_update" in text


@pytest.mark.parametrize(
    "args, exc, match",
    [
        (["--tasks", "NoSuchEnv-v9"], EvodevoError, "NoSuchEnv-v9"),
        (["--tasks", "nosuchmod:Thing-v0"], EvodevoError, "PYTHONPATH"),
        (["--tasks", "Pendulum-v1"], EvodevoError, "only Discrete actions"),
        (["--tasks", "FrozenLake-v1"], EvodevoError, "only Box observations"),
        (["--set", "network.d_max=3"], EvodevoError, "exceeds d_max=3"),
        (["--episodes-scale", "0"], ConfigError, "--episodes-scale 0.0"),
        (["--episodes-scale", "-1"], ConfigError, "positive"),
        (["--variant", "biarn"], EvodevoError, "unknown variant 'biarn'"),
        (["--set", "dqn.gama=0.9"], ConfigError, "dqn.gama"),
        (["--set", "modules.learning=sometimes"], ConfigError, "modules.learning"),
        (["--set", "modules.tau_da=2"], ConfigError, "modules.tau_da=2.0"),
        (["--set", "eval.episodes=0"], ConfigError, "eval.episodes=0"),
    ],
)
def test_bad_inputs_fail_before_training(tmp_path, tiny_cfg, args, exc, match):
    out = tmp_path / "bad"
    _fails(["train", "--config", str(tiny_cfg), *args, "--out", str(out)], exc, match)
    assert not (out / "metrics.csv").exists()


def test_malformed_config_files(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("tasks: [\n")
    _fails(
        ["train", "--config", str(bad), "--out", str(tmp_path / "o")], ConfigError, "not valid YAML"
    )
    bad.write_text("tasks:\n  - {env_id: CartPole-v1, episodes: ten}\n")
    _fails(["train", "--config", str(bad), "--out", str(tmp_path / "o")], ConfigError, "episodes")
    bad.write_text("dqn: {lr: -1}\n")
    _fails(["train", "--config", str(bad), "--out", str(tmp_path / "o")], ConfigError, "dqn.lr")
    _fails(
        ["compare", "--variants", "pnn,nope", "--out", str(tmp_path / "o")], EvodevoError, "nope"
    )
    _fails(["compare", "--seeds", "x-y", "--out", str(tmp_path / "o")], EvodevoError, "--seeds")
    _fails(["report", str(tmp_path / "nothing")], EvodevoError, "does not exist")


def test_console_script_prints_one_error_line(tmp_path):
    exe = Path(sys.executable).parent / "evodevo"
    res = subprocess.run(
        [str(exe), "biarm", "train", "--tasks", "Pendulum-v1", "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 2
    assert res.stderr.strip().startswith("error:") and "Pendulum-v1" in res.stderr
    assert "Traceback" not in res.stderr
