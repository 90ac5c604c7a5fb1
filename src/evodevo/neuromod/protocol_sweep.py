"""The DQN protocol sweep that picks SPEC §1.6's unstated details by measurement.

Table 3.1 fixes batch, learning rate, optimiser, discount, buffer, the ε start/floor/"rate
0.995" and the episodes; it leaves open what ε decays per, the target network, double
Q-learning and which network a task keeps. A *protocol* is a named set of overrides of the
run config (``configs/biarm_sweep.yaml``); :func:`run_sweep` trains every
(protocol, task, variant, seed) with each task **alone** (its thesis episodes, its own fresh
column) into ``OUT/{protocol}/{task}/{variant}__s{seed}/``, over a process pool, skipping
finished runs and resuming interrupted ones; :func:`sweep_table` reads the saved summaries
only and writes the table (final greedy return, mean ± std and bootstrap 95 % interval over
seeds, on validation seeds: the sweep chooses, so it never reads the locked test range) that ``docs/results/biarm.md`` shows.

>>> spec = SweepSpec.from_dict({"protocols": {"v1": {"dqn": {"eps_unit": "episode"}}},
...                             "tasks": ["CartPole-v1"], "variants": ["pnn"], "seeds": "0-1"})
>>> spec.seeds, list(spec.protocols)
([0, 1], ['v1'])
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.config import from_dict, read_yaml, to_dict
from evodevo.errors import ConfigError, EvodevoError
from evodevo.neuromod.checkpoint import latest_resume_point
from evodevo.neuromod.config import THESIS_TASKS, BiarmConfig, TaskConfig
from evodevo.neuromod.trainer import train
from evodevo.neuromod.variants import get_variant
from evodevo.parallel import make_pool
from evodevo.runs import atomic_write_text, read_json
from evodevo.seed_split import VALIDATION, require_selection
from evodevo.seeding import parse_seeds
from evodevo.stats import summarise

__all__ = [
    "SWEEP_EVAL_SEED",
    "SweepSpec",
    "protocol_config",
    "run_sweep",
    "collect_sweep",
    "sweep_table",
]

#: First evaluation seed of the sweep's runs: validation seeds (the ones the committed sweep
#: read, 10000..10019), because the sweep picks a protocol (SPEC §6).
SWEEP_EVAL_SEED = VALIDATION.first

_THESIS = {env: (episodes, steps) for env, episodes, steps in THESIS_TASKS}


def _merge(base: dict[str, Any], over: Mapping[str, Any], path: str = "") -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in over.items():
        where = f"{path}{key}"
        if key not in out:
            raise ConfigError(
                f"protocol override {where!r} is not a config key; see `evodevo biarm config`"
            )
        if isinstance(value, Mapping):
            if not isinstance(out[key], dict):
                raise ConfigError(f"protocol override {where!r} is a value, not a section")
            out[key] = _merge(out[key], value, f"{where}.")
        else:
            out[key] = value
    return out


def protocol_config(base: BiarmConfig, overrides: Mapping[str, Any]) -> BiarmConfig:
    """``base`` with a protocol's overrides (nested dict of config keys), validated."""
    return from_dict(BiarmConfig, _merge(to_dict(base), overrides))


