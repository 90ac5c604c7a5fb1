"""Visual front-ends: camera image → visual features of the GRN (SPEC §2.2, ``sensors.encoder``).

A front-end is a small class with one interface, chosen by name in the config:

* ``"cnn"`` — the thesis encoder (:class:`~evodevo.grn.encoder.Encoder`): a fixed random CNN,
  128 unit-norm features per frame; the genome's evolved projection P maps them to 4 values.
* ``"blob"`` — :class:`BlobLocaliser`, an object-localising front-end that uses only the camera
  image: on the first frame of an episode the difference against the empty tray is split into
  connected blobs, the blob nearest the gripper is the target, and its pixel centroid is mapped
  to table coordinates through the camera's view and projection matrices (a calibrated camera;
  never simulator object poses). On every frame the 4 features are

  ``[dx, dy, size, found]``: the target minus the gripper's position (from proprioception, the
  robot's own pose) in units of one action (0.06 m) clipped to ±:data:`DXY_CLIP`; the blob's area
  in pixels / :data:`SIZE_UNIT` clipped to [0, 2]; and 1 if a target was found, else 0 (then the
  other three are 0).

  The target is held for the rest of the episode: from the second frame on, the arm is in the
  picture and occludes the tray under it, so the first frame is the one view of the scene the
  robot has; the features still change every step because the gripper moves.

  A dark frame (every pixel 0, as the Kuka env's ``dark_after`` gives; a lit camera never shows
  one) carries nothing: its features are all 0 and it is not taken as the first look, so what
  was seen before it must be remembered by the controller, not by the front-end.

Every front-end is *stateful per episode* through :meth:`reset` (the CNN's state is empty):
``state = fe.reset(n)`` for ``n`` episode slots, then ``fe.encode(images, proprio, state, idx)``
once per step for the still-running slots ``idx``. Features are checked finite.

The empty-tray background is the per-pixel median of the first frames of
:data:`BACKGROUND_EPISODES` calibration episodes (training objects, fixed seeds): objects land in
different places each time, so the median is the empty tray — a photograph the robot could take
itself. It is computed once per run and saved with it (``frontend.npz``), like the CNN's
``encoder.pt``.

>>> fe = BlobLocaliser(background=np.zeros((48, 48, 3), np.uint8))
>>> img = np.zeros((1, 48, 48, 3), np.uint8)
>>> fe.encode(img, np.zeros((1, 4)), fe.reset(1), np.arange(1)).tolist()
[[0.0, 0.0, 0.0, 0.0]]
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from evodevo.errors import CheckpointError, ConfigError, EvodevoError
from evodevo.grn.config import FRONTEND_FEATURES, GrnConfig
from evodevo.grn.encoder import Encoder
from evodevo.grn.env_interface import make_env
from evodevo.runs import atomic_write_bytes
from evodevo.seeding import derive

__all__ = [
    "FRONTENDS",
    "FRONTEND_FILE",
    "BlobLocaliser",
    "CameraModel",
    "frontend_dim",
    "make_frontend",
    "load_frontend",
    "check_features",
    "BACKGROUND_EPISODES",
    "DXY_UNIT",
    "DXY_CLIP",
    "SIZE_UNIT",
]

FRONTENDS = tuple(FRONTEND_FEATURES)
"""Names accepted by ``sensors.encoder``."""
FRONTEND_FILE = "frontend.npz"
"""The blob localiser's calibration (background and camera matrices) in a run directory."""

#: Table units of the (dx, dy) features: one action's end-effector displacement (m).
DXY_UNIT = 0.06
#: Bound of the (dx, dy) features, in those units.
DXY_CLIP = 3.0
#: Blob area (pixels) per unit of the size feature.
SIZE_UNIT = 20.0
#: Summed absolute RGB difference (0-765) above which a pixel differs from the empty tray.
DIFF_THRESHOLD = 30
#: Smallest blob (pixels) taken as an object.
MIN_BLOB = 3
#: Height (m, world z) of the plane onto which blob centroids are projected: the objects'
#: centres rest around it in the tray.
OBJECT_PLANE_Z = -0.15
#: Calibration episodes whose first frames' median is the empty tray.
BACKGROUND_EPISODES = 15
#: Seed of the calibration episodes (training objects; never a test seed).
BACKGROUND_SEED = 424_242

