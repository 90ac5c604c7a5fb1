"""The DQN protocol details Table 3.1 leaves open (SPEC §1.6): ε unit, target
update, double Q, which network a task keeps, the v1 preset and the sweep."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
import yaml

from evodevo.config import from_dict, load_config, to_dict
from evodevo.errors import ConfigError
from evodevo.neuromod import train
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.columns import huber
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.keep_best import BestColumn
from evodevo.neuromod.protocols import PROTOCOLS, apply_protocol, protocol_config
from evodevo.neuromod.replay import ReplayBuffer
from evodevo.neuromod.tasks import resolve_tasks
from evodevo.neuromod.trainer import TIMING_KEYS, TaskRunner
from evodevo.neuromod.variants import get_variant

pytestmark = pytest.mark.usefixtures("one_torch_thread")

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).with_name("data")


def cfg_with(**dqn: Any) -> BiarmConfig:
    return from_dict(
        BiarmConfig,
        {
            "tasks": [{"env_id": "CartPole-v1", "episodes": 3, "max_steps": 40}],
            "dqn": {"batch_size": 8, "learning_starts": 8, **dqn},
            "eval": {"episodes": 2},
        },
    )


# ---------------------------------------------------------------- epsilon
@pytest.mark.parametrize("unit", ["step", "episode"])
def test_epsilon_after_k_steps_or_episodes(unit):
    cfg = cfg_with(eps_unit=unit, eps_decay=0.9, eps_min=0.05)
    specs, d_max = resolve_tasks(cfg)
    agent = BiarmAgent(cfg, get_variant("pnn"), d_max, 0)
    runner = TaskRunner(agent, specs[0], 0, seed=0)
    try:
        lengths = [runner.episode() for _ in range(2)]
    finally:
        runner.close()
    k = sum(lengths) if unit == "step" else 2
    expected = 1.0
    for _ in range(k):  # by hand: multiply, then clip at the floor
        expected = max(0.05, expected * 0.9)
    assert runner.eps == pytest.approx(expected, rel=0, abs=1e-12)
    assert k > 2 or unit == "episode"


# ---------------------------------------------------------------- train_every
@pytest.mark.parametrize("every", [1, 3])
def test_train_every_k_steps_counts_gradient_steps(every, monkeypatch):
    cfg = cfg_with(train_every=every, learning_starts=8)
    specs, d_max = resolve_tasks(cfg)
    agent = BiarmAgent(cfg, get_variant("pnn"), d_max, 0)
    at: list[int] = []
    original = agent.update

    def spy(batch):
        at.append(runner.buf.size - 1)  # index of the task's step just stored
        return original(batch)

    monkeypatch.setattr(agent, "update", spy)
    runner = TaskRunner(agent, specs[0], 0, seed=0)
    try:
        n = sum(runner.episode() for _ in range(2))
    finally:
        runner.close()
    # by hand: after the step with index t (0-based, buffer size t + 1 >= learning_starts),
    # a gradient step when (t + 1) is a multiple of every
    expected = [t for t in range(n) if t + 1 >= 8 and (t + 1) % every == 0]
    assert at == expected and len(at) > 3


# ---------------------------------------------------------------- target network
def _agent_after_updates(n: int, **dqn: Any) -> BiarmAgent:
    cfg = cfg_with(**dqn)
    agent = BiarmAgent(cfg, get_variant("pnn"), 4, 0)
    agent.begin_task(2)
    buf = ReplayBuffer(64, 4)
    rng = np.random.default_rng(0)
    for _ in range(32):
        buf.add(rng.normal(size=4).astype(np.float32), int(rng.integers(2)), 1.0,
                rng.normal(size=4).astype(np.float32), bool(rng.random() < 0.1), 1.0)  # fmt: skip
    for _ in range(n):
        agent.update(buf.sample(rng, 8))
    return agent


def test_soft_update_with_tau_one_is_a_hard_copy():
    soft = _agent_after_updates(3, target_mode="soft", tau=1.0)
    hard = _agent_after_updates(3, target_mode="hard", target_update=1)
    assert soft.target is not None and hard.target is not None
    s_t, h_t = soft.target.state_dict(), hard.target.state_dict()
    online = soft.net.current.state_dict()
    for k in s_t:
        assert torch.equal(s_t[k], h_t[k]), k
        assert torch.equal(s_t[k], online[k]), k


def test_soft_update_moves_target_by_tau():
    agent = _agent_after_updates(0, target_mode="soft", tau=0.25)
    assert agent.target is not None
    before = {k: v.clone() for k, v in agent.target.state_dict().items()}
    rng = np.random.default_rng(1)
    buf = ReplayBuffer(64, 4)
    for _ in range(16):
        buf.add(rng.normal(size=4).astype(np.float32), 1, 0.5, rng.normal(size=4).astype(np.float32), False, 1.0)  # fmt: skip
    agent.update(buf.sample(rng, 8))
    online = agent.net.current.state_dict()
    for k, v in agent.target.state_dict().items():
        assert torch.allclose(v, before[k] + 0.25 * (online[k] - before[k]), atol=1e-6), k


# ---------------------------------------------------------------- double Q
@pytest.mark.parametrize("kernel", ["torch", "cpp"])
@pytest.mark.parametrize("double_q", [False, True])
def test_double_q_target_on_a_hand_built_batch(kernel, double_q):
    if kernel == "cpp":
        from evodevo.neuromod.kernels import load

        if load() is None:
            pytest.skip("C++ kernels unavailable")
    cfg = cfg_with(double_q=double_q, target_mode="hard", target_update=10_000)
    cfg.network.lateral_kernel = kernel
    agent = BiarmAgent(cfg, get_variant("pnn"), 4, 0)
    agent.begin_task(3)
    assert agent.target is not None
    with torch.no_grad():  # a target that disagrees with the online column
        for p in agent.target.parameters():
            p.mul_(-1.5)
    g = torch.Generator().manual_seed(3)
    obs, nobs = torch.randn(6, 4, generator=g), torch.randn(6, 4, generator=g)
    act = torch.tensor([0, 1, 2, 0, 1, 2])
    rew = torch.tensor([1.0, 0.0, -1.0, 0.5, 2.0, 0.0])
    term = torch.tensor([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    batch = (obs, nobs, act, rew, term, torch.ones(6))
    with torch.no_grad():
        q_on_next = agent.net.current(nobs)
        q_tg_next = agent.target(nobs)
        if double_q:  # the online column picks, the target column values
            q_next = q_tg_next[torch.arange(6), q_on_next.argmax(1)]
        else:
            q_next = q_tg_next.max(1).values
        y = rew + 0.99 * (1 - term) * q_next
        q = agent.net.current(obs)[torch.arange(6), act]
        expected = float(huber(q, y, 1.0))
    # the two readings must really differ on this batch, or the test could not fail
    assert not torch.equal(q_on_next.argmax(1), q_tg_next.argmax(1))
    assert agent.fused_update is (kernel == "cpp")
    loss = float(agent.td_loss(batch).detach())
    assert loss == pytest.approx(expected, rel=1e-5)


# ---------------------------------------------------------------- keep the best column
def test_best_column_kept_and_never_reads_evaluation_seeds(monkeypatch):
    cfg = cfg_with(keep="best")
    cfg.eval.validation_every = 1
    specs, d_max = resolve_tasks(cfg)
    agent = BiarmAgent(cfg, get_variant("pnn"), d_max, 0)
    agent.begin_task(2)
    seen: list[list[int]] = []
    scripted = iter([10.0, 30.0, 20.0])

    def fake_eval(agent_: Any, col: int, task: Any, seeds: list[int]) -> list[float]:
        seen.append(list(seeds))
        return [next(scripted)] * len(seeds)

    monkeypatch.setattr("evodevo.neuromod.keep_best.evaluate_column", fake_eval)
    keeper = BestColumn(cfg, episodes=3)
    states = []
    for k in range(1, 4):
        with torch.no_grad():
            agent.net.current.w1.add_(float(k))  # a different column at every check
        states.append(agent.net.current.w1.detach().clone())
        keeper.check(agent, 0, specs[0], k, step=10 * k)
    record = keeper.restore(agent)
    assert torch.equal(agent.net.current.w1, states[1])  # the check that returned 30
    assert record["best_episode"] == 2 and record["best_validation_return"] == 30.0
    evaluation = set(range(cfg.eval.seed, cfg.eval.seed + cfg.eval.episodes))
    assert seen and all(not (set(s) & evaluation) for s in seen)


def test_keep_best_run_records_validation(tmp_path):
    cfg = cfg_with(keep="best")
    cfg.eval.validation_every = 2
    cfg.eval.validation_episodes = 2
    summary = train(cfg, "pnn", 0, tmp_path)
    task = summary["tasks"][0]
    assert task["validation"]["kept"] == "best"
    assert task["validation"]["validation_checks"] == 2  # after episode 2 and the last (3)
    assert len(task["validation"]["last_network_returns"]) == cfg.eval.episodes
    rows = (tmp_path / "validation.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[0].startswith("task,env_id,episode")


# ---------------------------------------------------------------- per-task settings
def _two_tasks(**per_task: Any) -> BiarmConfig:
    return from_dict(
        BiarmConfig,
        {
            "tasks": [
                {"env_id": "CartPole-v1", "episodes": 3, "max_steps": 40},
                {"env_id": "Acrobot-v1", "episodes": 3, "max_steps": 40},
            ],
            "dqn": {"batch_size": 8, "learning_starts": 8, "keep": "best", "per_task": per_task},
            "eval": {"episodes": 2, "validation_every": 2, "validation_episodes": 2},
        },
    )


def test_per_task_override_applies_to_its_task_only(tmp_path):
    """``dqn.per_task``: CartPole keeps its last network, Acrobot (no entry) the best one."""
    cfg = _two_tasks(**{"CartPole-v1": {"keep": "last", "grad_clip": 1.0}})
    assert cfg.dqn.for_task("CartPole-v1").grad_clip == 1.0
    assert cfg.dqn.for_task("Acrobot-v1") is cfg.dqn and cfg.dqn.grad_clip == 10.0
    summary = train(cfg, "pnn", 0, tmp_path)
    cartpole, acrobot = summary["tasks"]
    assert "validation" not in cartpole and acrobot["validation"]["kept"] == "best"
    rows = (tmp_path / "validation.csv").read_text().splitlines()[1:]
    assert rows and all(r.split(",")[1] == "Acrobot-v1" for r in rows)


def test_per_task_entry_with_the_base_values_changes_nothing(tmp_path):
    plain = train(_two_tasks(), "pnn", 0, tmp_path / "plain")
    same = train(
        _two_tasks(**{"CartPole-v1": {"grad_clip": 10.0, "tau": 0.005}}), "pnn", 0, tmp_path / "s"
    )
    assert _strip(same["tasks"]) == _strip(plain["tasks"])


def test_per_task_override_from_the_command_line():
    from evodevo.neuromod.resolve import resolve_biarm

    cfg = resolve_biarm("default", sets=["dqn.per_task.CartPole-v1.grad_clip=1.0"])
    assert cfg.dqn.per_task == {"CartPole-v1": {"grad_clip": 1.0}}
    assert cfg.for_task("CartPole-v1").dqn.grad_clip == 1.0 and cfg.dqn.grad_clip == 10.0


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("data", "needle"),
    [
        ({"dqn": {"eps_unit": "minute"}}, ("dqn.eps_unit", "'minute'")),
        ({"dqn": {"target_mode": "polyak"}}, ("dqn.target_mode", "'polyak'")),
        ({"dqn": {"keep": "first"}}, ("dqn.keep", "'first'")),
        ({"dqn": {"tau": 0.0}}, ("dqn.tau=0.0", "(0, 1]")),
        ({"dqn": {"tau": 1.5}}, ("dqn.tau=1.5", "(0, 1]")),
        ({"dqn": {"train_every": 0}}, ("dqn.train_every=0",)),
        ({"eval": {"validation_episodes": 0}}, ("eval.validation_episodes=0",)),
        ({"eval": {"validation_seed": 1_000_010}}, ("eval.validation_seed=1000010", "test range")),
        (
            {"eval": {"seed": 10_000, "validation_seed": 10_010}},
            ("eval.validation_seed=10010", "overlap"),
        ),
        ({"dqn": {"per_task": {"CartPole-v1": {"clip": 1}}}}, ("dqn.per_task.CartPole-v1.clip",)),
        (
            {"dqn": {"per_task": {"CartPole-v1": {"grad_clip": -1}}}},
            ("dqn.per_task.CartPole-v1", "dqn.grad_clip=-1.0"),
        ),
        ({"dqn": {"per_task": {"CartPole-v1": 1.0}}}, ("dqn.per_task.CartPole-v1=1.0",)),
    ],
)
def test_bad_protocol_values_are_one_clear_error(data, needle):
    with pytest.raises(ConfigError) as info:
        load_config(BiarmConfig, None, data)
    message = str(info.value)
    assert "\n" not in message and all(n in message for n in needle), message


# ---------------------------------------------------------------- presets
def test_config_files_match_the_protocols():
    default = yaml.safe_load((ROOT / "configs" / "biarm.yaml").read_text())
    assert to_dict(from_dict(BiarmConfig, default)) == to_dict(protocol_config("default"))
    v1 = yaml.safe_load((ROOT / "configs" / "biarm_spec_v1.yaml").read_text())
    assert to_dict(from_dict(BiarmConfig, v1)) == to_dict(protocol_config("v1"))
    v2 = yaml.safe_load((ROOT / "configs" / "biarm_v2.yaml").read_text())
    assert to_dict(from_dict(BiarmConfig, v2)) == to_dict(protocol_config("v2"))
    scaled = to_dict(protocol_config("scaled"))
    assert scaled["eval"]["validation_episodes"] == 10
    scaled["eval"]["validation_episodes"] = 20  # the only difference from v3
    assert scaled == to_dict(protocol_config("v3"))
    v3 = to_dict(protocol_config("v3"))
    assert v3["dqn"]["per_task"] == {} and default["dqn"]["per_task"] != {}
    v3["dqn"]["per_task"] = default["dqn"]["per_task"]  # the only difference from the default
    assert v3 == to_dict(protocol_config("default"))
    assert set(PROTOCOLS) == {"default", "v3", "scaled", "v2", "v1"}


def test_a_protocol_clears_the_per_task_settings_of_a_config_file():
    """``--protocol v3`` over ``configs/biarm.yaml`` (CartPole clipped at 1) trains CartPole
    with the common clip: the protocol's empty ``per_task`` replaces the file's."""
    cfg = load_config(BiarmConfig, ROOT / "configs" / "biarm.yaml", apply_protocol({}, "v3"))
    assert cfg.dqn.per_task == {} and cfg.dqn.for_task("CartPole-v1").grad_clip == 10.0
    over = apply_protocol({"dqn": {"per_task": {"Acrobot-v1": {"tau": 0.01}}}}, "default")
    cfg = load_config(BiarmConfig, ROOT / "configs" / "biarm.yaml", over)
    assert cfg.dqn.for_task("CartPole-v1").grad_clip == 1.0
    assert cfg.dqn.for_task("Acrobot-v1").tau == 0.01


def _strip(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in TIMING_KEYS}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


@pytest.mark.parametrize("variant", ["pnn", "biarm"])
def test_v1_preset_reproduces_the_first_protocol_bit_for_bit(tmp_path, variant):
    """``tests/data/v1_summary_{variant}.json`` was written by the code before the DQN protocols existed (commit
    0018ec7) for this tiny run; the v1 preset must give the same summary, float for float."""
    data: dict[str, Any] = {
        "tasks": [
            {"env_id": "CartPole-v1", "episodes": 6, "max_steps": 500},
            {"env_id": "Acrobot-v1", "episodes": 2, "max_steps": 100},
        ],
        "checkpoint_every": 0,
        # the evaluation seeds of the reference (validation seeds since the split, SPEC §6)
        "eval": {"episodes": 2, "seed": 10_000},
        "dqn": {"target_update": 25, "learning_starts": 32},
    }
    from evodevo.neuromod.protocols import apply_protocol

    cfg = load_config(BiarmConfig, None, apply_protocol(data, "v1"))
    summary = _strip(json.loads(json.dumps(train(cfg, variant, 3, tmp_path))))
    reference = json.loads((DATA / f"v1_summary_{variant}.json").read_text())
    if reference.get("lateral_kernel") != summary.get("lateral_kernel"):
        pytest.skip("the reference was written with the other lateral kernel")
    assert summary == reference


# ---------------------------------------------------------------------------- the sweep
def test_tiny_sweep_trains_each_task_alone_and_tables_best_and_last(tmp_path):
    """Two protocols x one task x one seed through ``run_sweep``; the table has a row per
    protocol, and the keep-best protocol also a ``(last network)`` row read from the same runs;
    a second call trains nothing (finished runs are skipped)."""
    from evodevo.neuromod.protocol_sweep import SweepSpec, run_sweep, sweep_table

    tiny = {"dqn": {"batch_size": 8, "learning_starts": 8}, "eval": {"episodes": 1}}
    spec = SweepSpec.from_dict(
        {
            "protocols": {
                "v1": {**tiny, "dqn": {**tiny["dqn"], "eps_unit": "episode", "keep": "last"}},
                "best": {
                    **tiny,
                    "eval": {"episodes": 1, "validation_episodes": 1, "validation_every": 1},
                },
            },
            "tasks": ["CartPole-v1"],
            "variants": ["pnn"],
            "seeds": "0",
            "episodes_scale": 2 / 400,  # 2 episodes
        }
    )
    out = tmp_path / "sweep"
    assert len(run_sweep(spec, out)) == 2
    assert run_sweep(spec, out) == []
    best = json.loads((out / "best" / "CartPole-v1" / "pnn__s0" / "summary.json").read_text())
    v = best["tasks"][0]["validation"]
    assert v["kept"] == "best" and v["validation_checks"] == 2
    text = sweep_table(spec, out)
    rows = [r for r in text.splitlines() if r.startswith("| ")]
    assert [r.split(" | ")[0] for r in rows[1:]] == ["| v1", "| best", "| best (last network)"]
    last = float(np.mean(v["last_network_returns"]))
    assert f"{last:.1f} ± 0.0" in rows[3]
    assert (out / "sweep.md").read_text() == text


# ---------------------------------------------------------------------------- lateral init
@pytest.mark.parametrize("gated", [False, True])
def test_zero_lateral_init_starts_a_column_as_an_isolated_one(gated):
    """``network.lateral_init: zero``: a new column's U maps are zero, so its Q-values are those
    of the same column without laterals; every other parameter equals the Xavier draw."""
    from evodevo.neuromod.columns import ProgressiveNet

    nets = {}
    for init in ("xavier", "zero"):
        net = ProgressiveNet(4, 16, gated, 4, seed=3, lateral_kernel="torch", lateral_init=init)
        net.add_column(2)
        net.add_column(3)
        nets[init] = net
    zx, zz = nets["xavier"].current, nets["zero"].current
    for name, p in zx.named_parameters():
        if name in ("u2", "uq"):
            assert not torch.equal(p, getattr(zz, name)) and not getattr(zz, name).any()
        else:
            assert torch.equal(p, getattr(zz, name)), name
    x = torch.randn(5, 4, generator=torch.Generator().manual_seed(0))
    states = torch.full((4,), 0.5)
    q = nets["zero"].q(x, 1, states)
    h1 = torch.relu(x @ zz.w1 + zz.b1)
    h2 = torch.relu(h1 @ zz.w2 + zz.b2)
    torch.testing.assert_close(q, h2 @ zz.wq + zz.bq)


def test_lateral_init_must_be_known():
    with pytest.raises(ConfigError, match="network.lateral_init='ones'"):
        from_dict(BiarmConfig, {"network": {"lateral_init": "ones"}})


def test_runs_written_before_lateral_init_resume_as_xavier(tmp_path):
    """A config.json without ``network.lateral_init`` (older runs) resumes under ``xavier`` and
    is refused under ``zero``."""
    from evodevo.errors import CheckpointError
    from evodevo.neuromod.resume import check_resume
    from evodevo.runs import RunDir

    run = RunDir(tmp_path / "old")
    cfg = protocol_config("v2")  # Xavier laterals, as every run before the key
    old = {"variant": "pnn", "seed": 0, **to_dict(cfg)}
    del old["network"]["lateral_init"]
    run.write_config(old, kind="biarm")
    check_resume(run, get_variant("pnn"), 0, cfg)
    cfg.network.lateral_init = "zero"
    with pytest.raises(CheckpointError, match="network"):
        check_resume(run, get_variant("pnn"), 0, cfg)


def test_runs_written_before_per_task_resume_without_it(tmp_path):
    """A config.json without ``dqn.per_task`` (every run before it existed) resumes with no
    per-task settings, not with today's default (CartPole clipped at 1): ``train --resume``
    reads it so, and the consistency check accepts it."""
    from evodevo.cli.biarm import _resume_settings
    from evodevo.neuromod.resume import check_resume
    from evodevo.runs import RunDir

    run = RunDir(tmp_path / "old")
    cfg = protocol_config("v3")
    old = {"variant": "pnn", "seed": 3, **to_dict(cfg)}
    del old["dqn"]["per_task"]
    run.write_config(old, kind="biarm")
    variant, seed, resumed = _resume_settings(run.path, None, None, own_config=False)
    assert (variant, seed) == ("pnn", 3) and resumed.dqn.per_task == {}
    assert to_dict(resumed) == to_dict(cfg)
    check_resume(run, get_variant("pnn"), 3, resumed)


def test_the_resolver_applies_preset_then_file_then_set_then_flags(tmp_path):
    """One order for every command: defaults, protocol preset, --config, --set, flags."""
    from evodevo.neuromod.resolve import resolve_biarm

    f = tmp_path / "c.yaml"
    f.write_text("eval: {validation_episodes: 7, episodes: 3}\nepisodes_scale: 0.5\n")
    cfg = resolve_biarm("v1", f, ["eval.episodes=4"], episodes_scale=0.25)
    assert cfg.dqn.eps_unit == "episode"  # the preset
    assert cfg.eval.validation_episodes == 7  # the file over the preset's 10
    assert cfg.eval.episodes == 4  # --set over the file
    assert cfg.episodes_scale == 0.25  # the flag over the file
    with pytest.raises(ConfigError, match="'nope' is not one of"):
        resolve_biarm("nope")
    with pytest.raises(ConfigError, match="dqn.nope"):
        resolve_biarm(sets=["dqn.nope=1"])
