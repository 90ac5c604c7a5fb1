"""Issue 23 item 4: TensorBoard as an optional sink beside the CSVs (``--tensorboard DIR``): the
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