# Proprioception (x, y) is (raw − centre) / half range (evodevo.envs.kuka_diverse_object).
_EE_CENTRE = (0.575, 0.025)
_EE_HALF = (0.075, 0.195)


@dataclass(frozen=True)
class CameraModel:
    """The Kuka env's fixed camera (SPEC §3, ``camera_random = 0``), as a calibrated camera.

    The values are those of the env's ``reset``: ``computeViewMatrixFromYawPitchRoll(target,
    distance, yaw, pitch, 0, up_axis=2)`` and ``computeProjectionMatrixFOV(fov, 1, near, far)``;
    a test checks the matrices against the env's own.
    """

    target: tuple[float, float, float] = (0.23, 0.2, 0.54)
    distance: float = 1.0
    yaw: float = 245.0
    pitch: float = -56.0
    fov: float = 20.0
    near: float = 0.01
    far: float = 10.0

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """(view, projection) as row-major 4×4 arrays (OpenGL convention, like PyBullet)."""
        from evodevo.envs.bullet import pybullet as p  # optional dependency: pybullet

        view = (
            np.array(
                p.computeViewMatrixFromYawPitchRoll(
                    list(self.target), self.distance, self.yaw, self.pitch, 0, 2
                )
            )
            .reshape(4, 4)
            .T
        )
        proj = (
            np.array(p.computeProjectionMatrixFOV(self.fov, 1.0, self.near, self.far))
            .reshape(4, 4)
            .T
        )
        return view, proj


def _pixel_rays(inv: np.ndarray, rows: np.ndarray, cols: np.ndarray, h: int, w: int) -> Any:
    xn = 2.0 * (cols + 0.5) / w - 1.0
    yn = 1.0 - 2.0 * (rows + 0.5) / h
    ones = np.ones_like(xn)
    a = inv @ np.stack([xn, yn, -ones, ones])
    b = inv @ np.stack([xn, yn, ones, ones])
    return a[:3] / a[3], b[:3] / b[3]


@dataclass
class BlobState:
    """Per-slot target (table x, y in m), blob size and found flag, and whether it was seen."""

    target: np.ndarray
    size: np.ndarray
    found: np.ndarray
    seen: np.ndarray


