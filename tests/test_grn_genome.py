"""Genome (SPEC §2.3): initialisation, single-file save/load, clear errors, stacking."""

from __future__ import annotations

import json

import numpy as np
import pytest

from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.grn.genome import GrnGenome, init_genome, load_arrays, save_arrays, stack_genomes


@pytest.fixture
def genome() -> GrnGenome:
    return init_genome(GrnConfig(), 3, np.random.default_rng(0))


def test_init_shapes_bounds_and_sparsity(genome):
    assert genome.W_s.shape == (8, 50) and genome.W_r.shape == (50, 50)
    assert genome.W_m.shape == (50, 3) and genome.P.shape == (128, 4)
    density = np.count_nonzero(genome.W_r) / genome.W_r.size
    assert 0.15 < density < 0.25  # kept with p = 0.2 out of 2500 entries
    assert genome.theta.min() >= 0.2 and genome.theta.max() <= 0.8
    assert genome.delta.min() >= 0.1 and genome.delta.max() <= 0.9
    assert genome.alpha.min() >= 0.5 and genome.alpha.max() <= 2.0
    assert abs(genome.W_s.std() - 0.3) < 0.05 and abs(genome.P.std() - 1.0) < 0.1


def test_save_load_bit_identical(genome, tmp_path):
    path = tmp_path / "g.npz"
    genome.save(path, {"seed": 7})
    loaded = GrnGenome.load(path, n_sensors=8, n_actions=3, n_visual=4)
    for name, arr in genome.arrays().items():
        got = getattr(loaded, name)
        assert got.dtype == arr.dtype and got.tobytes() == arr.tobytes(), name
    _, header = load_arrays(path)
    assert header["kind"] == "grn" and header["config"] == {"seed": 7}


def test_wrong_shape_is_a_clear_error(genome, tmp_path):
    path = tmp_path / "g.npz"
    genome.save(path)
    with pytest.raises(CheckpointError, match=r"W_m has shape \(50, 3\), expected \(50, 4\)"):
        GrnGenome.load(path, n_actions=4)
    bad = genome.arrays()
    bad["W_r"] = np.zeros((50, 49))
    save_arrays(tmp_path / "bad.npz", "grn", bad, {})
    with pytest.raises(CheckpointError, match="W_r has shape"):
        GrnGenome.load(tmp_path / "bad.npz")


def test_wrong_version_missing_keys_and_kind(genome, tmp_path):
    arrays = genome.arrays()
    header = {"kind": "grn", "format_version": 99}
    np.savez(
        tmp_path / "v.npz",
        **arrays,
        __meta__=np.frombuffer(json.dumps(header).encode(), np.uint8),
    )
    with pytest.raises(CheckpointError, match="format version 99"):
        GrnGenome.load(tmp_path / "v.npz")
    partial = dict(arrays)
    del partial["theta"]
    save_arrays(tmp_path / "m.npz", "grn", partial, {})
    with pytest.raises(CheckpointError, match="lacks the genome arrays"):
        GrnGenome.load(tmp_path / "m.npz")
    save_arrays(tmp_path / "k.npz", "open_loop", {"actions": np.zeros((8, 3))}, {})
    with pytest.raises(CheckpointError, match="not a 'grn' genome"):
        GrnGenome.load(tmp_path / "k.npz")
    with pytest.raises(CheckpointError, match="does not exist"):
        GrnGenome.load(tmp_path / "nope.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(CheckpointError):
        GrnGenome.load(tmp_path / "junk.npz")


def test_stack_genomes(genome):
    other = init_genome(GrnConfig(), 3, np.random.default_rng(1))
    batch = stack_genomes([genome, other])
    assert batch.W_r.shape == (2, 50, 50) and batch.theta.shape == (2, 50)
    np.testing.assert_array_equal(batch.W_s[1], other.W_s)
