"""Opening a run folder never runs code from it (SPEC §6; STYLE.md: no pickle in a file that
somebody else may hand you).

Every loader gets a planted file under the exact name it reads — a pickle, a PyTorch zip or a
gzip whose unpickling would write a marker file — and must leave the marker unwritten and raise
one clear :class:`~evodevo.errors.CheckpointError` that names the file. The old pickle-based
names (``task3.pt``, ``best_genome.pkl``, ``model.zip``, ``neat-checkpoint-1``) are refused
unopened, pointing at the conversion script. Legitimate files round-trip without any unpickling
(pickle, cloudpickle and ``torch.load`` are made to fail while they load).
"""

from __future__ import annotations

import base64
import gzip
import io
import json
import pickle
import shutil
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

import evodevo
from evodevo.config import from_dict, to_dict
from evodevo.errors import CheckpointError, EvodevoError
from evodevo.neuromod import train
from evodevo.neuromod.config import BiarmConfig
from evodevo.runs import RunDir, write_json
from evodevo.safe_io import CONVERT_SCRIPT, load_state, save_state

pytestmark = pytest.mark.usefixtures("one_torch_thread")

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()

TINY_BIARM: dict[str, Any] = {
    "tasks": [{"env_id": "CartPole-v1", "episodes": 3, "max_steps": 30}],
    "dqn": {"batch_size": 8, "learning_starts": 8},
    "modules": {"sample_interval": 10},
    "eval": {"episodes": 1},
    "checkpoint_every": 2,
}


class Payload:
    """Unpickling this writes ``marker``: the proof that a loader ran code from a file."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (exec, (f"open({str(self.marker)!r}, 'w').write('ran')",))


def _pickle(marker: Path) -> bytes:
    return pickle.dumps({"agent": Payload(marker)}, protocol=4)


def _torch_zip(marker: Path) -> bytes:
    buf = io.BytesIO()
    torch.save({"agent": Payload(marker), "format": "evodevo-biarm"}, buf)
    return buf.getvalue()


def _gzip(marker: Path) -> bytes:
    return gzip.compress(_pickle(marker))


def _sb3_zip(marker: Path) -> bytes:
    """A Stable-Baselines3 zip whose ``data`` JSON carries a cloudpickled payload."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        evil = base64.b64encode(pickle.dumps(Payload(marker))).decode()
        z.writestr("data", json.dumps({"policy_class": {":type:": "x", ":serialized:": evil}}))
        z.writestr("policy.pth", _torch_zip(marker))
    return buf.getvalue()


PAYLOADS = {"pickle": _pickle, "torch-zip": _torch_zip, "gzip": _gzip}


