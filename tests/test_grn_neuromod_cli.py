"""`evodevo grn evolve --controller neuromodulated` on Kuka (tiny), and the modulator tools.

The Kuka smoke runs 2 genomes x 1 episode x 1 generation (about 2 s of env time). The modulator
ablations, the trace and its figure run on the fake env.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_grn_fakeenv import FAKE_ID
from typer.testing import CliRunner

from evodevo.callbacks import Callback
from evodevo.cli import app
from evodevo.config import replace
from evodevo.errors import EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.evolution import evolve_run
from evodevo.grn.figures import plot_run
from evodevo.grn.genome import load_arrays
from evodevo.grn.neuromodulated import (
    MODULATOR_ABLATIONS,
    MODULATOR_TRACE_FILE,
    NeuromodGrnGenome,
    record_modulator_trace,
    run_modulator_ablations,
)

runner = CliRunner()


def invoke(*args: object):
    res = runner.invoke(app, ["grn", *map(str, args)])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output
    return res


def test_cli_neuromodulated_on_the_real_kuka_env(tmp_path):
    pytest.importorskip("pybullet")
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text("evolution:\n  early_stop: false\nevaluation:\n  lockstep: 2\n")
    out = tmp_path / "run"
    invoke(
        "evolve", "--controller", "neuromodulated", "--population", 2, "--generations", 1,
        "--episodes", 1, "--config", cfg, "--out", out, "--quiet",
    )  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    assert summary["controller"] == "neuromodulated" and summary["episodes_run"] == 2
    arrays, header = load_arrays(out / "best_genome.npz", NeuromodGrnGenome.KIND)
    assert set(arrays) == set(NeuromodGrnGenome.names())
    assert header["config"]["controller"] == "neuromodulated"


@pytest.fixture
def fake_neuromod_run(tmp_path):
    cfg = tmp_path / "fake.yaml"
    cfg.write_text(
        f"controller: neuromodulated\nenv:\n  id: '{FAKE_ID}'\n  kwargs: {{}}\n"
        "evolution:\n  early_stop: false\n"
    )
    out = tmp_path / "run"
    invoke(
        "evolve", "--config", cfg, "--population", 3, "--generations", 2, "--episodes", 2,
        "--out", out, "--quiet",
    )  # fmt: skip
    return out


def test_modulator_ablations_trace_and_figure(fake_neuromod_run):
    run = fake_neuromod_run
    res = invoke("evaluate", run, "--test-episodes", 4, "--noise", 0.03, "--no-baselines", "--json")
    assert json.loads(res.output.strip().splitlines()[-1])["controller"] == "neuromodulated"
    res = invoke("ablate", run, "--modulators", "--test-episodes", 6)
    assert "no_ACh" in res.output and "Modulator ablations" in res.output
    rows = json.loads((run / "modulator_ablations.json").read_text())["rows"]
    assert [r["ablation"] for r in rows] == ["intact", *MODULATOR_ABLATIONS]
    assert rows[0]["change"] == 0.0 and all(r["episodes"] == 6 for r in rows)
    assert len(rows[0]["gamma"]) == 4
    assert (run / "modulator_ablations.md").read_text().startswith("Modulator ablations")
    res = invoke("plot", run)
    names = {p.rsplit("/", 1)[-1] for p in res.output.split()}
    assert {"modulator_trace.png", "expression_trace.png", "regulatory_heatmap.png"} <= names
    arrays, meta = load_arrays(run / MODULATOR_TRACE_FILE, "grn_modulator_trace")
    assert arrays["m"].shape == (7, 4) and arrays["x"].shape == (7, 50)
    assert np.all((arrays["m"] > 0) & (arrays["m"] < 1))
    assert meta["modulators"] == ["DA", "5HT", "NE", "ACh"]
    assert record_modulator_trace(run, index=1) == run / MODULATOR_TRACE_FILE
    assert "modulator_trace.png" in {p.name for p in plot_run(run)}
    with pytest.raises(EvodevoError, match="neuromodulated run"):
        run_modulator_ablations(plain_run(run.parent), episodes=1)


def plain_run(tmp_path):
    cfg = tmp_path / "fake_plain.yaml"
    cfg.write_text(f"env:\n  id: '{FAKE_ID}'\n  kwargs: {{}}\n")
    out = tmp_path / "plain"
    invoke("evolve", "--config", cfg, "--population", 2, "--generations", 1, "--episodes", 1,
           "--out", out, "--quiet")  # fmt: skip
    return out


class _Interrupt(Exception):
    pass


class _StopAfterFirst(Callback):
    def on_generation(self, record):
        raise _Interrupt


def test_interrupted_neuromodulated_run_resumes_exactly(tmp_path):
    cfg = GrnConfig(controller="neuromodulated")
    cfg = replace(
        cfg,
        env=replace(cfg.env, id=FAKE_ID, kwargs={}),
        evolution=replace(cfg.evolution, population=4, generations=3, early_stop=False),
        evaluation=replace(cfg.evaluation, episodes=2),
    )
    whole = evolve_run(cfg, tmp_path / "whole", progress=False)
    with pytest.raises(_Interrupt):
        evolve_run(cfg, tmp_path / "cut", callbacks=[_StopAfterFirst()], progress=False)
    resumed = evolve_run(cfg, tmp_path / "cut", resume=True, progress=False)
    assert resumed["fitness_history"] == whole["fitness_history"]
    a, _ = load_arrays(tmp_path / "whole" / "best_genome.npz", NeuromodGrnGenome.KIND)
    b, _ = load_arrays(tmp_path / "cut" / "best_genome.npz", NeuromodGrnGenome.KIND)
    assert all(np.array_equal(a[k], b[k]) for k in a)
