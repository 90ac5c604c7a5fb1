"""`grn video` and `biarm video` write GIFs at the asked frame rate, with the step,
action and outcome drawn on the frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.errors import EvodevoError
from evodevo.video import annotate, frame_durations, save_frames

pytestmark = pytest.mark.usefixtures("one_torch_thread")
pytest.importorskip("pygame")  # classic-control rendering

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()
TINY_BIARM = """
tasks:
  - {env_id: CartPole-v1, episodes: 2, max_steps: 30}
dqn: {batch_size: 8, learning_starts: 8}
eval: {episodes: 1}
"""


def _cli(*args: object) -> str:
    res = runner.invoke(app, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output
    return res.output


def _frames(gif: Path) -> list[np.ndarray]:
    with Image.open(gif) as im:
        return [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]


@pytest.mark.parametrize("fps, ms", [(2.0, 500), (25.0, 40)])
def test_gif_frame_durations_are_what_was_asked(tmp_path, fps, ms):
    frames = [np.full((48, 48, 3), 40 * i, np.uint8) for i in range(4)]
    gif = save_frames(frames, tmp_path / "x.gif", fps)
    assert frame_durations(gif) == [ms] * 4
    with pytest.raises(EvodevoError, match=".gif or an .mp4"):
        save_frames(frames, tmp_path / "x.avi", fps)


def test_annotation_draws_text_below_an_enlarged_frame():
    frame = np.zeros((48, 48, 3), np.uint8)
    out = annotate(frame, ["step 3", "action [+0.10]"])
    assert out.shape[1] >= 240 and out.shape[0] > out.shape[1]
    assert out[: out.shape[1]].max() == 0 and out[out.shape[1] :].max() > 0  # text in the band


def test_grn_video(tmp_path):
    run = tmp_path / "run"
    _cli("grn", "evolve", "--config", ROOT / "configs" / "grn_pendulum.yaml", "--population", 2,
         "--generations", 1, "--episodes", 1, "--quiet", "--out", run)  # fmt: skip
    gif = tmp_path / "ep.gif"
    text = _cli("grn", "video", run, "--objects", "train", "--out", gif, "--fps", 10,
                "--max-steps", 6)  # fmt: skip
    assert "7 frames at 10 fps" in text
    assert frame_durations(gif) == [100] * 7  # reset + 6 steps
    first, last = _frames(gif)[0], _frames(gif)[-1]
    assert not np.array_equal(first, last)  # the caption (step, action) changes


def test_biarm_video(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY_BIARM)
    run = tmp_path / "run"
    _cli("biarm", "train", "--config", cfg, "--quiet", "--out", run)
    gif = tmp_path / "col.gif"
    text = _cli("biarm", "video", run, "--task", "CartPole-v1", "--out", gif, "--fps", 20,
                "--max-steps", 5)  # fmt: skip
    assert "6 frames at 20 fps" in text
    assert frame_durations(gif) == [50] * 6
    with pytest.raises(EvodevoError, match="not in this run's tasks"):
        _cli("biarm", "video", run, "--task", "Acrobot-v1", "--out", gif)
