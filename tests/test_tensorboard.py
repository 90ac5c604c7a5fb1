"""TensorBoard as an optional sink beside the CSVs (``--tensorboard DIR``): the
scalars equal the CSV rows."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from typer.testing import CliRunner

from evodevo.cli import app

pytest.importorskip("tensorboard")
from evodevo.tensorboard import read_scalars  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread")
ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()
TINY_BIARM = """
tasks:
  - {env_id: CartPole-v1, episodes: 3, max_steps: 30}
dqn: {batch_size: 8, learning_starts: 8}
eval: {episodes: 1}
"""


def _invoke(*args: object) -> None:
    res = runner.invoke(app, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output


def _csv(path: Path) -> list[dict[str, str]]:
    with path.open() as fh:
        return list(csv.DictReader(fh))


def test_grn_evolve_scalars_match_history(tmp_path):
    out, tb = tmp_path / "run", tmp_path / "tb"
    _invoke("grn", "evolve", "--config", ROOT / "configs" / "grn_pendulum.yaml", "--population",
            2, "--generations", 2, "--episodes", 1, "--quiet", "--tensorboard", tb, "--out", out)  # fmt: skip
    scalars = read_scalars(tb)
    rows = _csv(out / "history.csv")
    got = scalars["evolution/best_fitness"]
    assert [s for s, _ in got] == [0, 1]
    assert [v for _, v in got] == pytest.approx([float(r["best_fitness"]) for r in rows], rel=1e-6)


@pytest.mark.parametrize("quiet", [True, False])
def test_biarm_train_scalars_match_metrics(tmp_path, quiet):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY_BIARM)
    out, tb = tmp_path / "run", tmp_path / "tb"
    _invoke("biarm", "train", "--config", cfg, *(["--quiet"] if quiet else []),
            "--tensorboard", tb, "--out", out)  # fmt: skip
    got = read_scalars(tb)["task0_CartPole-v1/return"]
    rows = _csv(out / "metrics.csv")
    assert [s for s, _ in got] == [int(r["episode"]) for r in rows]
    assert [v for _, v in got] == pytest.approx([float(r["return"]) for r in rows])


def test_missing_package_is_one_line(monkeypatch):
    import builtins

    from evodevo.errors import EvodevoError
    from evodevo.tensorboard import writer

    real = builtins.__import__

    def fake(name, *a, **k):
        if name == "torch.utils.tensorboard":
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", fake)
    with pytest.raises(EvodevoError, match="pip install"):
        writer("/nonexistent/tb")


def _runs_scalars(tb: Path, run: str) -> dict[str, list[tuple[int, float]]]:
    return read_scalars(tb / run)


def test_biarm_compare_exports_every_finished_run(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY_BIARM)
    out, tb = tmp_path / "grid", tmp_path / "tb"
    args = ["biarm", "compare", "--config", cfg, "--variants", "pnn", "--seeds", "0-1",
            "--workers", 1, "--tensorboard", tb, "--out", out]  # fmt: skip
    _invoke(*args)
    for seed in (0, 1):
        run = f"pnn__s{seed}"
        rows = _csv(out / "runs" / run / "metrics.csv")
        got = _runs_scalars(tb, run)
        assert [s for s, _ in got["task0_CartPole-v1/return"]] == [int(r["episode"]) for r in rows]
        assert [v for _, v in got["task0_CartPole-v1/epsilon"]] == pytest.approx(
            [float(r["epsilon"]) for r in rows]
        )
    events = sorted(tb.rglob("events.out.tfevents.*"))
    _invoke(*args, "--quiet")  # every run finished: nothing trained, nothing written twice
    assert sorted(tb.rglob("events.out.tfevents.*")) == events


FAKE_BASELINE = """\
env: {id: "test_grn_fakeenv:GrnFakeKuka-v0", kwargs: {max_steps: 8}}
budget: {eval_every_steps: 8, eval_episodes: 1, checkpoint_every_steps: 8}
ppo: {n_steps: 8, batch_size: 8, n_epochs: 1}
neat: {population: 2, episodes: 1, elitism: 1, generations: 2}
evaluation: {lockstep: 2}
"""


@pytest.mark.parametrize("method", ["ppo", "neat"])
def test_baselines_kuka_scalars_match_the_csvs(tmp_path, method):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("neat")
    import test_grn_fakeenv  # noqa: F401 - registers the fake Kuka env

    cfg = tmp_path / "fake.yaml"
    cfg.write_text(FAKE_BASELINE)
    out, tb = tmp_path / "run", tmp_path / "tb"
    budget = ["--budget-steps", 16] if method == "ppo" else []
    res = runner.invoke(app, [str(a) for a in ["baselines", "kuka", "--method", method,
                        "--config", cfg, *budget, "--tensorboard", tb, "--out", out]])  # fmt: skip
    assert res.exit_code == 0, (res.output, res.exception)
    unit = "env steps" if method == "ppo" else "generations"
    assert f"{method} {unit}" in res.stderr and "ETA" in res.stderr  # the progress bar
    scalars = read_scalars(tb)
    curve = _csv(out / "learning_curve.csv")
    assert len(curve) == 2  # PPO: at 8 and 16 steps; NEAT: one row per generation
    got = scalars["baseline/success"]
    assert [s for s, _ in got] == [int(r["env_steps"]) for r in curve]
    assert [v for _, v in got] == pytest.approx([float(r["success"]) for r in curve])
    if method == "neat":
        hist = _csv(out / "history.csv")
        best = scalars["neat/best_fitness"]
        assert [s for s, _ in best] == [0, 1]
        assert [v for _, v in best] == pytest.approx([float(r["best_fitness"]) for r in hist])


def test_a_file_as_the_folder_is_one_line(tmp_path):
    from evodevo.errors import EvodevoError
    from evodevo.tensorboard import RunsExporter, writer

    f = tmp_path / "file"
    f.write_text("x")
    for make in (writer, lambda d: RunsExporter(tmp_path / "runs", d)):
        with pytest.raises(EvodevoError, match="--tensorboard .* cannot be created"):
            make(f)
