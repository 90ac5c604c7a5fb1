"""The evolution loop of Algorithm 3 (SPEC §2.4), shared by every optimiser, with callbacks.

Each generation (ask-evaluate-tell): the optimiser's population (``evolution.optimizer``:
the thesis' GA, elites included, or CMA-ES's samples; :mod:`evodevo.grn.optimizers`) is
evaluated on the SAME fresh episodes (common random numbers; 70 % clean, 30 % with
visual-feature noise), scored with Eq. 4.6 (plus the shaped term, if configured) and ranked; if
the best genome's training success reaches ``early_stop_success`` it is retested on
``retest_episodes`` new episodes (same protocol) and evolution stops when the retest reaches
``retest_success``. Otherwise the optimiser is told the fitness and asked for the next
population (for the GA: the best ``elites`` unchanged and mutated copies of tournament-picked
parents).

The loop knows nothing of GRNs: the controller kind, the optimiser and the
:class:`~evodevo.grn.evaluator.Evaluator` are separate pieces, so the open-loop control, the
feed-forward arms and later kinds reuse it. :func:`evolve_run` wires it to a run directory:
``encoder.pt``, ``config.json``, ``history.csv``, ``best_genome.npz``, ``summary.json`` and an
atomic checkpoint after every generation (population, optimiser state as arrays and JSON,
history) so ``resume`` continues exactly where an interrupted run stopped. Which genome the run
returns is ``evolution.keep`` (:mod:`evodevo.grn.return_rule`): ``validated`` adds
``validation.csv`` and ``checkpoints/validation.safetensors``.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.callbacks import Callback, CallbackList
from evodevo.config import from_dict, to_dict
from evodevo.errors import CheckpointError, ConfigError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import check_controller, make_controller
from evodevo.grn.evaluator import Episode, Evaluator, genome_key
from evodevo.grn.evolution_callbacks import (
    CHECKPOINT_FILE,
    Checkpointer,
    GenerationRecord,
    ProgressPrinter,
    StopOnSignal,
    summarise_evolution,
)
from evodevo.grn.fitness import distance_penalty, fitness_matrix
from evodevo.grn.frontends import load_frontend, make_frontend, save_frontend
from evodevo.grn.genome import load_arrays, save_arrays
from evodevo.grn.optimizers import make_optimizer
from evodevo.grn.return_rule import STATE_FILE, VALIDATED, ValidatedBest
from evodevo.grn.selection import rank
from evodevo.runs import RunDir, write_json
from evodevo.seeding import derive, np_rng
from evodevo.signals import GracefulStop
from evodevo.stats import wilson_interval

__all__ = [
    "CHECKPOINT_FILE",
    "GenerationRecord",
    "StopOnSignal",
    "summarise_evolution",
    "ProgressPrinter",
    "Checkpointer",
    "Evolution",
    "training_episodes",
    "evolve_run",
    "EVOLUTION_KEY",
    "EPISODE_KEY",
    "RETEST_KEY",
    "FINAL_PICK_KEY",
]

EVOLUTION_KEY = 2
"""Seed stream of the optimiser (initial genomes, mutations, tournaments; CMA-ES's samples)."""
EPISODE_KEY = 3
"""Seed stream of the training episodes (per generation)."""
RETEST_KEY = 4
"""Seed stream of the early-stop retest episodes (per generation)."""
FINAL_PICK_KEY = 5
"""Seed stream of the final-pick episodes (``evolution.final_pick_episodes``)."""
OPTIMIZER_PREFIX = "optimizer__"
"""Checkpoint arrays of the optimiser's state (none for the GA)."""


def training_episodes(
    seed: int, key: int, generation: int, count: int, noisy_fraction: float
) -> list[Episode]:
    """``count`` episodes for ``generation``: the last round(noisy_fraction·count) are noisy."""
    n_noisy = int(round(noisy_fraction * count))
    return [
        Episode(derive(seed, key, generation, i), noisy=i >= count - n_noisy) for i in range(count)
    ]


class Evolution:
    """The loop of Algorithm 3 over any controller kind and optimiser.

    Args:
        config: a :class:`~evodevo.grn.config.GrnConfig`.
        controller: the controller kind (``init_genome``, ``mutate``, ``connections``,
            ``genome_from_arrays``; ``evolvable`` and ``repair`` for CMA-ES).
        evaluator: scores genomes on episodes.
        callbacks: told after every generation and at the end (:mod:`evodevo.callbacks`).
    """

    def __init__(
        self,
        config: GrnConfig,
        controller: Any,
        evaluator: Evaluator,
        callbacks: Sequence[Callback] = (),
    ) -> None:
        self.config = config
        self.controller = controller
        self.evaluator = evaluator
        self.callback = CallbackList(callbacks)
        self.callback.init(self)
        self.rng = np_rng(config.seed, EVOLUTION_KEY)
        self.optimizer = make_optimizer(config, controller, self.rng)
        self.population: list[Any] = self.optimizer.ask()
        """The genomes the next :meth:`step` evaluates."""
        self.generation = 0
        self.history: list[GenerationRecord] = []
        self.best_genome: Any = None
        self.stopped_early = False
        self.elapsed_s = 0.0
        self.episodes_run = 0
        self.env_steps = 0
        self.episodes_saved = 0
        self.bred_at_end = True
        self.reevaluated: list[int] = []
        """Generations that evaluated the previous generation's population again (an
        extension of a run whose checkpoint predates breeding after the last generation)."""
        self.final_pick: dict[str, Any] | None = None
        """The final re-selection (``evolution.final_pick_episodes``), once it ran."""
        self.records: dict[str, list[int]] = {}
        """``evolution.keep: record``: [successes, episodes] of every genome evaluated so far,
        keyed by its content (identical genomes share one record)."""
        self.champion: Any = None
        """``evolution.keep: record``: the genome whose record has the highest Wilson lower
        bound so far (see :meth:`update_records`)."""
        self.champion_key: str | None = None
        self.validated: ValidatedBest | None = None
        """``evolution.keep: validated``: each generation's best scored on the validation
        episodes, the one with the most successes kept (:mod:`evodevo.grn.return_rule`)."""
        if config.evolution.keep == VALIDATED:
            ev = config.evaluation
            self.validated = ValidatedBest(
                ev.validation_seed, ev.validation_episodes, "generation", ev.validation_score
            )

    @property
    def done(self) -> bool:
        return self.stopped_early or self.generation >= self.config.evolution.generations

    def step(self) -> GenerationRecord:
        """Evaluate the current population, check the early stop, breed the next one."""
        cfg, evo_cfg = self.config, self.config.evolution
        t0 = time.perf_counter()
        if not self.bred_at_end:
            self.reevaluated.append(self.generation)
            self.bred_at_end = True
        episodes = training_episodes(
            cfg.seed,
            EPISODE_KEY,
            self.generation,
            cfg.evaluation.episodes,
            cfg.evaluation.noisy_fraction,
        )
        weight = float(getattr(cfg.evaluation, "distance_weight", 0.0))
        res = self.evaluator.evaluate(self.population, episodes, measure_distance=weight > 0)
        fit = fitness_matrix(res.reward, res.success)
        if weight > 0 and res.distance is not None:
            fit = fit - weight * distance_penalty(res.distance)
        succ = res.success_rate
        order = rank(fit)
        if evo_cfg.keep == "record":
            self.update_records(res.success, order)
        best = int(order[0])
        n_eps, steps, saved = res.reward.size, res.env_steps, res.episodes_saved
        retest = float("nan")
        self.best_genome = self.population[best]
        if cfg.evolution.early_stop and succ[best] >= evo_cfg.early_stop_success:
            re_eps = training_episodes(
                cfg.seed,
                RETEST_KEY,
                self.generation,
                evo_cfg.retest_episodes,
                cfg.evaluation.noisy_fraction,
            )
            re = self.evaluator.evaluate([self.best_genome], re_eps)
            retest = float(re.success_rate[0])
            n_eps += re.reward.size
            steps += re.env_steps
            self.stopped_early = retest >= evo_cfg.retest_success
        conns = [self.controller.connections(g) for g in self.population]
        # breed after the last generation too: the checkpoint then holds the population a
        # longer run would evaluate next, so extending the run (--resume with more
        # generations) continues exactly as if it had been started with them
        if not self.stopped_early:
            self.optimizer.tell(self.population, fit, order)
            self.population = self.optimizer.ask()
        eval_s = time.perf_counter() - t0
        if self.validated is not None:  # after the clock: validation is not training time
            self.validate(self.best_genome)
        self.elapsed_s += eval_s
        self.episodes_run += n_eps
        self.env_steps += steps
        self.episodes_saved += saved
        record = GenerationRecord(
            generation=self.generation,
            best_fitness=float(fit[best]),
            mean_fitness=float(fit.mean()),
            best_success=float(succ[best]),
            mean_success=float(succ.mean()),
            best_connections=int(conns[best]),
            mean_connections=float(np.mean(conns)),
            retest_success=retest,
            episodes=n_eps,
            env_steps=steps,
            eval_s=eval_s,
            evals_per_s=n_eps / eval_s if eval_s > 0 else float("nan"),
            elapsed_s=self.elapsed_s,
            episodes_saved=saved,
        )
        self.history.append(record)
        self.generation += 1
        self.callback.on_generation(record)
        return record

    def validate(self, genome: Any) -> bool:
        """``evolution.keep: validated``: score this generation's best on the validation
        episodes (not training: its episodes and time are counted apart); keep it if it has
        the most successes so far (the later generation on a tie)."""
        if self.validated is None:
            raise ConfigError("validate() needs evolution.keep: validated")
        arrays = genome.arrays() if hasattr(genome, "arrays") else {}
        if not arrays:
            raise ConfigError(
                f"evolution.keep=validated saves the kept genome as arrays; "
                f"{type(genome).__name__} has none. Use evolution.keep: last"
            )
        return self.validated.check(self.evaluator, genome, self.generation, {"arrays": arrays})

    def update_records(self, success: np.ndarray, order: np.ndarray) -> None:
        """Add this generation's outcomes to the records; replace the champion if beaten.

        ``evolution.keep: record`` (SPEC §2.4 leaves the returned genome to us; the thesis keeps
        the last generation's best). Each distinct genome of the population (by content, so a
        clone's copied outcomes count once) adds its successes and episodes to its record;
        elites, which pass unchanged, build records over many generations' fresh episodes.
        Then, in rank order, any genome whose record's 95 % Wilson lower bound is strictly above
        the champion's (re-read, the champion may have been evaluated again) becomes the
        champion. Selection is untouched: the run's trajectory is the same as with ``last``.

        Args:
            success: (population, episodes) outcomes of this generation.
            order: genome indices, best first.
        """
        seen: dict[str, int] = {}
        for i in (int(j) for j in order):
            key = _record_key(self.population[i])
            if key in seen:
                continue
            seen[key] = i
            rec = self.records.setdefault(key, [0, 0])
            rec[0] += int(np.sum(success[i]))
            rec[1] += int(np.size(success[i]))
        best = self.record_bound(self.champion_key) if self.champion_key is not None else -1.0
        for key, i in seen.items():
            bound = self.record_bound(key)
            if bound > best:
                best, self.champion_key, self.champion = bound, key, self.population[i]

    def record_bound(self, key: str) -> float:
        """The 95 % Wilson lower bound of the success rate of record ``key``."""
        k, n = self.records[key]
        return wilson_interval(k, n)[0]

    def champion_record(self) -> dict[str, Any] | None:
        """The champion's record for ``summary.json`` (None before the first generation)."""
        if self.champion_key is None:
            return None
        k, n = self.records[self.champion_key]
        return {"successes": k, "episodes": n, "lower_bound": self.record_bound(self.champion_key)}

    def pick_final(self) -> dict[str, Any]:
        """Re-select the final genome among the last generation's elites (SPEC §2.4 budget).

        The optimiser's ``elites`` finalists (the GA: the population bred after the last
        generation starts with its ``elites`` best genomes, best first; CMA-ES: the genome at
        its mean, then the last generation's best) are each scored on the same
        ``final_pick_episodes`` fresh clean episodes (seed stream :data:`FINAL_PICK_KEY`,
        disjoint from the generations' and the test's) and the one with the most successes
        becomes :attr:`best_genome` (the earlier finalist on a tie).
        Measured on the Kuka vision preset's budget it gained nothing: the elites were too alike
        for a few dozen binary outcomes to tell apart (docs/results/grn.md, "The final pick").
        """
        evo_cfg = self.config.evolution
        t0 = time.perf_counter()
        candidates = self.optimizer.finalists(evo_cfg.elites)
        episodes = training_episodes(
            self.config.seed, FINAL_PICK_KEY, self.generation, evo_cfg.final_pick_episodes, 0.0
        )
        res = self.evaluator.evaluate(candidates, episodes)
        wins = res.success.sum(axis=1).astype(int)
        pick = int(np.argmax(wins))
        self.best_genome = candidates[pick]
        eval_s = time.perf_counter() - t0
        self.elapsed_s += eval_s
        self.episodes_run += res.reward.size
        self.env_steps += res.env_steps
        self.episodes_saved += res.episodes_saved
        self.final_pick = {
            "after_generation": self.generation,
            "episodes": evo_cfg.final_pick_episodes,
            "successes": wins.tolist(),
            "picked_rank": pick,
            "eval_s": eval_s,
        }
        return self.final_pick

    def run(self) -> Evolution:
        """Step until the budget is spent or the early stop fires; then :meth:`finish`."""
        while not self.done:
            self.step()
        return self.finish()

    def finish(self) -> Evolution:
        """Choose the returned genome (``evolution.keep``, the final pick); call the end callbacks.

        :meth:`run` calls it once the budget is spent; a caller stepping the loop itself (e.g.
        against a wall-clock budget) calls it when it stops.
        """
        if self.config.evolution.keep == "record" and self.champion is not None:
            self.best_genome = self.champion
        if self.validated is not None and self.validated.best_state is not None:
            self.best_genome = self.controller.genome_from_arrays(
                self.validated.best_state["arrays"]
            )
        if (
            self.config.evolution.final_pick_episodes > 0
            and not self.stopped_early
            and (self.final_pick is None or self.final_pick["after_generation"] != self.generation)
        ):
            self.pick_final()
        self.callback.on_end()
        return self

    # -- checkpoints -------------------------------------------------------------------------
    def save_checkpoint(self, path: str | Path) -> None:
        """Atomically save everything needed to continue exactly (no live handles).

        With ``evolution.keep: validated`` the validation state is written first, beside
        ``path`` (a resume drops the candidates this checkpoint does not cover)."""
        if self.validated is not None:
            self.validated.save(Path(path).with_name(STATE_FILE))
        arrays: dict[str, np.ndarray] = {}
        for i, g in enumerate(self.population):
            for name, a in g.arrays().items():
                arrays[f"pop{i}__{name}"] = a
        if self.best_genome is not None:
            for name, a in self.best_genome.arrays().items():
                arrays[f"best__{name}"] = a
        if self.champion is not None:
            for name, a in self.champion.arrays().items():
                arrays[f"champion__{name}"] = a
        opt_arrays, opt_meta = self.optimizer.state()
        for name, a in opt_arrays.items():
            arrays[f"{OPTIMIZER_PREFIX}{name}"] = a
        meta = {
            **opt_meta,  # the GA: rng_state, as before optimisers were pluggable
            "optimizer": self.optimizer.name,
            "controller": self.config.controller,
            "seed": self.config.seed,
            "population_size": len(self.population),
            "generation": self.generation,
            "stopped_early": self.stopped_early,
            "elapsed_s": self.elapsed_s,
            "episodes_run": self.episodes_run,
            "env_steps": self.env_steps,
            "episodes_saved": self.episodes_saved,
            "history": [asdict(r) for r in self.history],
            "bred": True,
            "reevaluated": self.reevaluated,
            "final_pick": self.final_pick,
            "records": self.records,
            "champion_key": self.champion_key,
        }
        save_arrays(path, "grn_checkpoint", arrays, json.loads(json.dumps(meta, default=float)))
        if self.validated is not None:  # the checkpoint covers every candidate now
            self.validated.prune()

    def load_checkpoint(self, path: str | Path) -> None:
        """Restore a checkpoint written by :meth:`save_checkpoint` of the same config."""
        arrays, meta = load_arrays(path, "grn_checkpoint")
        if meta.get("controller") != self.config.controller or meta.get("seed") != self.config.seed:
            raise CheckpointError(
                f"{str(path)!r} belongs to controller {meta.get('controller')!r} seed "
                f"{meta.get('seed')!r}, not {self.config.controller!r} seed {self.config.seed}"
            )

        def genome(prefix: str) -> Any:
            sub = {k.split("__", 1)[1]: v for k, v in arrays.items() if k.startswith(prefix + "__")}
            return self.controller.genome_from_arrays(sub) if sub else None

        saved_optimizer = meta.get("optimizer", "ga")  # written before CMA-ES: the GA
        if saved_optimizer != self.optimizer.name:
            raise CheckpointError(
                f"{str(path)!r} was written by evolution.optimizer {saved_optimizer!r}, this "
                f"config uses {self.optimizer.name!r}; resume with the optimizer it started with"
            )
        self.population = [genome(f"pop{i}") for i in range(int(meta["population_size"]))]
        opt_arrays = {
            k[len(OPTIMIZER_PREFIX) :]: v
            for k, v in arrays.items()
            if k.startswith(OPTIMIZER_PREFIX)
        }
        self.optimizer.load_state(opt_arrays, meta, self.population)
        self.best_genome = genome("best")
        self.generation = int(meta["generation"])
        self.stopped_early = bool(meta["stopped_early"])
        self.elapsed_s = float(meta["elapsed_s"])
        self.episodes_run = int(meta["episodes_run"])
        self.env_steps = int(meta["env_steps"])
        self.episodes_saved = int(meta.get("episodes_saved", 0))
        self.history = [GenerationRecord(**r) for r in meta["history"]]
        # checkpoints written before 2026-12-05 did not breed after the last generation: an
        # extension of such a run first re-evaluates that population, then breeds
        self.bred_at_end = bool(meta.get("bred", False)) or self.generation == 0
        self.reevaluated = [int(g) for g in meta.get("reevaluated", [])]
        self.final_pick = meta.get("final_pick")
        self.records = {str(k): [int(v[0]), int(v[1])] for k, v in meta.get("records", {}).items()}
        self.champion_key = meta.get("champion_key")
        self.champion = genome("champion")
        if self.validated is not None:
            ev = self.config.evaluation
            self.validated = ValidatedBest.load(
                Path(path).with_name(STATE_FILE),
                ev.validation_seed,
                ev.validation_episodes,
                "generation",
                upto=self.generation - 1,
                by=ev.validation_score,
            )


def _record_key(genome: Any) -> str:
    """The content key of a genome's record (``evolution.keep: record``)."""
    key = genome_key(genome)
    if isinstance(key, tuple) and len(key) == 2 and isinstance(key[1], str):
        return key[1]
    raise ConfigError(
        f"evolution.keep=record needs genomes with arrays to key their records; "
        f"{type(genome).__name__} has none. Use evolution.keep: last"
    )


def _check_same_config(run: RunDir, config: GrnConfig, cfg_dict: dict[str, Any]) -> int | None:
    """Refuse to resume a run whose saved config differs from ``config``.

    The one difference allowed is more ``evolution.generations`` (extending a run, e.g. to
    measure what a larger budget buys); returns the saved generations then, else None.
    """
    saved = run.read_config().get("config")
    try:  # fields added to the config since the run started take their defaults
        saved = to_dict(from_dict(type(config), saved or {}))
    except ConfigError:
        saved = None
    extended = None
    if saved is not None:
        old = int(saved["evolution"]["generations"])
        if cfg_dict["evolution"]["generations"] > old:
            extended = old
            saved = {**saved, "evolution": {**saved["evolution"]}}
            saved["evolution"]["generations"] = cfg_dict["evolution"]["generations"]
    if saved is None:
        raise EvodevoError(
            f"--resume: the config saved in {str(run / 'config.json')!r} is not a GRN config "
            "this version reads; start a new run directory"
        )
    run.check_same_config(cfg_dict, list(cfg_dict), saved, " (only --generations may grow)")
    return extended


def evolve_run(
    config: GrnConfig,
    out: str | Path,
    workers: int = 1,
    resume: bool = False,
    callbacks: Sequence[Callback] = (),
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
) -> dict[str, Any]:
    """Evolve per ``config`` into run directory ``out``; returns the summary.

    Args:
        config: the resolved :class:`~evodevo.grn.config.GrnConfig`.
        out: run directory (created).
        workers: worker processes for the evaluator.
        resume: continue from ``out/checkpoints/checkpoint.npz`` (config must match).
        callbacks: extra callbacks (:mod:`evodevo.callbacks`).
        progress: print one line per generation.
        backend: "local" (process pool) or "ray" (Ray actors); results are the same.
        address: Ray cluster address ("auto" or HOST:PORT); None starts a local Ray.
    """
    check_controller(config)
    run = RunDir(out)
    ckpt = run.path / "checkpoints" / CHECKPOINT_FILE
    cfg_dict = to_dict(config)
    if resume and not ckpt.is_file():
        if not (run / "config.json").is_file():
            raise EvodevoError(f"--resume: {str(ckpt)!r} does not exist; start without --resume")
        _check_same_config(run, config, cfg_dict)
        # killed before the first generation's checkpoint: nothing to continue, start it again
        resume = False
    extended: int | None = None
    if resume:
        extended = _check_same_config(run, config, cfg_dict)
        encoder = load_frontend(config, run.path)
        if extended is not None:  # the saved config records the budget the run now has
            saved = run.read_config()
            saved["config"] = cfg_dict
            saved.setdefault("extended_from_generations", []).append(extended)
            write_json(run.path / "config.json", saved)
            print(
                f"extending {str(run.path)!r} from {extended} to "
                f"{config.evolution.generations} generations",
                file=sys.stderr,
            )
    else:
        if ckpt.is_file():
            raise EvodevoError(
                f"{str(run.path)!r} already holds a run; pass --resume to continue it or choose "
                "another --out"
            )
        encoder = make_frontend(config)
        save_frontend(encoder, run.path)
        run.write_config(cfg_dict, kind="grn")
    with (
        GracefulStop() as stop,
        Evaluator(config, encoder, workers=workers, backend=backend, address=address) as evaluator,
    ):
        controller = make_controller(config, evaluator.n_actions)
        # Checkpoint first, then report, then stop cleanly if SIGINT/SIGTERM arrived.
        own: list[Callback] = [Checkpointer(run)]
        if progress:
            own.append(ProgressPrinter())
        own.append(StopOnSignal(stop, run.path))
        evo = Evolution(config, controller, evaluator, [*own, *callbacks])
        if resume:
            evo.load_checkpoint(ckpt)
        evo.run()
    return summarise_evolution(evo)
