"""Continual-learning baselines of BIARM: finetune, ewc, sb3-dqn, and `compare biarm`."""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn
from typer.testing import CliRunner

from evodevo.cli import app as root_app
from evodevo.cli.biarm import app as biarm_app
from evodevo.errors import EvodevoError
from evodevo.neuromod.checkpoint import load_checkpoint
from evodevo.neuromod.config import (
    BiarmConfig,
    DQNConfig,
    EvalConfig,
    EWCConfig,
    NetworkConfig,
    TaskConfig,
)
from evodevo.neuromod.ewc import EWC, diagonal_fisher, ewc_penalty
from evodevo.neuromod.forgetting import forgetting
from evodevo.neuromod.shared_net import SharedNet
from evodevo.neuromod.trainer import TIMING_KEYS, load_agent, train
from evodevo.neuromod.variants import VARIANTS
from evodevo.runs import RunDir
from evodevo.stats import bootstrap_ci

runner = CliRunner()


pytestmark = pytest.mark.usefixtures("one_torch_thread")


# ---------------------------------------------------------------------------- EWC (Eq. 2.4)
def _hand_case() -> tuple[list[torch.Tensor], list[tuple[list[torch.Tensor], list[torch.Tensor]]]]:
    """theta = ([1, 2], [[0.5]]); task 1: F = ([0.5, 2], [[4]]), theta* = 0;
    task 2: F = ([1, 0], [[0]]), theta* = ([2, 0], [[1]])."""
    theta = [torch.tensor([1.0, 2.0]), torch.tensor([[0.5]])]
    t1 = ([torch.tensor([0.5, 2.0]), torch.tensor([[4.0]])], [torch.zeros(2), torch.zeros(1, 1)])
    t2 = (
        [torch.tensor([1.0, 0.0]), torch.tensor([[0.0]])],
        [torch.tensor([2.0, 0.0]), torch.ones(1, 1)],
    )
    return theta, [t1, t2]


def test_ewc_penalty_matches_the_hand_worked_case():
    theta, anchors = _hand_case()
    # task 1: 0.5*1^2 + 2*2^2 + 4*0.5^2 = 9.5; task 2: 1*(1-2)^2 = 1; lambda/2 = 1
    assert float(ewc_penalty(theta, anchors, lam=2.0)) == pytest.approx(10.5)
    assert float(ewc_penalty(theta, anchors[:1], lam=2.0)) == pytest.approx(9.5)
    assert float(ewc_penalty(theta, anchors, lam=0.0)) == 0.0


def test_ewc_closed_form_penalty_and_gradient_equal_the_literal_sum():
    theta, anchors = _hand_case()
    params = [("a", nn.Parameter(theta[0].clone())), ("b", nn.Parameter(theta[1].clone()))]
    ewc = EWC(params, lam=2.0)
    assert float(ewc.penalty()) == 0.0  # nothing consolidated yet
    ewc.load_state_dict({"names": ["a", "b"], "anchors": anchors})
    pen = ewc.penalty()
    assert float(pen.detach()) == pytest.approx(10.5, abs=1e-5)
    pen.backward()
    # d/dtheta = lambda * sum_k F_k (theta - theta*_k): a -> 2*([0.5, 4] + [-1, 0]); b -> 2*2
    assert torch.allclose(params[0][1].grad, torch.tensor([-1.0, 8.0]))
    assert torch.allclose(params[1][1].grad, torch.tensor([[4.0]]))


def test_fisher_of_softmax_q_matches_its_closed_form():
    """Q = W x (2 actions): F[b, j] = mean_s pi_b (1 - pi_b) x_j^2; W = 0 gives pi = 1/2."""
    model = nn.Sequential(nn.Linear(2, 2, bias=False))
    nn.init.zeros_(model[0].weight)
    states = torch.tensor([[1.0, 2.0], [3.0, 0.0]])
    (f,) = diagonal_fisher(model, ["0.weight"], states, chunk=1)
    expect = 0.25 * (states**2).mean(0)
    assert torch.allclose(f, expect.expand(2, 2))


