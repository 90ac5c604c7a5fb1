"""``--set key=value`` on the commands that train or test: it reaches the config, and an
unknown key is one clear error naming it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer.main
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.cli.biarm import sweep_with_sets
from evodevo.errors import ConfigError
from evodevo.neuromod.protocol_sweep import SWEEP_EVAL_SEED, SweepSpec

pytestmark = pytest.mark.usefixtures("one_torch_thread")

runner = CliRunner()

SWEEP = """
protocols:
  v1: {dqn: {batch_size: 8, learning_starts: 8}, eval: {episodes: 1}}
  plain: {}
tasks: [CartPole-v1]
variants: [pnn]
seeds: '0'
episodes_scale: 0.005
"""


@pytest.fixture()
def sweep_file(tmp_path: Path) -> Path:
    p = tmp_path / "sweep.yaml"
    p.write_text(SWEEP)
    return p


def test_every_training_and_test_command_takes_set():
    root = typer.main.get_command(app)
    ctx = root.make_context("evodevo", [], resilient_parsing=True)
    with_set = set()
    for group in root.list_commands(ctx):
        sub = root.get_command(ctx, group)
        for name in getattr(sub, "commands", {}):
            if any("--set" in p.opts for p in sub.commands[name].params):
                with_set.add(f"{group} {name}")
    assert with_set >= {
        "grn evolve",
        "grn evaluate",
        "grn baselines",
        "baselines kuka",
        "baselines evaluate",
        "biarm train",
        "biarm compare",
        "biarm sweep",
        "grn ablate",
        "grn video",
    }
    assert any("--set" in p.opts for p in root.get_command(ctx, "reproduce").params)


def test_sweep_set_is_the_base_config_of_every_protocol(sweep_file):
    spec = sweep_with_sets(
        SweepSpec.load(sweep_file),
        ["eval.episodes=7", "dqn.batch_size=4", "dqn.lr=0.01", "episodes_scale=0.5"],
    )
    v1, plain = spec.run_config("v1", "CartPole-v1"), spec.run_config("plain", "CartPole-v1")
    assert plain.eval.episodes == 7 and plain.dqn.batch_size == 4 and plain.dqn.lr == 0.01
    # a protocol's own overrides still win over --set
    assert v1.eval.episodes == 1 and v1.dqn.batch_size == 8 and v1.dqn.lr == 0.01
    assert spec.episodes_scale == 0.5 and plain.episodes_scale == 0.5
    assert plain.eval.seed == SWEEP_EVAL_SEED  # still the validation seeds (SPEC §6)
    assert sweep_with_sets(SweepSpec.load(sweep_file), None) == SweepSpec.load(sweep_file)


def test_sweep_set_reaches_the_saved_run_config(tmp_path, sweep_file):
    out = tmp_path / "sweep"
    args = ["biarm", "sweep", "--config", str(sweep_file), "--protocols", "v1", "--out", str(out)]
    res = runner.invoke(app, [*args, "--set", "dqn.lr=0.0123", "--quiet"])
    assert res.exit_code == 0, (res.output, res.exception)
    saved = json.loads((out / "v1" / "CartPole-v1" / "pnn__s0" / "config.json").read_text())
    assert saved["config"]["dqn"]["lr"] == 0.0123
    assert saved["config"]["dqn"]["batch_size"] == 8  # the protocol's own value


@pytest.mark.parametrize(
    ("sets", "match"),
    [
        (["dqn.bach_size=4"], "dqn.bach_size"),
        (["evall.episodes=4"], "evall"),
        (["tasks=[Acrobot-v1]"], "--set tasks"),
        (["eval.episodes=0"], "eval.episodes=0"),
    ],
)
def test_sweep_set_unknown_or_bad_key_is_one_clear_error(tmp_path, sweep_file, sets, match):
    out = tmp_path / "sweep"
    args = ["biarm", "sweep", "--config", str(sweep_file), "--out", str(out)]
    res = runner.invoke(app, [*args, *(a for s in sets for a in ("--set", s))])
    assert res.exit_code != 0
    assert isinstance(res.exception, ConfigError), (res.output, res.exception)
    assert match in str(res.exception) and "\n" not in str(res.exception).strip()
    assert not out.exists()  # before any run


def test_reproduce_set_reaches_the_budget(tmp_path):
    out = tmp_path / "rp"
    base = ["reproduce", "--out", str(out), "--plan"]
    res = runner.invoke(app, [*base, "--set", "grn.seeds='5'", "--set", "grn.control_seeds='5'"])
    assert res.exit_code == 0, (res.output, res.exception)
    assert "grn-evolve-plain-s5" in res.output and "grn-evolve-plain-s0" not in res.output
    res = runner.invoke(app, [*base, "--set", "grn.nope=3"])
    assert isinstance(res.exception, ConfigError) and "grn.nope" in str(res.exception)
