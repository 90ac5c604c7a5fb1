"""What an evolution tells its callbacks, and the callbacks every run has (SPEC §2.4).

A :class:`GenerationRecord` is one generation's row of ``history.csv``; the evolution
(:class:`~evodevo.grn.evolution.Evolution`, each callback's ``owner``) passes it to
``on_generation``. :class:`Checkpointer` writes the checkpoint and the run files after every
generation, :class:`StopOnSignal` ends a run after the generation SIGINT/SIGTERM arrived in,
:class:`ProgressPrinter` prints one line per generation.
"""

from __future__ import annotations

import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.callbacks import Callback
from evodevo.config import to_dict
from evodevo.grn.return_rule import summary_fields
from evodevo.runs import RunDir, machine_info
from evodevo.signals import GracefulStop

__all__ = [
    "CHECKPOINT_FILE",
    "GenerationRecord",
    "ProgressPrinter",
    "StopOnSignal",
    "Checkpointer",
    "summarise_evolution",
]

CHECKPOINT_FILE = "checkpoint.npz"


@dataclass
class GenerationRecord:
    """One row of ``history.csv``."""

    generation: int
    best_fitness: float
    mean_fitness: float
    best_success: float
    mean_success: float
    best_connections: int
    mean_connections: float
    retest_success: float
    episodes: int
    env_steps: int
    eval_s: float
    evals_per_s: float
    elapsed_s: float
    episodes_saved: int = 0
    """Episodes of ``episodes`` copied from an identical genome, not run (evaluation.dedupe)."""


class ProgressPrinter(Callback):
    """One progress line per generation on stderr."""

    def on_generation(self, record: GenerationRecord) -> None:
        evo = self.owner
        r = record
        retest = "" if np.isnan(r.retest_success) else f" retest {r.retest_success:.2f}"
        if evo.validated is not None and evo.validated.rows:
            v = evo.validated.rows[-1]
            retest += f" validation {v['successes']}/{v['episodes']} (kept gen {v['kept_at'] + 1})"
        print(
            f"gen {r.generation + 1:>3}/{evo.config.evolution.generations} "
            f"best F {r.best_fitness:6.2f} mean F {r.mean_fitness:6.2f} "
            f"best success {r.best_success:.2f}{retest} connections {r.best_connections} "
            f"{r.evals_per_s:.2f} ep/s elapsed {r.elapsed_s:.0f}s",
            file=sys.stderr,
            flush=True,
        )

    def on_end(self) -> None:
        evo = self.owner
        p = evo.final_pick
        if p is not None and p["after_generation"] == evo.generation:
            print(
                f"final pick: elites won {p['successes']} of {p['episodes']} fresh episodes; "
                f"kept rank {p['picked_rank']}",
                file=sys.stderr,
                flush=True,
            )


class StopOnSignal(Callback):
    """Stop after the generation that was running when SIGINT/SIGTERM arrived (it is checkpointed)."""

    def __init__(self, stop: GracefulStop, run_path: Path) -> None:
        self.stop = stop
        self.run_path = run_path

    def on_generation(self, record: GenerationRecord) -> None:
        self.stop.check(
            f"generation {record.generation}",
            f"continue with: evodevo grn evolve --resume --out {self.run_path}",
        )


class Checkpointer(Callback):
    """After every generation: checkpoint, ``history.csv``, ``best_genome.npz``, ``summary.json``."""

    def __init__(self, run: RunDir) -> None:
        self.run = run

    def on_generation(self, record: GenerationRecord) -> None:
        self.owner.save_checkpoint(self.run.checkpoints / CHECKPOINT_FILE)
        self.write_outputs(self.owner)

    def on_end(self) -> None:
        self.owner.save_checkpoint(self.run.checkpoints / CHECKPOINT_FILE)  # holds the final pick
        self.write_outputs(self.owner)

    def write_outputs(self, evo: Any) -> None:
        rows = [asdict(r) for r in evo.history]
        self.run.write_csv("history.csv", rows, list(GenerationRecord.__dataclass_fields__))
        if evo.validated is not None:
            evo.validated.write_csv(self.run)
        if evo.best_genome is not None:
            evo.best_genome.save(self.run / "best_genome.npz", to_dict(evo.config))
        self.run.write_summary(summarise_evolution(evo))


def summarise_evolution(evo: Any) -> dict[str, Any]:
    """The ``summary.json`` of an evolution run (``evo``: an :class:`~evodevo.grn.evolution.Evolution`)."""
    h = evo.history
    return {
        "kind": "grn_evolve",
        "controller": evo.config.controller,
        "optimizer": evo.config.evolution.optimizer,
        "blind": evo.config.sensors.blind,
        "seed": evo.config.seed,
        "fitness_history": [r.best_fitness for r in h],
        "mean_fitness_history": [r.mean_fitness for r in h],
        "success_history": [r.best_success for r in h],
        "connections_history": [r.best_connections for r in h],
        "retest_history": [None if np.isnan(r.retest_success) else r.retest_success for r in h],
        "generations_run": evo.generation,
        "stopped_early": evo.stopped_early,
        "done": evo.done,
        "wall_s": evo.elapsed_s,
        "episodes_run": evo.episodes_run,
        "env_steps": evo.env_steps,
        "episodes_saved": evo.episodes_saved,
        "reevaluated_generations": evo.reevaluated,
        "final_pick": evo.final_pick,
        "kept": evo.config.evolution.keep,
        **summary_fields(evo.config.evolution.keep, evo.validated),
        "champion": evo.champion_record(),
        "best_fitness": h[-1].best_fitness if h else None,
        "best_training_success": h[-1].best_success if h else None,
        "budget": {
            "population": evo.config.evolution.population,
            "generations": evo.config.evolution.generations,
            "episodes_per_evaluation": evo.config.evaluation.episodes,
        },
        "machine": machine_info(),
    }