def test_fisher_equals_a_per_sample_autograd_loop():
    net = SharedNet(obs_dim=3, hidden=5, seed=1)
    net.add_column(3)
    model = net.current
    names = [n for n, _ in net.shared_parameters()]
    states = torch.randn(7, 3, generator=torch.Generator().manual_seed(0))
    fast = diagonal_fisher(model, names, states, chunk=3)
    params = dict(model.named_parameters())
    slow = [torch.zeros_like(params[n]) for n in names]
    for x in states:
        logp = torch.log_softmax(model(x.unsqueeze(0)), -1)[0]
        pi = logp.exp().detach()
        for a in range(3):
            grads = torch.autograd.grad(logp[a], [params[n] for n in names], retain_graph=True)
            for s, g in zip(slow, grads, strict=True):
                s += pi[a] * g**2
    for a, b in zip(fast, slow, strict=True):
        assert torch.allclose(a, b / len(states), atol=1e-7)


def test_forgetting_is_eq_1_4():
    assert forgetting({"returns_after": [100.0, 180.0, 150.0], "final_return": 120.0}) == 60.0
    assert forgetting({"returns_after": [-90.0], "final_return": -80.0}) == -10.0
    assert math.isnan(forgetting({"returns_after": [1.0], "final_return": 0.0}, last=True))


# ---------------------------------------------------------------------------- toy sequence
class SignBandit(gym.Env):
    """Contextual bandit: x ~ U(-1, 1)^2, reward 1 when the action equals [x[dim] > 0]; 10 steps.

    Task A reads x[0], task B x[1]: a small shared body must re-purpose its units for B.
    """

    def __init__(self, dim: int = 0) -> None:
        self.dim = dim
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.action_space = gym.spaces.Discrete(2)

    def _draw(self) -> np.ndarray:
        self.x = self.np_random.uniform(-1, 1, 2).astype(np.float32)
        return self.x

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self._draw(), {}

    def step(self, action):
        r = float(int(action) == int(self.x[self.dim] > 0))
        self.t += 1
        return self._draw(), r, self.t >= 10, False, {}


for _dim in (0, 1):
    gym.register(f"evodevo-test/Sign{_dim}-v0", entry_point=SignBandit, kwargs={"dim": _dim})


def _toy_cfg() -> BiarmConfig:
    return BiarmConfig(
        tasks=[
            TaskConfig("evodevo-test/Sign0-v0", 40, None),
            TaskConfig("evodevo-test/Sign1-v0", 40, None),
        ],
        dqn=DQNConfig(
            lr=0.01, batch_size=32, learning_starts=32, gamma=0.0, target_update=50, eps_decay=0.9
        ),
        network=NetworkConfig(hidden=4),
        eval=EvalConfig(episodes=10),
        ewc=EWCConfig(lam=1000.0),
        checkpoint_every=0,
    )


def test_finetune_forgets_the_first_task_where_pnn_and_ewc_keep_it(tmp_path):
    cfg = _toy_cfg()
    ret: dict[str, list[float]] = {}
    for v in ("pnn", "finetune", "ewc"):
        for seed in (0, 1, 2):
            s = train(cfg, v, seed, tmp_path / f"{v}{seed}")
            first = s["tasks"][0]
            assert first["initial_return"] >= 9.0  # task A was learned (of 10)
            ret.setdefault(v, []).append(first["retention"])
    assert ret["pnn"] == [1.0, 1.0, 1.0]  # frozen column: exact
    assert max(ret["finetune"]) < 0.8 and np.mean(ret["finetune"]) < 0.7
    assert all(e > f for e, f in zip(ret["ewc"], ret["finetune"], strict=True))


# ---------------------------------------------------------------------------- CLI
TINY_YAML = """
tasks:
  - {env_id: CartPole-v1, episodes: 6, max_steps: 40}
  - {env_id: Acrobot-v1, episodes: 4, max_steps: 30}
  - {env_id: MountainCar-v0, episodes: 4, max_steps: 30}
dqn: {batch_size: 16, learning_starts: 16, target_update: 20}
modules: {sample_interval: 10}
"""


@pytest.fixture()
def tiny_cfg(tmp_path: Path) -> Path:
    p = tmp_path / "tiny.yaml"
    p.write_text(TINY_YAML)
    return p


