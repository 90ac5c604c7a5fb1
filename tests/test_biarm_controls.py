"""The controls of the neuromodulation experiments (SPEC §1.5, §6): ``clamped`` holds every
module at rest, so its learning rate and context gate never move; ``lr-only`` and
``gates-only`` hold one of the two paths at rest."""

from __future__ import annotations

import csv

from evodevo.config import load_config
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.trainer import train


def _tiny(**over: object) -> BiarmConfig:
    data = {
        "tasks": [
            {"env_id": "CartPole-v1", "episodes": 3, "max_steps": 60},
            {"env_id": "Acrobot-v1", "episodes": 2, "max_steps": 60},
        ],
        "checkpoint_every": 0,
        "dqn": {"batch_size": 8, "learning_starts": 8},
        "eval": {"episodes": 1, "validation_episodes": 1, "validation_every": 1},
        **over,
    }
    return load_config(BiarmConfig, None, data)


def test_clamped_keeps_every_state_learning_rate_and_gate_at_rest(tmp_path):
    # the context weights w_m fixed, so that the gate can move only through the states
    cfg = _tiny(
        modules={"sample_interval": 5, "lr_relative": False, "learn_context_weights": False}
    )
    summary = train(cfg, "clamped", 0, tmp_path / "clamped")
    assert summary["final_states"] == [0.5, 0.5, 0.5, 0.5]
    rows = list(csv.DictReader((tmp_path / "clamped" / "neuromod.csv").open()))
    assert rows, "neuromod.csv has no samples"
    assert {r["lr"] for r in rows} == {"0.0005"}  # Eq. 3.7 as written at rest: eta_base / 2
    assert len({r["gate"] for r in rows if r["gate"]}) == 1
    moving = train(cfg, "biarm", 0, tmp_path / "biarm")["final_states"]
    assert moving != [0.5, 0.5, 0.5, 0.5]


def test_lr_only_and_gates_only_hold_the_other_path_at_rest(tmp_path):
    """E2's follow-up arms: the modules run in both; one path reads them, the other rest."""
    cfg = _tiny(
        modules={"sample_interval": 5, "lr_relative": False, "learn_context_weights": False}
    )
    runs = {}
    for v in ("lr-only", "gates-only", "biarm"):
        summary = train(cfg, v, 0, tmp_path / v)
        assert summary["final_states"] != [0.5, 0.5, 0.5, 0.5], v  # the modules run
        runs[v] = list(csv.DictReader((tmp_path / v / "neuromod.csv").open()))
    lr_only, gates_only, biarm = runs["lr-only"], runs["gates-only"], runs["biarm"]
    assert len({r["gate"] for r in lr_only if r["gate"]}) == 1  # the gate at rest
    assert len({r["lr"] for r in lr_only}) > 1  # Eq. 3.7 on the live states
    assert {r["lr"] for r in gates_only} == {"0.0005"}  # Eq. 3.7 at rest
    assert len({r["gate"] for r in gates_only if r["gate"]}) > 1  # the gate moves
    assert len({r["lr"] for r in biarm}) > 1 and len({r["gate"] for r in biarm if r["gate"]}) > 1
