"""The GRN genome G = {W_s, W_r, W_m, theta, delta, alpha, P} (SPEC §2.3, Eq. 4.5).

A genome is a dataclass of NumPy arrays. :func:`init_genome` draws one with the SPEC §2.3
distributions; :meth:`GrnGenome.save` writes a single ``.npz`` holding the arrays and a JSON
header (format version, kind, the config it was made with), and :meth:`GrnGenome.load` reads it
back bit-identical or raises :class:`~evodevo.errors.CheckpointError` saying what is wrong.
:func:`stack_genomes` turns a list of genomes into batched arrays (leading batch axis) for the
vectorised dynamics of :mod:`evodevo.grn.dynamics`.

>>> import numpy as np
>>> from evodevo.grn.config import GrnConfig
>>> g = init_genome(GrnConfig(), n_actions=3, rng=np.random.default_rng(0))
>>> g.W_s.shape, g.W_r.shape, g.W_m.shape, g.P.shape
((8, 50), (50, 50), (50, 3), (128, 4))
"""

from __future__ import annotations

import io
import json
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.runs import atomic_write_bytes

__all__ = [
    "FORMAT_VERSION",
    "GrnGenome",
    "init_genome",
    "stack_genomes",
    "save_arrays",
    "load_arrays",
    "genome_frontend",
    "check_frontend",
]

FORMAT_VERSION = 1
_META_KEY = "__meta__"


def save_arrays(
    path: str | Path, kind: str, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any]
) -> None:
    """Atomically write ``arrays`` and a JSON header (kind, version, ``meta``) to one ``.npz``."""
    header = {"kind": kind, "format_version": FORMAT_VERSION, **meta}
    buf = io.BytesIO()
    payload = {k: np.asarray(v) for k, v in arrays.items()}
    payload[_META_KEY] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez(buf, **payload)  # type: ignore[arg-type]
    atomic_write_bytes(path, buf.getvalue())