def _train_cli(cfg: Path, variant: str, out: Path, seed: int = 0) -> dict:
    args = ["train", "--variant", variant, "--config", str(cfg), "--episodes-scale", "0.5"]
    args += ["--set", "eval.episodes=1", "--seed", str(seed), "--quiet", "--out", str(out)]
    res = runner.invoke(biarm_app, args)
    assert res.exit_code == 0, (res.output, res.exception)
    assert "retention" in res.output
    return RunDir(out, create=False).read_summary()


def _check_run_files(out: Path, s: dict, variant: str) -> None:
    assert s["variant"] == variant
    assert [t["env_id"] for t in s["tasks"]] == ["CartPole-v1", "Acrobot-v1", "MountainCar-v0"]
    assert [t["episodes"] for t in s["tasks"]] == [3, 2, 2]
    # returns after every later task but the last (Eq. 1.4): 2, 1, 1 entries
    assert [len(t["returns_after"]) for t in s["tasks"]] == [2, 1, 1]
    for t in s["tasks"]:
        assert len(t["eval_returns_final"]) == 1 and t["returns_after"][0] == t["initial_return"]
    run = RunDir(out, create=False)
    rows = run.read_csv("metrics.csv")
    assert [int(r["task"]) for r in rows] == [0] * 3 + [1] * 2 + [2] * 2
    # the default protocol decays epsilon per environment step (SPEC §1.6): episode 2 starts
    # at 0.995 ** (steps of episode 1)
    first_len = int(rows[0]["length"])
    assert float(rows[0]["epsilon"]) == 1.0
    assert float(rows[1]["epsilon"]) == pytest.approx(0.995**first_len, rel=1e-4)
    assert run.read_csv("neuromod.csv")  # rows every sample_interval steps
    assert run.read_config()["config"]["variant"] == variant


@pytest.mark.parametrize("variant", ["finetune", "ewc"])
def test_shared_body_variants_through_the_cli(tmp_path, tiny_cfg, variant):
    out = tmp_path / variant
    s = _train_cli(tiny_cfg, variant, out)
    _check_run_files(out, s, variant)
    ckpt = load_checkpoint(out / "checkpoints" / "task2.safetensors")["agent"]
    assert ("ewc" in ckpt) == (variant == "ewc")
    agent = load_agent(out)  # the saved agent is the trained one
    if variant == "ewc":
        assert len(agent.ewc.anchors) == 3 and len(agent.ewc.anchors[0][0]) == 4
        saved = ckpt["ewc"]["anchors"][1][0][2]
        assert torch.equal(agent.ewc.anchors[1][0][2], saved)
    x = torch.zeros(1, 6)
    assert agent.greedy_q(x, 1).shape == (1, 3)


def test_sb3_dqn_through_the_cli_writes_nothing_outside_the_run(tmp_path, tiny_cfg, monkeypatch):
    scratch = tmp_path / "tmp"
    cwd = tmp_path / "cwd"
    scratch.mkdir()
    cwd.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr(tempfile, "tempdir", None)
    monkeypatch.chdir(cwd)
    out = tmp_path / "sb3"
    before_rng = (np.random.get_state()[1].copy(), torch.random.get_rng_state().clone())
    s = _train_cli(tiny_cfg, "sb3-dqn", out)
    _check_run_files(out, s, "sb3-dqn")
    assert not [p for p in scratch.iterdir() if p.name.startswith("SB3")]
    assert list(cwd.iterdir()) == []
    # SB3 seeds the global generators inside a scope that restores them
    assert np.array_equal(np.random.get_state()[1], before_rng[0])
    assert torch.equal(torch.random.get_rng_state(), before_rng[1])
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "sb3_progress.json",
        "sb3_task0.safetensors",
        "sb3_task1.safetensors",
        "sb3_task2.safetensors",
    ]
    for t in s["tasks"]:  # a model per task, re-evaluated from its file: 1 by construction
        assert t["retention"] == 1.0 and t["returns_after"] == [t["initial_return"]] * len(
            t["returns_after"]
        )