@dataclass
class BlobLocaliser:
    """Object-localising front-end from the camera image only (see module docstring).

    Args:
        background: the empty-tray image (H, W, 3) uint8.
        view: the camera's row-major 4×4 view matrix (default: :class:`CameraModel`).
        proj: the camera's row-major 4×4 projection matrix (default: :class:`CameraModel`).
    """

    background: np.ndarray
    view: np.ndarray | None = None
    proj: np.ndarray | None = None
    name: str = "blob"
    dim: int = 4
    _inv: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        bg = np.asarray(self.background)
        if bg.ndim != 3 or bg.shape[2] != 3:
            raise EvodevoError(f"the background must be an (H, W, 3) image, got shape {bg.shape}")
        self.background = bg.astype(np.uint8)
        if self.view is None or self.proj is None:
            self.view, self.proj = CameraModel().matrices()
        self._inv = np.linalg.inv(np.asarray(self.proj) @ np.asarray(self.view))

    # -- geometry ------------------------------------------------------------------------------
    def pixel_to_table(self, row: float, col: float, z: float = OBJECT_PLANE_Z) -> np.ndarray:
        """Table point (x, y) where the ray through pixel centre (row, col) meets height z."""
        h, w = self.background.shape[:2]
        a, b = _pixel_rays(self._inv, np.array([row]), np.array([col]), h, w)
        t = (z - a[2]) / (b[2] - a[2])
        return np.asarray((a + t * (b - a))[:2, 0], dtype=np.float64)

    def table_to_pixel(self, x: float, y: float, z: float = OBJECT_PLANE_Z) -> tuple[float, float]:
        """(row, col) of table point (x, y, z), fractional pixel coordinates (for tests)."""
        h, w = self.background.shape[:2]
        c = np.asarray(self.proj) @ np.asarray(self.view) @ np.array([x, y, z, 1.0])
        xn, yn = c[0] / c[3], c[1] / c[3]
        return (1.0 - yn) * h / 2.0 - 0.5, (xn + 1.0) * w / 2.0 - 0.5

    # -- features ------------------------------------------------------------------------------
    def check_images(self, images: Any) -> np.ndarray:
        """The images as (B, H, W, 3) uint8, or an EvodevoError naming what is wrong."""
        arr = np.asarray(images)
        want = self.background.shape
        if arr.ndim != 4 or tuple(arr.shape[1:]) != tuple(want):
            raise EvodevoError(
                f"the blob front-end reads (batch, {want[0]}, {want[1]}, 3) camera images; got an "
                f"observation of shape {tuple(arr.shape[1:]) if arr.ndim else arr.shape}. Use "
                "sensors.encoder: cnn, or an environment with this camera"
            )
        if arr.dtype != np.uint8:
            raise EvodevoError(f"the blob front-end reads uint8 images, got dtype {arr.dtype}")
        return arr

    def blobs(self, image: np.ndarray) -> list[tuple[float, float, int]]:
        """Blobs of one image: (row centroid, col centroid, area) of each connected region."""
        diff = np.abs(image.astype(np.int16) - self.background.astype(np.int16)).sum(-1)
        labels, n = ndimage.label(diff > DIFF_THRESHOLD)
        out = []
        for k in range(1, n + 1):
            rr, cc = np.nonzero(labels == k)
            if rr.size >= MIN_BLOB:
                out.append((float(rr.mean()), float(cc.mean()), int(rr.size)))
        return out

    def locate(self, image: np.ndarray, ee_xy: np.ndarray) -> tuple[np.ndarray, int] | None:
        """Table (x, y) and area of the blob nearest the gripper at ``ee_xy``; None if none."""
        best: tuple[float, np.ndarray, int] | None = None
        for r, c, area in self.blobs(image):
            pt = self.pixel_to_table(r, c)
            d = float(np.hypot(*(pt - ee_xy)))
            if best is None or d < best[0]:
                best = (d, pt, area)
        return None if best is None else (best[1], best[2])

    def seen_target(self, state: BlobState, slot: int) -> np.ndarray:
        """The table (x, y) (m) localised on slot ``slot``'s first frame; NaN if none was found
        (the shaped training fitness' ``evaluation.distance_to: target``)."""
        if not state.found[slot]:
            return np.full(2, np.nan)
        return np.array(state.target[slot], dtype=np.float64)

    def reset(self, n: int) -> BlobState:
        """State for ``n`` episode slots (nothing seen yet)."""
        return BlobState(np.zeros((n, 2)), np.zeros(n), np.zeros(n, bool), np.zeros(n, bool))

    def encode(
        self, images: Any, proprio: np.ndarray, state: BlobState, idx: np.ndarray
    ) -> np.ndarray:
        """Features (len(idx), 4) = [dx, dy, size, found] for slots ``idx`` (module docstring);
        all 0 on a dark frame."""
        imgs = self.check_images(images)
        ee = _gripper_xy(proprio)
        dark = np.asarray(imgs.reshape(len(imgs), -1).max(axis=1) == 0)
        for j, slot in enumerate(np.asarray(idx).tolist()):
            if not dark[j] and not state.seen[slot]:
                state.seen[slot] = True
                hit = self.locate(imgs[j], ee[j])
                if hit is not None:
                    state.target[slot], state.size[slot], state.found[slot] = hit[0], hit[1], True
        out = self.held(proprio, state, idx)
        out[dark] = 0.0
        return check_features(out, self.name)

    def held(self, proprio: np.ndarray, state: BlobState, idx: np.ndarray) -> np.ndarray:
        """The features of the target held in ``state`` for slots ``idx``, dark frame or not:
        what :meth:`encode` gives on a lit frame once the target is localised (zeros for a slot
        without one). A controller that remembers what it saw reads this."""
        ee = _gripper_xy(proprio)
        out = np.zeros((len(idx), 4))
        for j, slot in enumerate(np.asarray(idx).tolist()):
            if state.found[slot]:
                d = np.clip((state.target[slot] - ee[j]) / DXY_UNIT, -DXY_CLIP, DXY_CLIP)
                out[j] = [d[0], d[1], min(state.size[slot] / SIZE_UNIT, 2.0), 1.0]
        return out

    # -- persistence ---------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the calibration (background, view, projection) to one ``.npz``."""
        buf = io.BytesIO()
        np.savez(
            buf,
            background=self.background,
            view=np.asarray(self.view),
            proj=np.asarray(self.proj),
        )
        atomic_write_bytes(path, buf.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> BlobLocaliser:
        """Load a calibration written by :meth:`save`."""
        p = Path(path)
        if not p.is_file():
            raise CheckpointError(
                f"{str(p)!r} does not exist; a run with sensors.encoder: blob saves its "
                f"{FRONTEND_FILE}"
            )
        try:
            with np.load(p, allow_pickle=False) as data:
                return cls(data["background"], data["view"], data["proj"])
        except (OSError, ValueError, KeyError) as exc:
            raise CheckpointError(
                f"{str(p)!r} is not a blob front-end calibration ({exc})"
            ) from None

    @classmethod
    def calibrate(
        cls,
        env_id: str = "evodevo/KukaDiverseObject-v0",
        env_kwargs: dict[str, Any] | None = None,
        episodes: int = BACKGROUND_EPISODES,
    ) -> BlobLocaliser:
        """Photograph the empty tray: the per-pixel median of ``episodes`` first frames."""

        env = make_env(env_id, env_kwargs)
        try:
            frames = [env.reset(seed=derive(BACKGROUND_SEED, i))[0] for i in range(episodes)]
        finally:
            env.close()
        bg = np.median(np.stack(frames), axis=0).round().astype(np.uint8)
        return cls(bg)


def _gripper_xy(proprio: np.ndarray) -> np.ndarray:
    """The gripper's table (x, y) (m) from the normalised proprioception (the robot's pose)."""
    prop = np.asarray(proprio, dtype=np.float64)
    return np.stack(
        [_EE_CENTRE[0] + prop[:, 0] * _EE_HALF[0], _EE_CENTRE[1] + prop[:, 1] * _EE_HALF[1]],
        axis=1,
    )


def check_features(features: np.ndarray, name: str) -> np.ndarray:
    """Return ``features`` or raise an EvodevoError if any is NaN or infinite."""
    if not np.all(np.isfinite(features)):
        bad = np.argwhere(~np.isfinite(features))[0].tolist()
        raise EvodevoError(
            f"the {name!r} front-end produced a non-finite feature at {bad}; check the camera "
            "image and the front-end's calibration"
        )
    return features


def frontend_dim(name: str) -> int:
    """Features per frame of front-end ``name`` (what P projects to ``n_visual``)."""
    if name not in FRONTEND_FEATURES:
        raise ConfigError(f"sensors.encoder={name!r} is not a front-end; choose one of {FRONTENDS}")
    return FRONTEND_FEATURES[name]


def make_frontend(config: GrnConfig, seed: int | None = None) -> Any:
    """A new front-end for ``config.sensors.encoder`` (the CNN is drawn from ``seed``)."""

    name = config.sensors.encoder
    frontend_dim(name)
    if name == "cnn":
        return Encoder.from_seed(config.seed if seed is None else seed)
    return BlobLocaliser.calibrate(config.env.id, dict(config.env.kwargs))


def save_frontend(frontend: Any, run: Any) -> None:
    """Save a front-end into run directory ``run`` (``encoder.pt`` or ``frontend.npz``)."""
    if isinstance(frontend, BlobLocaliser):
        frontend.save(Path(run) / FRONTEND_FILE)
    else:
        frontend.save(Path(run) / "encoder.pt")


def load_frontend(config: GrnConfig, run: Any) -> Any:
    """The front-end saved in run directory ``run`` for ``config.sensors.encoder``."""

    name = config.sensors.encoder
    frontend_dim(name)
    if name == "cnn":
        return Encoder.load(Path(run) / "encoder.pt")
    return BlobLocaliser.load(Path(run) / FRONTEND_FILE)


def frontend_name(frontend: Any) -> str:
    """``"blob"`` or ``"cnn"`` for a front-end object."""
    return str(getattr(frontend, "name", "cnn"))


def encode(
    frontend: Any, images: np.ndarray, proprio: np.ndarray, state: Any, idx: Any
) -> np.ndarray:
    """One step of any front-end (the CNN is stateless: its ``features``)."""
    if hasattr(frontend, "encode"):
        return np.asarray(frontend.encode(images, proprio, state, np.asarray(idx)))
    return check_features(frontend.features(images), "cnn")


__all__ += ["save_frontend", "frontend_name", "encode", "BlobState"]
