"""the BIARM comparison grid on Ray gives the local numbers; finished runs are skipped
and partly finished ones resume from their checkpoint."""

from __future__ import annotations

import shutil

import pytest
from test_biarm_resume import Killed, _kill_at, strip_timing, tiny

from evodevo.callbacks import FunctionCallback
from evodevo.errors import EvodevoError
from evodevo.neuromod import train
from evodevo.neuromod.compare import run_dir_name, run_grid
from evodevo.runs import RunDir

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _summaries(root, variants, seeds):
    return {
        (v, s): strip_timing(RunDir(root / "runs" / run_dir_name(v, s)).read_summary())
        for v in variants
        for s in seeds
    }


def test_grid_on_ray_equals_local_and_resumes_partial_runs(tmp_path):
    pytest.importorskip("ray")
    cfg = tiny()
    variants, seeds = ["biarm", "pnn"], [0, 1]
    local = tmp_path / "local"
    assert len(run_grid(cfg, variants, seeds, local, workers=1)) == 4
    ray_root = tmp_path / "ray"
    # pnn seed 0 already finished; biarm seed 0 killed in the middle of its second task
    shutil.copytree(local / "runs" / "pnn__s0", ray_root / "runs" / "pnn__s0")
    cut = ray_root / "runs" / "biarm__s0"
    with pytest.raises(Killed):
        train(cfg, "biarm", 0, cut, callback=FunctionCallback(on_episode=_kill_at(1, 3)))
    assert (cut / "checkpoints" / "task1_ep2.safetensors").is_file()
    done = run_grid(cfg, variants, seeds, ray_root, workers=2, backend="ray")
    assert sorted(done) == sorted(
        str(ray_root / "runs" / n) for n in ("biarm__s0", "biarm__s1", "pnn__s1")
    )
    assert _summaries(local, variants, seeds) == _summaries(ray_root, variants, seeds)
    assert RunDir(cut).read_csv("metrics.csv") == RunDir(local / "runs" / "biarm__s0").read_csv(
        "metrics.csv"
    )
    import ray

    assert not ray.is_initialized()  # the pool shut down the Ray instance it started


def test_address_needs_the_ray_backend(tmp_path):
    with pytest.raises(EvodevoError, match="--address only goes with --backend ray"):
        run_grid(tiny(), ["pnn"], [0], tmp_path, address="auto")


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--backend", "spark"], "--backend 'spark' is not known"),
        (["--address", "auto"], "--address only goes with --backend ray"),
        (["--workers", "0"], "--workers 0 must be at least 1"),
    ],
)
def test_compare_cli_rejects_bad_backend_options(tmp_path, extra, match):
    from typer.testing import CliRunner

    from evodevo.cli.biarm import app

    res = CliRunner().invoke(
        app, ["compare", "--variants", "pnn", "--seeds", "0", "--out", str(tmp_path), *extra]
    )
    assert isinstance(res.exception, EvodevoError) and match in str(res.exception)
    assert not (tmp_path / "runs").exists()  # nothing started