@dataclass
class SweepSpec:
    """What a sweep trains: protocols × tasks × variants × seeds."""

    protocols: dict[str, dict[str, Any]] = field(default_factory=dict)
    tasks: list[str] = field(default_factory=lambda: [t[0] for t in THESIS_TASKS])
    variants: list[str] = field(default_factory=lambda: ["pnn", "biarm"])
    seeds: list[int] = field(default_factory=lambda: [0, 1, 2, 3, 4])
    episodes_scale: float = 1.0

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepSpec:
        """Build from the YAML's mapping; unknown keys and bad values are errors."""
        known = {"protocols", "tasks", "variants", "seeds", "episodes_scale"}
        unknown = set(data) - known
        if unknown:
            raise ConfigError(f"unknown sweep key(s) {sorted(unknown)}; expected {sorted(known)}")
        protocols = dict(data.get("protocols") or {})
        if not protocols:
            raise ConfigError("the sweep names no protocols; give protocols: {name: overrides}")
        for name, over in protocols.items():
            if not isinstance(over, Mapping):
                raise ConfigError(f"protocol {name!r} must map config keys to values")
            protocol_config(BiarmConfig(), over)  # every override checked before any run
        seeds = data.get("seeds", "0-4")
        spec = cls(
            protocols={str(k): dict(v) for k, v in protocols.items()},
            tasks=[str(t) for t in data.get("tasks", [t[0] for t in THESIS_TASKS])],
            variants=[str(v) for v in data.get("variants", ["pnn", "biarm"])],
            seeds=parse_seeds(str(seeds), "seeds") if not isinstance(seeds, list) else seeds,
            episodes_scale=float(data.get("episodes_scale", 1.0)),
        )
        for v in spec.variants:
            get_variant(v)
        if not spec.tasks:
            raise ConfigError("the sweep names no tasks")
        return spec

    @classmethod
    def load(cls, path: str | Path) -> SweepSpec:
        """Read ``configs/biarm_sweep.yaml``-style YAML (errors name the file and line)."""
        data = read_yaml(path, what="sweep file")
        return cls.from_dict(data)

    def select(
        self,
        protocols: Sequence[str] | None = None,
        tasks: Sequence[str] | None = None,
        variants: Sequence[str] | None = None,
        seeds: Sequence[int] | None = None,
    ) -> SweepSpec:
        """A part of the sweep (unknown protocol names are an error)."""
        names = list(protocols) if protocols else list(self.protocols)
        for n in names:
            if n not in self.protocols:
                raise ConfigError(
                    f"protocol {n!r} is not in the sweep; choose from {', '.join(self.protocols)}"
                )
        for v in variants or []:
            get_variant(v)
        return SweepSpec(
            protocols={n: self.protocols[n] for n in names},
            tasks=list(tasks) if tasks else list(self.tasks),
            variants=list(variants) if variants else list(self.variants),
            seeds=list(seeds) if seeds else list(self.seeds),
            episodes_scale=self.episodes_scale,
        )

    def items(self, out: Path) -> list[tuple[str, str, str, int, Path]]:
        """``(protocol, task, variant, seed, run folder)`` of every run of the sweep."""
        return [
            (p, t, v, s, out / p / t / f"{v}__s{s}")
            for p in self.protocols
            for t in self.tasks
            for v in self.variants
            for s in self.seeds
        ]

    def run_config(self, protocol: str, task: str) -> BiarmConfig:
        """The config of one run: the protocol's overrides, ``task`` alone at its episodes.

        The sweep chooses a protocol, so its runs are evaluated on validation seeds
        (:data:`SWEEP_EVAL_SEED` unless the protocol names others); a protocol that points
        ``eval.seed`` at the locked test range is refused (SPEC §6)."""
        over = self.protocols[protocol]
        cfg = protocol_config(BiarmConfig(), over)
        if "seed" not in over.get("eval", {}):
            cfg.eval.seed = SWEEP_EVAL_SEED
        require_selection(cfg.eval.seed, cfg.eval.episodes, f"protocol {protocol!r} eval.seed")
        episodes, steps = _THESIS.get(task, (cfg.default_episodes, None))
        cfg.tasks = [TaskConfig(task, episodes, steps)]
        cfg.episodes_scale = self.episodes_scale
        cfg.validate()
        return cfg


def _run_one(item: tuple[str, int, dict[str, Any], str]) -> str:
    """Worker body: train one single-task run into its folder (resuming if interrupted)."""
    variant, seed, cfg_dict, out = item
    cfg = from_dict(BiarmConfig, cfg_dict)
    resume = latest_resume_point(Path(out) / "checkpoints") is not None
    train(cfg, variant, seed, out, resume=resume)
    return out