def test_sb3_dqn_resume_after_a_finished_task_gives_the_same_run(tmp_path, tiny_cfg):
    full = tmp_path / "full"
    s_full = _train_cli(tiny_cfg, "sb3-dqn", full, seed=3)
    part = tmp_path / "part"
    shutil.copytree(full, part)
    progress = json.loads((part / "checkpoints" / "sb3_progress.json").read_text())
    progress["results"] = progress["results"][:1]
    progress["results"][0]["returns_after"] = progress["results"][0]["returns_after"][:1]
    progress["step"] = progress["results"][0]["end_step"]
    assert progress["elapsed"]["timing_complete"] is True  # the time is saved with the progress
    progress["elapsed"] = {"wall_seconds": 1000.0, "cpu_seconds": 500.0, "timing_complete": True}
    (part / "checkpoints" / "sb3_progress.json").write_text(json.dumps(progress))
    for name in ("sb3_task1.safetensors", "sb3_task2.safetensors"):
        (part / "checkpoints" / name).unlink()
    (part / "summary.json").unlink()
    res = runner.invoke(biarm_app, ["train", "--resume", "--quiet", "--out", str(part)])
    assert res.exit_code == 0, (res.output, res.exception)
    s_part = RunDir(part, create=False).read_summary()

    def strip(s: dict) -> dict:
        s = {k: v for k, v in s.items() if k not in TIMING_KEYS}
        s["tasks"] = [{k: v for k, v in t.items() if k not in TIMING_KEYS} for t in s["tasks"]]
        return s

    assert strip(s_part) == strip(s_full)
    assert (part / "metrics.csv").read_text() == (full / "metrics.csv").read_text()
    # the earlier session's time is added to this one's
    assert 1000.0 < s_part["wall_seconds"] < 1000.0 + s_full["wall_seconds"] + 60.0
    assert s_part["cpu_seconds"] > 500.0 and s_part["timing_complete"] is True
    assert s_full["cpu_seconds"] > 0.0 and s_full["timing_complete"] is True


def test_biarm_compare_accepts_the_new_variants(tmp_path, tiny_cfg):
    out = tmp_path / "cmp"
    args = ["compare", "--variants", "finetune,sb3-dqn", "--seeds", "0", "--workers", "1"]
    args += ["--config", str(tiny_cfg), "--episodes-scale", "0.5", "--set", "eval.episodes=1"]
    res = runner.invoke(biarm_app, [*args, "--out", str(out)])
    assert res.exit_code == 0, (res.output, res.exception)
    with open(out / "table_continual.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["variant"], r["env_id"]) for r in rows][:4] == [
        ("finetune", "CartPole-v1"),
        ("finetune", "Acrobot-v1"),
        ("finetune", "MountainCar-v0"),
        ("sb3-dqn", "CartPole-v1"),
    ]
    s = RunDir(out / "runs" / "finetune__s0", create=False).read_summary()
    assert float(rows[0]["final_mean"]) == s["tasks"][0]["final_return"]


def test_unknown_variant_lists_every_choice(tmp_path):
    for args in (
        ["train", "--variant", "nope", "--out", str(tmp_path / "x")],
        ["compare", "--variants", "finetune,nope", "--out", str(tmp_path / "y")],
    ):
        res = runner.invoke(biarm_app, args)
        assert res.exit_code != 0 and isinstance(res.exception, EvodevoError)
        for name in VARIANTS:
            assert name in str(res.exception)
    help_text = runner.invoke(biarm_app, ["train", "--help"], terminal_width=200).output
    for name in VARIANTS:
        assert name in help_text


# ---------------------------------------------------------------------------- compare biarm
ENVS = ["CartPole-v1", "Acrobot-v1", "MountainCar-v0"]


def _fixture_run(
    path: Path, variant: str, seed: int, tasks: list[tuple[list[float], float]]
) -> Path:
    """A finished run directory: per task (returns_after, final_return)."""
    run = RunDir(path)
    run.write_config({"variant": variant, "seed": seed, "episodes_scale": 0.1}, kind="biarm")
    entries = []
    for env, (after, final) in zip(ENVS, tasks, strict=True):
        entries.append(
            {
                "env_id": env,
                "episodes": 40,
                "initial_return": after[0],
                "final_return": final,
                "returns_after": after,
                "retention": 0.0,
                "us_per_step": 1.0,
            }
        )
    summary = {"variant": variant, "seed": seed, "eval_seeds": [10000, 10001], "tasks": entries}
    run.write_summary(summary)
    return path