def _plant(path: Path, kind: str, marker: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(PAYLOADS[kind](marker))
    return path


def _refused(call: Any, path: Path, marker: Path, match: str = "") -> str:
    """``call()`` raises one CheckpointError naming ``path``; no code from the file ran."""
    with pytest.raises(CheckpointError) as err:
        call()
    msg = str(err.value)
    assert not marker.exists(), "the planted file's code ran"
    assert str(path) in msg and "\n" not in msg, msg
    if match:
        assert match in msg, msg
    return msg


@pytest.fixture(scope="module")
def biarm_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished one-task BIARM run (3 episodes): ``checkpoints/task0.safetensors``."""
    out = tmp_path_factory.mktemp("biarm") / "run"
    train(from_dict(BiarmConfig, TINY_BIARM), "biarm", 1, out)
    return out


@pytest.fixture
def run_copy(biarm_run: Path, tmp_path: Path) -> Path:
    out = tmp_path / "run"
    shutil.copytree(biarm_run, out)
    return out


# ---------------------------------------------------------------------------- BIARM


@pytest.mark.parametrize("kind", sorted(PAYLOADS))
def test_evodevo_load_refuses_a_planted_old_checkpoint_name(run_copy, tmp_path, kind):
    planted = _plant(run_copy / "checkpoints" / "task3.pt", kind, tmp_path / "marker")
    msg = _refused(lambda: evodevo.load(run_copy, task=0), planted, tmp_path / "marker")
    assert "no longer opens" in msg and CONVERT_SCRIPT in msg


@pytest.mark.parametrize("kind", sorted(PAYLOADS))
def test_evodevo_load_refuses_a_planted_checkpoint(run_copy, tmp_path, kind):
    planted = _plant(run_copy / "checkpoints" / "task0.safetensors", kind, tmp_path / "marker")
    _refused(lambda: evodevo.load(run_copy, task=0), planted, tmp_path / "marker")


@pytest.mark.parametrize("name", ["task0_ep2.safetensors", "task0_ep2.pt"])
def test_biarm_resume_refuses_a_planted_checkpoint(run_copy, tmp_path, name):
    (run_copy / "checkpoints" / "task0.safetensors").unlink()
    (run_copy / "summary.json").unlink()
    planted = _plant(run_copy / "checkpoints" / name, "torch-zip", tmp_path / "marker")
    cfg = from_dict(BiarmConfig, TINY_BIARM)
    _refused(lambda: train(cfg, "biarm", 1, run_copy, resume=True), planted, tmp_path / "marker")
    # the grid's resume (`biarm compare` picks up interrupted runs) reads the same files
    from evodevo.neuromod.compare import _run_item

    item = ("biarm", 1, to_dict(cfg), str(run_copy), None)
    _refused(lambda: _run_item(item), planted, tmp_path / "marker")


def test_biarm_video_and_report_refuse_or_ignore_planted_checkpoints(run_copy, tmp_path):
    from evodevo.cli import app

    marker = tmp_path / "marker"
    planted = _plant(run_copy / "checkpoints" / "task0.safetensors", "pickle", marker)
    res = runner.invoke(app, ["biarm", "video", str(run_copy), "--task", "0", "--out", "v.gif"])
    assert res.exit_code != 0 and not marker.exists()
    assert str(planted) in f"{res.output} {res.exception}"
    # `biarm report` reads summaries only: checkpoints next to them are never opened
    grid = tmp_path / "grid"
    shutil.copytree(run_copy, grid / "runs" / "biarm__s1")
    _plant(grid / "runs" / "biarm__s1" / "checkpoints" / "task1.pt", "torch-zip", marker)
    res = runner.invoke(app, ["biarm", "report", str(grid), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert not marker.exists()


def test_a_biarm_checkpoint_loads_without_any_unpickling(biarm_run, monkeypatch):
    from evodevo.neuromod.checkpoint import load_checkpoint

    _forbid_unpickling(monkeypatch)
    data = load_checkpoint(biarm_run / "checkpoints" / "task0.safetensors")
    assert set(data["agent"]) >= {"net", "net_config", "col"}
    policy = evodevo.load(biarm_run, task=0)
    assert policy is not None


def _forbid_unpickling(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make every unpickling entry point fail, so a load that still uses one is caught."""
    import cloudpickle

    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a loader unpickled something")

    for mod, name in (
        (pickle, "load"),
        (pickle, "loads"),
        (pickle, "Unpickler"),
        (cloudpickle, "load"),
        (cloudpickle, "loads"),
        (torch, "load"),
    ):
        monkeypatch.setattr(mod, name, refuse)


# ---------------------------------------------------------------------------- state files


def test_a_state_file_round_trips_and_refuses_a_foreign_kind(tmp_path):
    rng = np.random.default_rng(3)
    state = {
        "t": torch.arange(6.0).reshape(2, 3),
        "a": np.arange(4, dtype=np.uint8),
        "rng": rng.bit_generator.state,
        "opt": {"state": {0: {"step": torch.tensor(2.0)}}, "groups": [{"betas": (0.9, 0.99)}]},
        "none": None,
        "nan": float("nan"),
        "scalar": np.float32(0.25),
    }
    save_state(tmp_path / "s.safetensors", "example", state)
    back = load_state(tmp_path / "s.safetensors", "example")
    assert torch.equal(back["t"], state["t"]) and np.array_equal(back["a"], state["a"])
    assert back["rng"] == state["rng"] and back["opt"]["groups"][0]["betas"] == (0.9, 0.99)
    assert back["opt"]["state"][0]["step"].item() == 2.0 and np.isnan(back["nan"])
    assert back["scalar"].dtype == np.float32 and back["none"] is None
    with pytest.raises(CheckpointError, match="not a 'other' state"):
        load_state(tmp_path / "s.safetensors", "other")
    (tmp_path / "s.safetensors").write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{broken")
    with pytest.raises(CheckpointError, match="corrupt or truncated"):
        load_state(tmp_path / "s.safetensors", "example")
    with pytest.raises(TypeError, match="without pickling"):
        save_state(tmp_path / "x.safetensors", "example", {"f": object()})


# ---------------------------------------------------------------------------- SB3


def _ppo(tmp_path: Path) -> Any:
    from stable_baselines3 import PPO

    return PPO("MlpPolicy", "CartPole-v1", n_steps=16, batch_size=8, seed=0, device="cpu")


def test_sb3_models_load_without_any_unpickling_and_act_alike(tmp_path, monkeypatch):
    from stable_baselines3 import DQN

    from evodevo.baselines.sb3_files import load_sb3_policy, restore_sb3, save_sb3

    ppo = _ppo(tmp_path)
    ppo.learn(32)
    dqn = DQN("MlpPolicy", "CartPole-v1", learning_starts=8, seed=0, device="cpu")
    dqn.learn(16)
    save_sb3(ppo, tmp_path / "ppo.safetensors")
    save_sb3(dqn, tmp_path / "dqn.safetensors")
    fresh = _ppo(tmp_path)
    obs = np.random.default_rng(0).normal(size=(5, 4)).astype(np.float32)
    with monkeypatch.context() as m:
        _forbid_unpickling(m)
        for model, name, algo in ((ppo, "ppo", "ppo"), (dqn, "dqn", "dqn")):
            policy = load_sb3_policy(algo, tmp_path / f"{name}.safetensors")
            got, _ = policy.predict(obs, deterministic=True)
            want, _ = model.predict(obs, deterministic=True)
            np.testing.assert_array_equal(got, want)
        restore_sb3(fresh, tmp_path / "ppo.safetensors")
    assert fresh.num_timesteps == ppo.num_timesteps and fresh._n_updates == ppo._n_updates
    for a, b in zip(fresh.policy.parameters(), ppo.policy.parameters(), strict=True):
        assert torch.equal(a, b)
    opt_a, opt_b = fresh.policy.optimizer.state_dict(), ppo.policy.optimizer.state_dict()
    assert opt_a["param_groups"] == opt_b["param_groups"]
    for k, v in opt_b["state"].items():
        assert all(torch.equal(v[x], opt_a["state"][k][x]) for x in v)


def test_sb3_model_naming_a_class_outside_the_allowlist_is_refused(tmp_path):
    from evodevo.baselines.sb3_files import KIND, load_sb3_policy, save_sb3

    path = tmp_path / "ppo.safetensors"
    save_sb3(_ppo(tmp_path), path)
    state = load_state(path, KIND)
    state["policy_params"]["activation_fn"] = {"class": "builtins.exec"}
    save_state(path, KIND, state)
    with pytest.raises(CheckpointError, match="names the class 'builtins.exec'"):
        load_sb3_policy("ppo", path)


def _sb3_run(tmp_path: Path) -> Path:
    """A PPO baseline run folder as ``evodevo baselines kuka`` leaves it (no training)."""
    from evodevo.baselines.kuka_config import KukaBaselineConfig

    run = RunDir(tmp_path / "ppo")
    run.write_config(to_dict(from_dict(KukaBaselineConfig, {"method": "ppo"})), kind="baseline")
    return run.path


@pytest.mark.parametrize("name", ["model.safetensors", "model.zip"])
def test_sb3_model_load_refuses_a_planted_model(tmp_path, name):
    from evodevo.baselines.policies import load_sb3

    run, marker = _sb3_run(tmp_path), tmp_path / "marker"
    planted = run / name
    planted.write_bytes(_sb3_zip(marker))
    _refused(lambda: evodevo.load(run), planted, marker)
    _refused(lambda: load_sb3("ppo", run / "model.safetensors"), planted, marker)


@pytest.mark.parametrize(
    "name",
    [
        "rl_model_16_steps.safetensors",
        "rl_model_16_steps.zip",
        "rl_model_replay_buffer_16_steps.pkl",
    ],
)
def test_sb3_resume_refuses_planted_checkpoints(tmp_path, name):
    from evodevo.baselines.kuka_config import KukaBaselineConfig
    from evodevo.baselines.sb3_kuka import train_sb3

    run, marker = _sb3_run(tmp_path), tmp_path / "marker"
    folder = run / "checkpoints"
    folder.mkdir()
    planted = folder / name
    planted.write_bytes(_sb3_zip(marker) if name.endswith(".zip") else _pickle(marker))
    cfg = from_dict(KukaBaselineConfig, {"method": "ppo", "budget": {"env_steps": 32}})
    _refused(lambda: train_sb3(cfg, RunDir(run), resume=True, quiet=True), planted, marker)


@pytest.mark.parametrize("content", ["pickle", "object-array"])
def test_td3_replay_buffer_load_refuses_a_planted_buffer(tmp_path, content):
    from stable_baselines3 import TD3

    from evodevo.baselines.sb3_files import load_replay_buffer, save_replay_buffer

    model = TD3("MlpPolicy", "Pendulum-v1", buffer_size=50, learning_starts=5, device="cpu")
    model.learn(8)
    good = tmp_path / "good.npz"
    save_replay_buffer(model, good)
    other = TD3("MlpPolicy", "Pendulum-v1", buffer_size=50, device="cpu")
    load_replay_buffer(other, good)
    assert other.replay_buffer.pos == model.replay_buffer.pos == 8
    assert np.array_equal(other.replay_buffer.observations, model.replay_buffer.observations)
    marker, planted = tmp_path / "marker", tmp_path / "rl_model_replay_buffer_8_steps.npz"
    if content == "pickle":
        planted.write_bytes(_pickle(marker))
    else:  # a real .npz whose array is an object array: a pickle inside the .npy
        np.savez(planted, observations=np.array([Payload(marker)], dtype=object))
    _refused(lambda: load_replay_buffer(other, planted), planted, marker)


# ---------------------------------------------------------------------------- NEAT


def _neat_run(tmp_path: Path) -> tuple[Path, Any]:
    """A NEAT baseline run folder (config, neat.ini, encoder) and its neat config."""
    from evodevo.baselines.kuka_config import KukaBaselineConfig
    from evodevo.baselines.neat_kuka import write_neat_config
    from evodevo.baselines.policies import neat_config
    from evodevo.grn.encoder import Encoder

    cfg = from_dict(KukaBaselineConfig, {"method": "neat"})
    run = RunDir(tmp_path / "neat")
    run.write_config(to_dict(cfg), kind="baseline")
    Encoder.from_seed(0).save(run / "encoder.pt")
    return run.path, neat_config(write_neat_config(cfg, 3, run))


@pytest.mark.parametrize("name", ["best_genome.json", "best_genome.pkl"])
def test_neat_genome_load_refuses_a_planted_genome(tmp_path, name):
    pytest.importorskip("neat")
    run, _ = _neat_run(tmp_path)
    planted = _plant(run / name, "pickle", tmp_path / "marker")
    _refused(lambda: evodevo.load(run), planted, tmp_path / "marker")


@pytest.mark.parametrize(
    ("name", "kind"), [("neat-checkpoint-1.json", "pickle"), ("neat-checkpoint-1", "gzip")]
)
def test_neat_resume_refuses_a_planted_population(tmp_path, name, kind):
    pytest.importorskip("neat")
    from evodevo.baselines.neat_kuka import STATE_FILE, _restore

    run, _ = _neat_run(tmp_path)
    state = {"generation": 1, "env_steps": 0, "episodes": 0, "train_s": 0.0, "history": []}
    write_json(run / "checkpoints" / STATE_FILE, state)
    planted = _plant(run / "checkpoints" / name, kind, tmp_path / "marker")
    _refused(lambda: _restore(RunDir(run)), planted, tmp_path / "marker")


def test_neat_json_resume_continues_exactly_as_an_uninterrupted_run(tmp_path, monkeypatch):
    """Three generations in one go, or one, a save to JSON, a restore and two more: the same
    populations, species and genomes (a toy fitness; no environment)."""
    pytest.importorskip("neat")
    from evodevo.baselines.neat_files import (
        genome_to_dict,
        restore_population,
        save_population,
    )
    from evodevo.baselines.policies import NeatNet, neat_config

    run, _ = _neat_run(tmp_path)
    ini = run / "neat.ini"

    def fitness(genomes: list[tuple[int, Any]], config: Any) -> None:
        for _, g in genomes:
            g.fitness = sum(c.weight for c in g.connections.values() if c.enabled)

    def snapshot(pop: Any) -> Any:
        species = {k: sorted(s.members) for k, s in pop.species.species.items()}
        return [genome_to_dict(g) for g in pop.population.values()], species

    import neat

    full = neat.Population(neat_config(ini), seed=5)
    full.run(fitness, 3)
    part = neat.Population(neat_config(ini), seed=5)
    part.run(fitness, 1)
    save_population(tmp_path / "pop.json", part, 1)
    with monkeypatch.context() as m:
        _forbid_unpickling(m)
        restored, gen = restore_population(tmp_path / "pop.json", neat_config(ini))
    assert gen == 1
    restored.run(fitness, 2)
    assert snapshot(restored) == snapshot(full)
    # the best genome's file round-trips to the same network
    best = NeatNet.from_genome(next(iter(full.population.values())), ini)
    best.save(tmp_path / "best_genome.json")
    with monkeypatch.context() as m:
        _forbid_unpickling(m)
        again = NeatNet.load(tmp_path / "best_genome.json", ini)
    assert again.behaviour_key() == best.behaviour_key()


# ---------------------------------------------------------------------------- GRN


@pytest.fixture(scope="module")
def grn_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from evodevo.cli import app

    out = tmp_path_factory.mktemp("grn") / "run"
    res = runner.invoke(
        app,
        ["grn", "evolve", "--config", str(ROOT / "configs" / "grn_pendulum.yaml")]
        + ["--population", "2", "--generations", "1", "--episodes", "1", "--quiet"]
        + ["--out", str(out)],
    )
    assert res.exit_code == 0, res.output
    return out


@pytest.mark.parametrize("content", ["pickle", "object-array"])
def test_grn_genome_load_refuses_a_planted_genome(grn_run, tmp_path, content):
    run = tmp_path / "run"
    shutil.copytree(grn_run, run)
    marker, planted = tmp_path / "marker", run / "best_genome.npz"
    if content == "pickle":
        planted.write_bytes(_pickle(marker))
    else:
        np.savez(planted, W_s=np.array([Payload(marker)], dtype=object))
    _refused(lambda: evodevo.load(run), planted, marker)


@pytest.mark.filterwarnings("ignore:Detected pickle protocol")
@pytest.mark.parametrize("kind", sorted(PAYLOADS))
def test_grn_encoder_load_refuses_a_planted_encoder(tmp_path, kind):
    from evodevo.grn.encoder import Encoder

    planted = _plant(tmp_path / "encoder.pt", kind, tmp_path / "marker")
    _refused(lambda: Encoder.load(planted), planted, tmp_path / "marker")


def test_every_refusal_is_an_evodevo_error():
    """The CLI prints CheckpointError's one line without a traceback."""
    assert issubclass(CheckpointError, EvodevoError)


# ------------------------------------------------ modules that a run folder's config names
def _planted_module(tmp_path, monkeypatch, name):
    """A run folder holding a module ``name`` that would leave a marker when imported, on the
    Python path (as when the folder is the working directory of ``python -m evodevo``)."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text('{"kind": "grn"}')
    (run / "summary.json").write_text("{}")
    marker = tmp_path / "executed"
    (run / f"{name}.py").write_text(
        f"open({str(marker)!r}, 'w').close()\nclass Ctl:\n    pass\nEnv = Ctl\n"
    )
    monkeypatch.syspath_prepend(str(run))
    return marker


def test_a_controller_named_by_a_run_folder_is_not_imported_from_it(tmp_path, monkeypatch):
    from evodevo.grn.config import GrnConfig
    from evodevo.grn.controller import make_controller

    marker = _planted_module(tmp_path, monkeypatch, "planted_ctl")
    with pytest.raises(CheckpointError, match="never runs code from a run folder"):
        make_controller(GrnConfig(controller="planted_ctl:Ctl"), 3)
    assert not marker.exists()


@pytest.mark.parametrize("maker", ["biarm", "grn"])
def test_an_environment_named_by_a_run_folder_is_not_imported_from_it(tmp_path, monkeypatch, maker):
    from evodevo.grn.env_interface import make_env as grn_make_env
    from evodevo.neuromod.tasks import make_env as biarm_make_env

    marker = _planted_module(tmp_path, monkeypatch, f"planted_env_{maker}")
    with pytest.raises(CheckpointError, match="inside the run folder"):
        if maker == "biarm":
            biarm_make_env(f"planted_env_{maker}:Planted-v0", None)
        else:
            grn_make_env(f"planted_env_{maker}:Planted-v0")
    assert not marker.exists()


def test_a_module_outside_run_folders_is_still_imported(tmp_path, monkeypatch):
    from evodevo.safe_io import check_import

    (tmp_path / "user_ctl.py").write_text("class Ctl:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    check_import("user_ctl:Ctl", "controller")  # a user's own module: no error
    check_import("CartPole-v1", "environment")  # no module named: nothing to check
