"""Convert run folders written before evodevo stopped using pickle (one-off; SPEC §6).

    python scripts/convert_safe_run_files.py FOLDER [FOLDER ...] [--dry-run] [--keep]

**Run it only on folders you trust** — your own runs, or runs from someone you trust. To read
the old files this script unpickles them (``torch.load(weights_only=False)``, ``pickle``,
Stable-Baselines3's ``load``, which cloudpickles), and unpickling a file runs any code it
holds. That is why evodevo itself no longer opens these files and refuses them with an error
that points here; this script is the one place that still reads them, and only because you run
it explicitly on your own folders.

Every file found under the folders is rewritten in the format evodevo reads now
(:mod:`evodevo.safe_io`), checked to load back equal, and then deleted (``--keep`` keeps it):

* BIARM checkpoints ``checkpoints/task{i}.pt``, ``task{i}_ep{k}.pt`` → ``.safetensors``;
* Stable-Baselines3 zips (``model.zip``, ``checkpoints/rl_model_{n}_steps.zip``,
  ``checkpoints/sb3_task{i}.zip``) → ``.safetensors`` (:mod:`evodevo.baselines.sb3_files`);
  the algorithm is the run's ``config.json`` method (``sb3_task`` files: DQN). A final
  ``model.zip`` whose converted file would exceed ``--max-mb`` (5 MB; TD3's two critics and
  target networks) keeps the policy for acting only: no optimiser states or target networks,
  so it is evaluated as before but cannot continue training. The check compares the actions
  of the old and new model on random observations;
* TD3 replay buffers ``*_replay_buffer_*.pkl`` → ``.npz``;
* NEAT ``best_genome.pkl`` → ``best_genome.json`` and neat-python checkpoints
  ``checkpoints/neat-checkpoint-{g}`` → ``neat-checkpoint-{g}.json``
  (:mod:`evodevo.baselines.neat_files`). neat-python's pickles hold neither the reproduction's
  ancestors nor its next genome id; they are restored as neat-python's own ``Checkpointer``
  restores them (no ancestors; the next id after the largest in the population).

``encoder.pt`` files stay as they are: they hold tensors only and evodevo reads them with
PyTorch's weights-only reader; the script checks that they do.
"""

from __future__ import annotations

import argparse
import gzip
import math
import pickle
import random
import re
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import torch

from evodevo.errors import CheckpointError
from evodevo.neuromod.checkpoint import FORMAT as BIARM_FORMAT
from evodevo.neuromod.checkpoint import load_checkpoint
from evodevo.runs import read_json
from evodevo.safe_io import load_torch_tensors, save_state

BIARM = re.compile(r"^task\d+(_ep\d+)?\.pt$")
SB3_ZIP = re.compile(r"^(model|rl_model_\d+_steps|sb3_task\d+)\.zip$")
REPLAY = re.compile(r"^.*_replay_buffer_\d+_steps\.pkl$")
NEAT_CKPT = re.compile(r"^neat-checkpoint-(\d+)$")


def same(a: Any, b: Any) -> bool:
    """Deep equality of loaded states (tensors and arrays exactly, NaN equal to NaN)."""
    if isinstance(a, torch.Tensor) or isinstance(b, torch.Tensor):
        return (
            isinstance(a, torch.Tensor)
            and isinstance(b, torch.Tensor)
            and a.dtype == b.dtype
            and a.shape == b.shape
            and bool(torch.equal(a, b) or torch.allclose(a, b, rtol=0, atol=0, equal_nan=True))
        )
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            isinstance(a, np.ndarray)
            and isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        )
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(type(a) is type(b) and a == b)


def convert_biarm(path: Path) -> Path:
    old = torch.load(path, map_location="cpu", weights_only=False)  # trusted: see docstring
    if not isinstance(old, dict) or "agent" not in old:
        raise CheckpointError(f"{str(path)!r} is not a BIARM checkpoint")
    old = {k: v for k, v in old.items() if k != "format"}
    new = path.with_suffix(".safetensors")
    save_state(new, BIARM_FORMAT, old)
    if not same(load_checkpoint(new), old):
        raise CheckpointError(f"{str(new)!r} does not load back equal to {str(path)!r}")
    return new


def _algo(path: Path) -> str:
    if path.name.startswith("sb3_task"):
        return "dqn"
    for folder in (path.parent, path.parent.parent):
        if (folder / "config.json").is_file():
            method = str(read_json(folder / "config.json").get("config", {}).get("method"))
            if method in ("ppo", "td3"):
                return method
    raise CheckpointError(f"cannot tell the algorithm of {str(path)!r} (no baseline config.json)")


def _observations(space: Any, n: int = 8) -> np.ndarray:
    rng = np.random.default_rng(0)
    if space.dtype == np.uint8:
        return rng.integers(0, 256, (n, *space.shape), dtype=np.uint8)
    return rng.normal(size=(n, *space.shape)).astype(space.dtype)