def test_compare_biarm_tables_from_fixture_runs(tmp_path):
    a = _fixture_run(
        tmp_path / "ft0", "finetune", 0, [([100, 150], 90), ([-100], -80), ([-200], -150)]
    )
    b = _fixture_run(
        tmp_path / "ft1", "finetune", 1, [([200, 120], 180), ([-100], -120), ([-190], -160)]
    )
    grid = tmp_path / "grid"
    _fixture_run(
        grid / "runs" / "pnn__s0", "pnn", 0, [([400, 400], 400), ([-90], -90), ([-150], -150)]
    )
    out = tmp_path / "table"
    res = runner.invoke(
        root_app, ["compare", "biarm", str(a), str(b), str(grid), "--out", str(out)]
    )
    assert res.exit_code == 0, (res.output, res.exception)
    with open(out / "table_continual.csv") as fh:
        rows = {(r["variant"], r["env_id"]): r for r in csv.DictReader(fh)}
    ft = rows[("finetune", "CartPole-v1")]
    assert ft["n_seeds"] == "2" and ft["seeds"] == "0 1" and ft["episodes"] == "40"
    assert float(ft["initial_mean"]) == 150.0
    assert float(ft["final_mean"]) == 135.0
    assert float(ft["final_std"]) == pytest.approx(math.sqrt(2 * 45**2))
    lo, hi = bootstrap_ci([90.0, 180.0])
    assert float(ft["final_ci_low"]) == pytest.approx(lo) and float(
        ft["final_ci_high"]
    ) == pytest.approx(hi)
    assert float(ft["retention"]) == pytest.approx(0.9)  # 135 / 150
    # Eq. 1.4 per seed: max(100, 150) - 90 = 60 and max(200, 120) - 180 = 20
    assert float(ft["forgetting_mean"]) == 40.0
    assert float(ft["forgetting_std"]) == pytest.approx(math.sqrt(2 * 20**2))
    assert math.isnan(float(ft["thesis_final_mean"]))
    acro = rows[("finetune", "Acrobot-v1")]  # both negative: initial / final
    assert float(acro["retention"]) == pytest.approx(-100 / -100)  # means -100 and -100
    assert float(acro["forgetting_mean"]) == pytest.approx((-20 + 20) / 2)
    assert math.isnan(float(rows[("finetune", "MountainCar-v0")]["forgetting_mean"]))
    pnn = rows[("pnn", "CartPole-v1")]
    assert float(pnn["forgetting_mean"]) == 0.0 and float(pnn["retention"]) == 1.0
    assert float(pnn["thesis_final_mean"]) == 491.0 and float(pnn["thesis_retention"]) == 0.9895
    md = (out / "table_continual.md").read_text()
    assert "| pnn | CartPole-v1 | 1 | 400.00 ± 0.00 [400.00, 400.00]" in md
    assert "— (last task)" in md and "finetune: seeds 0-1" in md and "episodes_scale 0.1" in md
    assert list(rows)[0] == ("pnn", "CartPole-v1")  # table order: known variants first


def test_compare_biarm_bad_inputs(tmp_path):
    a = _fixture_run(tmp_path / "a", "ewc", 0, [([1], 1), ([1], 1), ([1], 1)])
    b = _fixture_run(tmp_path / "b", "ewc", 0, [([1], 1), ([1], 1), ([1], 1)])
    kuka = tmp_path / "kuka"
    RunDir(kuka).write_config({"method": "ppo"}, kind="baseline_kuka")
    RunDir(kuka).write_summary({"method": "ppo"})
    for args, match in (
        ([str(a), str(b)], "seed 0 is in both"),
        ([str(kuka)], "not a BIARM run"),
        ([str(tmp_path / "missing")], "neither summary.json nor runs/"),
    ):
        res = runner.invoke(root_app, ["compare", "biarm", *args, "--out", str(tmp_path / "o")])
        assert res.exit_code != 0 and isinstance(res.exception, EvodevoError), res.output
        assert match in str(res.exception)
    assert not os.path.exists(tmp_path / "o" / "table_continual.md")