def run_sweep(spec: SweepSpec, out: str | Path, workers: int = 1) -> list[str]:
    """Train the sweep's missing runs (finished ones are skipped); returns those run."""
    root = Path(out)
    items = []
    for protocol, task, variant, seed, folder in spec.items(root):
        if (folder / "summary.json").is_file():
            continue
        cfg = spec.run_config(protocol, task)
        items.append((variant, seed, to_dict(cfg), str(folder)))
    if not items:
        return []
    root.mkdir(parents=True, exist_ok=True)
    with make_pool("local", min(workers, len(items))) as pool:
        return list(pool.map(_run_one, items))


def collect_sweep(
    spec: SweepSpec, out: str | Path
) -> dict[tuple[str, str, str], list[dict[str, Any]]]:
    """``{(protocol, task, variant): [summary per finished seed]}``."""
    found: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for protocol, task, variant, _, folder in spec.items(Path(out)):
        p = folder / "summary.json"
        if p.is_file():
            found.setdefault((protocol, task, variant), []).append(read_json(p))
    if not found:
        raise EvodevoError(f"no finished sweep run under {str(out)!r}; run the sweep first")
    return found


def _last_network(summary: dict[str, Any]) -> float:
    """Mean greedy return of the task's *last* network (recorded beside the kept best one when
    ``dqn.keep: best``); NaN when the run kept the last network anyway."""
    v = summary["tasks"][0].get("validation")
    if not v or not v.get("last_network_returns"):
        return math.nan
    return float(np.mean(v["last_network_returns"]))


def _cell(summaries: Sequence[dict[str, Any]], key: str) -> str:
    if key == "last_network":
        vals = [_last_network(s) for s in summaries]
    else:
        vals = [float(s["tasks"][0][key]) for s in summaries]
    vals = [v for v in vals if not math.isnan(v)]
    m = summarise(vals)
    if m.n == 0 or math.isnan(m.mean):
        return "–"
    return f"{m.mean:.1f} ± {m.std:.1f} [{m.ci_low:.1f}, {m.ci_high:.1f}] (n={m.n})"


def sweep_table(spec: SweepSpec, out: str | Path) -> str:
    """Markdown table of the sweep from the saved summaries; also written to
    ``OUT/sweep.md``. Rows: protocol × variant; columns: tasks; cells: final greedy return,
    mean ± std [bootstrap 95 % CI] over seeds, and the median wall time per run."""
    found = collect_sweep(spec, out)
    header = ["protocol", "variant", *spec.tasks, "minutes per run (median)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for protocol in spec.protocols:
        for variant in spec.variants:
            cells, last = [], []
            walls: list[float] = []
            for task in spec.tasks:
                runs = found.get((protocol, task, variant), [])
                cells.append(_cell(runs, "final_return") if runs else "–")
                last.append(_cell(runs, "last_network") if runs else "–")
                walls += [float(s.get("wall_seconds", math.nan)) / 60 for s in runs]
            if not any(c != "–" for c in cells):
                continue  # nothing of this protocol x variant has finished
            wall = sorted(walls)[len(walls) // 2] if walls else math.nan
            lines.append("| " + " | ".join([protocol, variant, *cells, f"{wall:.1f}"]) + " |")
            if any(c != "–" for c in last):  # keep: best -- the same runs' last networks
                lines.append(
                    "| " + " | ".join([f"{protocol} (last network)", variant, *last, ""]) + " |"
                )
    overrides = "\n".join(f"- `{name}`: {over}" for name, over in spec.protocols.items())
    text = (
        "Final greedy return of each task trained alone (its thesis episodes), mean ± std "
        "[bootstrap 95 % CI] over seeds "
        f"{spec.seeds[0]}-{spec.seeds[-1]}, on validation seeds from "
        f"{SWEEP_EVAL_SEED} (the sweep chooses a protocol, so it never reads the locked test "
        "range, SPEC §6). Under `keep: best` the task keeps the column that scored best on the "
        "column-picking validation seeds; "
        "the `(last network)` row is the same runs' final network on the same evaluation "
        "seeds.\n\n"
        + "\n".join(lines)
        + "\n\nProtocols (overrides of the config defaults):\n\n"
        + overrides
        + "\n"
    )
    atomic_write_text(Path(out) / "sweep.md", text)
    return text