def convert_sb3(path: Path, max_bytes: int) -> tuple[Path, str]:
    from stable_baselines3 import DQN, PPO

    from evodevo.baselines.sb3_files import load_sb3_policy, save_sb3
    from evodevo.baselines.sb3_kuka import Td3TwoRates

    algo = _algo(path)
    classes: dict[str, Any] = {"ppo": PPO, "td3": Td3TwoRates, "dqn": DQN}
    model = classes[algo].load(path, device="cpu")  # trusted: see docstring
    new = path.with_suffix(".safetensors")
    save_sb3(model, new)
    note = "with optimiser states"
    if new.stat().st_size > max_bytes and path.parent.name != "checkpoints":
        save_sb3(model, new, training=False)
        note = "policy for acting only (the full model exceeds --max-mb)"
    policy = load_sb3_policy(algo, new)
    obs = _observations(policy.observation_space)
    got, _ = policy.predict(obs, deterministic=True)
    want, _ = model.predict(obs, deterministic=True)
    if not np.array_equal(got, want):
        raise CheckpointError(f"{str(new)!r} acts unlike {str(path)!r}")
    return new, note


def convert_replay(path: Path) -> Path:
    from evodevo.baselines.sb3_files import save_replay_buffer

    with path.open("rb") as fh:
        buffer = pickle.load(fh)  # trusted: see docstring
    new = path.with_suffix(".npz")
    save_replay_buffer(SimpleNamespace(replay_buffer=buffer), new)
    with np.load(new, allow_pickle=False) as data:
        n = buffer.buffer_size if buffer.full else buffer.pos
        if not np.array_equal(data["observations"], buffer.observations[:n]):
            raise CheckpointError(f"{str(new)!r} does not hold {str(path)!r}'s transitions")
    return new


def _neat_config(run: Path) -> Any:
    from evodevo.baselines.policies import neat_config

    return neat_config(run / "neat.ini")


def convert_genome(path: Path) -> Path:
    from evodevo.baselines.neat_files import genome_to_dict, read_genome, save_genome

    with path.open("rb") as fh:
        genome = pickle.load(fh)  # trusted: see docstring
    new = path.with_suffix(".json")
    data = genome_to_dict(genome)
    save_genome(new, data, path.parent / "neat.ini")
    if read_genome(new, _neat_config(path.parent)) != data:
        raise CheckpointError(f"{str(new)!r} does not load back equal to {str(path)!r}")
    return new


def convert_population(path: Path) -> Path:
    import neat

    from evodevo.baselines.neat_files import genome_to_dict, restore_population, save_population

    run = path.parent.parent
    outer = random.getstate()
    try:
        with gzip.open(path) as fh:
            generation, saved, population, species, rnd = pickle.load(fh)  # trusted
        config = _neat_config(run)
        pop = neat.Population(config, (population, species, generation))
        tracker = getattr(saved.genome_config, "innovation_tracker", None)
        if tracker is not None:
            pop.reproduction.innovation_tracker = tracker
            config.genome_config.innovation_tracker = tracker
        config.genome_config.node_indexer = saved.genome_config.node_indexer
        random.setstate(rnd)
        new = path.with_name(path.name + ".json")
        save_population(new, pop, generation)
        back, gen = restore_population(new, _neat_config(run))
        if gen != generation or [genome_to_dict(g) for g in back.population.values()] != [
            genome_to_dict(g) for g in population.values()
        ]:
            raise CheckpointError(f"{str(new)!r} does not load back equal to {str(path)!r}")
        if random.getstate() != rnd:
            raise CheckpointError(f"{str(new)!r} does not restore {str(path)!r}'s random state")
    finally:
        random.setstate(outer)
    return new


def find(folder: Path) -> list[tuple[str, Path]]:
    """The (kind, path) of every file to convert under ``folder``, in a stable order."""
    found = []
    for p in sorted(folder.rglob("*")):
        if not p.is_file():
            continue
        if BIARM.match(p.name) and p.parent.name == "checkpoints":
            found.append(("biarm", p))
        elif SB3_ZIP.match(p.name):
            found.append(("sb3", p))
        elif REPLAY.match(p.name):
            found.append(("replay", p))
        elif p.name == "best_genome.pkl":
            found.append(("genome", p))
        elif NEAT_CKPT.match(p.name) and p.parent.name == "checkpoints":
            found.append(("population", p))
        elif p.name == "encoder.pt":
            found.append(("encoder", p))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="run folders you trust")
    parser.add_argument("--dry-run", action="store_true", help="only list what would change")
    parser.add_argument("--keep", action="store_true", help="keep the old files")
    parser.add_argument("--max-mb", type=float, default=5.0, help="size limit of a final model")
    args = parser.parse_args(argv)
    converted = kept = failed = 0
    for folder in args.folders:
        if not folder.is_dir():
            print(f"error: {folder} is not a folder", file=sys.stderr)
            return 2
        for kind, path in find(folder):
            if args.dry_run:
                print(f"would convert {kind}: {path}")
                continue
            try:
                if kind == "encoder":
                    load_torch_tensors(path, "encoder")
                    print(f"kept      {path} (tensors only; read weights-only)")
                    kept += 1
                    continue
                note = "verified"
                if kind == "biarm":
                    new = convert_biarm(path)
                elif kind == "sb3":
                    new, how = convert_sb3(path, int(args.max_mb * 2**20))
                    note = f"verified, {how}"
                elif kind == "replay":
                    new = convert_replay(path)
                elif kind == "genome":
                    new = convert_genome(path)
                else:
                    new = convert_population(path)
            except (CheckpointError, OSError, ValueError, KeyError) as exc:
                print(f"FAILED    {path}: {exc}", file=sys.stderr)
                failed += 1
                continue
            if not args.keep:
                path.unlink()
            converted += 1
            size = new.stat().st_size / 2**20
            print(f"converted {path} -> {new.name} ({size:.2f} MB; {note})")
    print(f"{converted} converted, {kept} kept as they are, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
