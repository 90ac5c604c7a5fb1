"""The report's side-by-side table of BIARM grids under two DQN protocols (SPEC §1.6-1.7)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

from evodevo.reproduce.biarm_protocols import grids, protocol_table


def _run(root: Path, variant: str, seed: int, finals: dict[str, float]) -> None:
    folder = root / "runs" / f"{variant}__s{seed}"
    folder.mkdir(parents=True)
    tasks = [{"env_id": env, "final_return": r} for env, r in finals.items()]
    summary = {"variant": variant, "seed": seed, "tasks": tasks}
    (folder / "summary.json").write_text(json.dumps(summary))


def test_two_protocols_side_by_side_with_paired_differences(tmp_path):
    cfg = SimpleNamespace(
        biarm=SimpleNamespace(protocol="v1", other_protocols={"biarm_default": "default"})
    )
    assert grids(cfg) == [("biarm", "v1"), ("biarm_default", "default")]
    for seed, (p, b) in enumerate([(100.0, 120.0), (110.0, 150.0), (90.0, 80.0)]):
        _run(tmp_path / "biarm", "pnn", seed, {"CartPole-v1": p})
        _run(tmp_path / "biarm", "biarm", seed, {"CartPole-v1": b})
        _run(tmp_path / "biarm_default", "pnn", seed, {"CartPole-v1": 500.0})
    _run(tmp_path / "biarm_default", "biarm", 0, {"CartPole-v1": 500.0})
    lines = protocol_table(tmp_path, cfg)
    rows = [r for r in lines if r.startswith("| CartPole-v1")]
    assert rows[0].startswith("| CartPole-v1 | thesis (Table 3.2) | 491.0 | 500.0 | +9.0 |")
    # v1: BIARM - PNN = +20, +40, -10 -> mean +16.7, higher on 2 of 3 seeds
    assert "`v1` (biarm/)" in rows[1] and "+16.7 (p = " in rows[1]
    assert "higher on 2/3 seeds" in rows[1]
    # default: one shared seed only -> no paired test
    assert "`default` (biarm_default/)" in rows[2] and rows[2].endswith("| – |")
    assert "500.0 [500.0, 500.0] (n=3)" in rows[2]


def test_one_grid_gives_no_table(tmp_path):
    cfg = SimpleNamespace(biarm=SimpleNamespace(protocol="default", other_protocols={}))
    _run(tmp_path / "biarm", "pnn", 0, {"CartPole-v1": 1.0})
    assert protocol_table(tmp_path, cfg) == []