def load_arrays(
    path: str | Path, kind: str | None = None
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read a file written by :func:`save_arrays`; check its version (and ``kind`` if given)."""
    p = Path(path)
    if not p.is_file():
        raise CheckpointError(f"genome file {str(p)!r} does not exist; check the run directory")
    with p.open("rb") as fh:
        magic = fh.read(4)
    if magic != b"PK\x03\x04":  # every .npz is a zip archive; say so instead of NumPy's advice
        what = "is empty" if not magic else "is not an .npz archive"
        raise CheckpointError(
            f"{str(p)!r} {what}, so it is not a file written by evodevo; check the path"
        )
    try:
        with np.load(p, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        raise CheckpointError(
            f"{str(p)!r} is truncated or corrupt ({type(exc).__name__}: {exc}); "
            "restore it or re-run the step that wrote it"
        ) from None
    if _META_KEY not in arrays:
        raise CheckpointError(f"{str(p)!r} has no evodevo header; it was not written by evodevo")
    header = json.loads(arrays.pop(_META_KEY).tobytes().decode())
    version = header.get("format_version")
    if version != FORMAT_VERSION:
        raise CheckpointError(
            f"{str(p)!r} has format version {version!r}; this evodevo reads version "
            f"{FORMAT_VERSION}. Re-run evolution with this version"
        )
    if kind is not None and header.get("kind") != kind:
        raise CheckpointError(
            f"{str(p)!r} holds a {header.get('kind')!r} genome, not a {kind!r} genome"
        )
    return arrays, header


@dataclass
class GrnGenome:
    """One GRN genome (or a batch of them, with a leading batch axis on every array).

    Attributes:
        W_s: sensor-to-gene weights, (n_sensors, n).
        W_r: gene-to-gene regulatory weights, (n, n); zero entries are absent connections.
        W_m: gene-to-motor weights, (n, n_actions).
        theta: Hill thresholds, (n,).
        delta: decay rates, (n,).
        alpha: interaction strengths of the source genes, (n,).
        P: visual projection of the 128 encoder features, (128, n_visual).
    """

    W_s: np.ndarray
    W_r: np.ndarray
    W_m: np.ndarray
    theta: np.ndarray
    delta: np.ndarray
    alpha: np.ndarray
    P: np.ndarray

    KIND = "grn"

    @classmethod
    def names(cls) -> list[str]:
        """Names of the arrays, in Eq. 4.5 order (plus P)."""
        return [f.name for f in fields(cls)]

    @property
    def n_genes(self) -> int:
        return int(self.theta.shape[-1])

    @property
    def n_actions(self) -> int:
        return int(self.W_m.shape[-1])

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays by name."""
        return {name: getattr(self, name) for name in self.names()}

    def copy(self) -> GrnGenome:
        """A deep copy."""
        return GrnGenome(**{k: v.copy() for k, v in self.arrays().items()})

    def connections(self) -> int:
        """Number of present (non-zero) regulatory connections."""
        return int(np.count_nonzero(self.W_r))

    def check(
        self,
        n_sensors: int | None = None,
        n_actions: int | None = None,
        n_visual: int | None = None,
        where: str = "genome",
        feature_dim: int | None = None,
    ) -> None:
        """Raise CheckpointError if the shapes are inconsistent or differ from the given sizes."""
        n = self.theta.shape[-1] if self.theta.ndim == 1 else -1
        expect = {
            "W_s": (n_sensors if n_sensors is not None else self.W_s.shape[0], n),
            "W_r": (n, n),
            "W_m": (n, n_actions if n_actions is not None else self.W_m.shape[-1]),
            "theta": (n,),
            "delta": (n,),
            "alpha": (n,),
            "P": (
                feature_dim if feature_dim is not None else self.P.shape[-2],
                n_visual if n_visual is not None else self.P.shape[-1],
            ),
        }
        for name, shape in expect.items():
            arr = getattr(self, name)
            if tuple(arr.shape) != shape or n < 1:
                raise CheckpointError(
                    f"{where}: {name} has shape {tuple(arr.shape)}, expected {shape}; "
                    "the genome does not match this controller (genes, sensors or actions)"
                )
            if not np.all(np.isfinite(arr)):
                raise CheckpointError(f"{where}: {name} holds non-finite values")

    def save(self, path: str | Path, config: Mapping[str, Any] | None = None) -> None:
        """Write this genome to one ``.npz`` with a JSON header holding ``config``."""
        save_arrays(path, self.KIND, self.arrays(), {"config": dict(config or {})})

    @classmethod
    def load(
        cls,
        path: str | Path,
        n_sensors: int | None = None,
        n_actions: int | None = None,
        n_visual: int | None = None,
        frontend: str | None = None,
        feature_dim: int | None = None,
    ) -> GrnGenome:
        """Load a genome saved by :meth:`save`; shapes are checked (against the sizes if given).

        With ``frontend``, the visual front-end the genome was evolved with (``sensors.encoder``
        of its saved config; ``cnn`` for genomes older than the choice) must be that one
        (SPEC §2.2: a genome records its front-end and refuses to run with another).
        """
        arrays, header = load_arrays(path, cls.KIND)
        if frontend is not None:
            check_frontend(header, frontend, path)
        missing = [n for n in cls.names() if n not in arrays]
        if missing:
            raise CheckpointError(f"{str(path)!r} lacks the genome arrays {missing}")
        g = cls(**{n: arrays[n] for n in cls.names()})
        g.check(n_sensors, n_actions, n_visual, where=str(path), feature_dim=feature_dim)
        return g


def genome_frontend(header: Mapping[str, Any]) -> str:
    """The front-end recorded in a genome file's header (``cnn`` when none is recorded)."""
    cfg = header.get("config") or {}
    return str((cfg.get("sensors") or {}).get("encoder", "cnn"))


def check_frontend(header: Mapping[str, Any], frontend: str, path: str | Path) -> None:
    """Raise CheckpointError if the genome of ``path`` was evolved with another front-end."""
    saved = genome_frontend(header)
    if saved != frontend:
        raise CheckpointError(
            f"{str(path)!r} was evolved with the visual front-end {saved!r} and cannot run with "
            f"{frontend!r}; evaluate it with sensors.encoder: {saved}"
        )


def init_genome(config: GrnConfig, n_actions: int, rng: np.random.Generator) -> GrnGenome:
    """Draw a genome with the SPEC §2.3 initialisation.

    With ``genome.regulation: false`` W_r is zeros; every other array is drawn as with
    regulation, from the same generator in the same order (so the arms share them).

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig`.
        n_actions: action dimensions A (3 for the Kuka env with its height hack).
        rng: the evolution's generator.
    """
    gi = config.genome
    n = config.dynamics.n_genes
    n_s = config.sensors.n_visual + config.sensors.n_proprio
    W_s = rng.normal(0.0, gi.ws_std, (n_s, n))
    mask = rng.random((n, n)) < gi.wr_density
    W_r = np.where(mask, rng.normal(0.0, gi.wr_std, (n, n)), 0.0)
    if not gi.regulation:  # the no-regulation arm: the same draws, W_r = 0
        W_r = np.zeros((n, n))
    W_m = rng.normal(0.0, gi.wm_std, (n, n_actions))
    theta = rng.uniform(gi.theta_init[0], gi.theta_init[1], n)
    delta = rng.uniform(gi.delta_init[0], gi.delta_init[1], n)
    alpha = rng.uniform(gi.alpha_init[0], gi.alpha_init[1], n)
    if gi.p_init == "identity":
        P = np.eye(config.sensors.feature_dim, config.sensors.n_visual)
    else:
        P = rng.normal(0.0, gi.p_std, (config.sensors.feature_dim, config.sensors.n_visual))
    return GrnGenome(W_s, W_r, W_m, theta, delta, alpha, P)


def stack_genomes(genomes: Sequence[GrnGenome]) -> GrnGenome:
    """Stack same-shaped genomes into one batched :class:`GrnGenome` (leading batch axis)."""
    if not genomes:
        raise ValueError("stack_genomes needs at least one genome")
    return GrnGenome(**{n: np.stack([getattr(g, n) for g in genomes]) for n in GrnGenome.names()})
