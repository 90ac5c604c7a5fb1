"""NEAT of neat-python on the Kuka benchmark (SPEC §4, thesis Table 4.1).

neat-python evolves the networks (front-end features → one tanh output per action);
everything else is the GRN's: the visual front-end (``neat.encoder``: the fixed random CNN of
the run seed, 128 features, ``encoder.pt``; or the vision preset's blob localiser, 4 features,
``frontend.npz``), the :class:`~evodevo.grn.evaluator.Evaluator` and its worker pool,
the training episodes of each generation (common random numbers: every genome sees the same
ones), and Eq. 4.6 as fitness, minus the GRN's shaped term when ``evaluation.distance_weight``
is set (``evaluation.distance_at``, SPEC §2.4).
Training time is the evaluation time of the generations (neat-python's reproduction of 12
genomes takes milliseconds), as for the GRN.

The neat config file is written into the run (``neat.ini``) from :data:`NEAT_TEMPLATE` and the
typed ``neat`` section, so unknown neat keys fail in neat-python and the run records what it used.
After every generation :class:`RunReporter` (a neat-python reporter) writes the population
(``checkpoints/neat-checkpoint-{g}.json``), ``neat_state.json``, ``history.csv``,
``learning_curve.csv``, ``best_genome.json`` and ``summary.json``; ``resume`` restores the last
generation both files agree on. With ``keep.rule: validated`` each generation's best is also
scored on the validation episodes and ``best_genome.json`` is the one with the most successes
(:mod:`evodevo.grn.return_rule`; ``validation.csv``, ``checkpoints/validation.safetensors``). Genomes and populations are JSON
(:mod:`evodevo.baselines.neat_files`), not neat-python's pickles, so a run folder can be opened
without running code from it. neat-python keeps its random state in Python's ``random`` module
(it is seeded through its ``seed`` argument, like SB3's ``seed=``, and saved and restored with
the population).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from evodevo.baselines.kuka_config import KukaBaselineConfig
from evodevo.baselines.neat_files import restore_population, save_population
from evodevo.baselines.policies import NeatNet, neat_config
from evodevo.baselines.sb3_kuka import CURVE_FIELDS, summarise
from evodevo.callbacks import Callback, CallbackList
from evodevo.errors import EvodevoError
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.evolution import EPISODE_KEY, training_episodes
from evodevo.grn.fitness import distance_penalty, fitness_matrix
from evodevo.grn.frontends import frontend_dim, load_frontend, make_frontend, save_frontend
from evodevo.grn.return_rule import STATE_FILE as VALIDATION_FILE
from evodevo.grn.return_rule import VALIDATED, ValidatedBest, summary_fields
from evodevo.runs import RunDir, atomic_write_text, read_json, write_json
from evodevo.safe_io import legacy_error

__all__ = [
    "NEAT_TEMPLATE",
    "write_neat_config",
    "NeatState",
    "RunReporter",
    "NeatFitness",
    "train_neat",
]

NEAT_INI = "neat.ini"
STATE_FILE = "neat_state.json"
CKPT_PREFIX = "neat-checkpoint-"
GENOME_FILE = "best_genome.json"
HISTORY_FIELDS = [
    "generation",
    "best_fitness",
    "mean_fitness",
    "best_success",
    "mean_success",
    "best_connections",
    "episodes",
    "env_steps",
    "elapsed_s",
    "episodes_saved",
]

NEAT_TEMPLATE = """\
[NEAT]
fitness_criterion      = max
fitness_threshold      = 1e9
no_fitness_termination = True
pop_size               = {population}
reset_on_extinction    = True

[DefaultGenome]
num_inputs              = {num_inputs}
num_outputs             = {num_outputs}
num_hidden              = 0
feed_forward            = True
initial_connection      = {initial_connection}
activation_default      = tanh
activation_mutate_rate  = 0.0
activation_options      = tanh
aggregation_default     = sum
aggregation_mutate_rate = 0.0
aggregation_options     = sum
bias_init_mean          = 0.0
bias_init_stdev         = 1.0
bias_max_value          = 30.0
bias_min_value          = -30.0
bias_mutate_power       = 0.5
bias_mutate_rate        = 0.7
bias_replace_rate       = 0.1
response_init_mean      = 1.0
response_init_stdev     = 0.0
response_max_value      = 30.0
response_min_value      = -30.0
response_mutate_power   = 0.0
response_mutate_rate    = 0.0
response_replace_rate   = 0.0
weight_init_mean        = 0.0
weight_init_stdev       = 1.0
weight_max_value        = 30.0
weight_min_value        = -30.0
weight_mutate_power     = {weight_mutate_power}
weight_mutate_rate      = {weight_mutate_rate}
weight_replace_rate     = 0.1
enabled_default         = True
enabled_mutate_rate     = 0.01
compatibility_disjoint_coefficient = 1.0
compatibility_weight_coefficient   = 0.5
conn_add_prob           = {conn_add_prob}
conn_delete_prob        = 0.3
node_add_prob           = {node_add_prob}
node_delete_prob        = 0.1

[DefaultSpeciesSet]
compatibility_threshold = {compatibility_threshold}

[DefaultStagnation]
species_fitness_func = max
max_stagnation       = 20
species_elitism      = 1

[DefaultReproduction]
elitism            = {elitism}
survival_threshold = 0.3
"""
"""neat-python config of the Kuka NEAT baseline; ``{...}`` fields come from the typed config."""


def write_neat_config(cfg: KukaBaselineConfig, n_actions: int, run: RunDir) -> str:
    """Write ``neat.ini`` for ``cfg`` into ``run`` and return its path."""
    n = cfg.neat
    text = NEAT_TEMPLATE.format(
        population=n.population,
        num_inputs=frontend_dim(n.encoder),
        num_outputs=n_actions,
        initial_connection=n.initial_connection,
        weight_mutate_power=n.weight_mutate_power,
        weight_mutate_rate=n.weight_mutate_rate,
        conn_add_prob=n.conn_add_prob,
        node_add_prob=n.node_add_prob,
        compatibility_threshold=n.compatibility_threshold,
        elitism=n.elitism,
    )
    path = run / NEAT_INI
    atomic_write_text(path, text)
    return str(path)


@dataclass
class NeatState:
    """Bookkeeping of a NEAT run across generations (and resumes)."""

    generation: int = 0
    env_steps: int = 0
    episodes: int = 0
    episodes_saved: int = 0
    """Episodes copied from an identical network instead of run (``evaluation.dedupe``)."""
    train_s: float = 0.0
    history: list[dict[str, Any]] = field(default_factory=list)
    best: Any = None


class RunReporter:
    """neat-python reporter: after every generation, checkpoint and run-directory files."""

    def __init__(
        self,
        run: RunDir,
        cfg: KukaBaselineConfig,
        state: NeatState,
        quiet: bool,
        callback: Callback | None = None,
        population: Any = None,
        keeper: ValidatedBest | None = None,
    ):
        self.run = run
        self.cfg = cfg
        self.state = state
        self.quiet = quiet
        self.callback = callback if callback is not None else Callback()
        self.population = population
        """The ``neat.Population`` whose state every checkpoint saves."""
        self.keeper = keeper
        """``keep.rule: validated``: the kept candidate (saved before the checkpoint)."""

    # neat-python's reporter hooks (BaseReporter interface)
    def start_generation(self, generation: int) -> None:
        """Unused hook."""

    def post_evaluate(self, config: Any, population: Any, species: Any, best: Any) -> None:
        """Unused hook."""

    def post_reproduction(self, config: Any, population: Any, species: Any) -> None:
        """Unused hook."""

    def complete_extinction(self) -> None:
        """Unused hook."""

    def found_solution(self, config: Any, generation: int, best: Any) -> None:
        """Unused hook."""

    def species_stagnant(self, sid: int, species: Any) -> None:
        """Unused hook."""

    def info(self, msg: str) -> None:
        """Unused hook."""

    def end_generation(self, config: Any, population: Any, species_set: Any) -> None:
        """Save the population of the next generation, then the state and outputs."""
        nxt = self.state.generation
        folder = self.run.checkpoints
        if self.keeper is not None:  # first: a resume drops what the checkpoint does not cover
            self.keeper.save(folder / VALIDATION_FILE)
        save_population(folder / f"{CKPT_PREFIX}{nxt}.json", self.population, nxt)
        write_json(
            folder / STATE_FILE,
            {
                "generation": nxt,
                "env_steps": self.state.env_steps,
                "episodes": self.state.episodes,
                "episodes_saved": self.state.episodes_saved,
                "train_s": self.state.train_s,
                "history": self.state.history,
            },
        )
        if self.keeper is not None:
            self.keeper.prune()
        for old in folder.glob(f"{CKPT_PREFIX}*.json"):  # keep this one and the one before
            suffix = old.name[len(CKPT_PREFIX) : -len(".json")]
            if suffix.isdigit() and int(suffix) < nxt - 1:
                old.unlink(missing_ok=True)
        self.write_outputs()
        h = self.state.history[-1]
        self.callback.on_generation(h)
        self.callback.on_curve_row(curve_rows([h])[0])
        self.callback.on_steps(self.state.env_steps)
        if not self.quiet:
            print(
                f"gen {h['generation'] + 1:>3} best F {h['best_fitness']:6.2f} "
                f"best success {h['best_success']:.2f} steps {h['env_steps']} "
                f"training {h['elapsed_s']:.0f}s",
                file=sys.stderr,
                flush=True,
            )

    def write_outputs(self) -> None:
        """``history.csv``, ``learning_curve.csv``, ``best_genome.json``, ``summary.json``."""
        self.run.write_csv("history.csv", self.state.history, HISTORY_FIELDS)
        self.run.write_csv("learning_curve.csv", curve_rows(self.state.history), CURVE_FIELDS)
        returned = self.state.best
        if self.keeper is not None:
            self.keeper.write_csv(self.run)
            kept = self.keeper.best_state
            if kept is not None:
                returned = NeatNet(str(kept["genome"]), str(self.run / NEAT_INI))
        if returned is not None:
            returned.save(self.run / GENOME_FILE)
        self.run.write_summary(neat_summary(self.cfg, self.state, self.keeper))


def curve_rows(history: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Learning-curve rows (as the SB3 runs') from the per-generation history."""
    return [
        {
            "env_steps": h["env_steps"],
            "train_s": h["elapsed_s"],
            "success": h["best_success"],
            "mean_reward": float("nan"),
            "episodes": h["episodes"],
        }
        for h in history
    ]


def neat_summary(
    cfg: KukaBaselineConfig, state: NeatState, keeper: ValidatedBest | None = None
) -> dict[str, Any]:
    """``summary.json`` of a NEAT run (written after every generation).

    ``"done": false`` and ``"stopped_by": "running"`` until the budget is spent, so a run
    killed mid-way is resumed by ``evodevo reproduce``, not taken as finished.
    """
    out = summarise(cfg, state.env_steps, state.train_s, 0.0, curve_rows(state.history), "")
    out |= summary_fields(cfg.keep.rule, keeper)
    reason = _stop_reason(cfg, state)
    out["stopped_by"] = reason or "running"
    out["done"] = reason is not None
    out["generations_run"] = state.generation
    out["episodes_run"] = state.episodes
    out["episodes_saved"] = state.episodes_saved
    out["budget"]["generations"] = cfg.neat.generations
    out["budget"]["population"] = cfg.neat.population
    out["budget"]["episodes_per_evaluation"] = cfg.neat.episodes
    return out


def _stop_reason(cfg: KukaBaselineConfig, state: NeatState) -> str | None:
    b = cfg.budget
    if b.env_steps is not None and state.env_steps >= b.env_steps:
        return "steps"
    if b.minutes is not None and state.train_s >= b.minutes * 60.0:
        return "time"
    if b.env_steps is None and b.minutes is None and state.generation >= cfg.neat.generations:
        return "generations"
    return None


def _restore(run: RunDir) -> tuple[Any, NeatState]:
    folder = run.path / "checkpoints"
    if not (folder / STATE_FILE).is_file():
        raise EvodevoError(
            f"--resume: {str(folder / STATE_FILE)!r} does not exist; start again without --resume"
        )
    saved = read_json(folder / STATE_FILE)
    gen = int(saved["generation"])
    ckpt = folder / f"{CKPT_PREFIX}{gen}.json"
    if not ckpt.is_file() and (folder / ckpt.stem).is_file():
        raise legacy_error(folder / ckpt.stem, "a pickled neat-python checkpoint")
    if not ckpt.is_file():
        raise EvodevoError(f"--resume: the neat checkpoint {str(ckpt)!r} is missing")
    pop, saved_gen = restore_population(ckpt, neat_config(run / NEAT_INI))
    if saved_gen != gen:
        raise EvodevoError(
            f"--resume: {str(ckpt)!r} holds generation {saved_gen}, {STATE_FILE} says {gen}; "
            "the run folder was edited: start the run again"
        )
    state = NeatState(
        generation=gen,
        env_steps=int(saved["env_steps"]),
        episodes=int(saved["episodes"]),
        episodes_saved=int(saved.get("episodes_saved", 0)),
        train_s=float(saved["train_s"]),
        history=list(saved["history"]),
    )
    if (run / GENOME_FILE).is_file() or (run / GENOME_FILE).with_suffix(".pkl").is_file():
        state.best = NeatNet.load(run / GENOME_FILE, run / NEAT_INI)
    return pop, state


class NeatFitness:
    """neat-python's fitness function: a generation's networks scored by the GRN's evaluator.

    Every network meets the generation's training episodes (common random numbers); fitness is
    Eq. 4.6, minus ``evaluation.distance_weight`` times the shaped distance term when that is
    set (SPEC §2.4). Each call books the generation into ``state`` (steps, episodes, training
    time, the history row) and, with ``keeper``, scores its best network on the validation
    episodes after the clock (validation is not training time).
    """

    def __init__(
        self,
        cfg: KukaBaselineConfig,
        evaluator: Evaluator,
        ini: str,
        state: NeatState,
        keeper: ValidatedBest | None,
    ) -> None:
        self.cfg = cfg
        self.weight = evaluator.config.evaluation.distance_weight
        self.evaluator = evaluator
        self.ini = ini
        self.state = state
        self.keeper = keeper

    def __call__(self, genomes: list[tuple[int, Any]], config: Any) -> None:
        cfg, state, weight = self.cfg, self.state, self.weight
        t0 = time.perf_counter()
        episodes = training_episodes(
            cfg.seed, EPISODE_KEY, state.generation, cfg.neat.episodes, cfg.neat.noisy_fraction
        )
        nets = [NeatNet.from_genome(g, self.ini) for _, g in genomes]
        res = self.evaluator.evaluate(nets, episodes, measure_distance=weight > 0)
        fit = fitness_matrix(res.reward, res.success)
        if weight > 0 and res.distance is not None:
            fit = fit - weight * distance_penalty(res.distance)
        for (_, g), f in zip(genomes, fit, strict=True):
            g.fitness = float(f)
        best = int(np.argmax(fit))
        state.best = nets[best]
        state.env_steps += res.env_steps
        state.episodes += int(res.reward.size)
        state.episodes_saved += res.episodes_saved
        state.train_s += time.perf_counter() - t0
        if self.keeper is not None:  # after the clock: validation is not training time
            self.keeper.check(
                self.evaluator, nets[best], state.generation, {"genome": nets[best].genome}
            )
        state.history.append(_history_row(state, fit, res.success_rate, best, genomes[best][1]))
        state.generation += 1


def _history_row(
    state: NeatState, fit: np.ndarray, success: np.ndarray, best: int, genome: Any
) -> dict[str, Any]:
    """The ``history.csv`` row of the generation just scored (``best``: the index of its best
    genome, ``genome``)."""
    return {
        "generation": state.generation,
        "best_fitness": float(fit[best]),
        "mean_fitness": float(fit.mean()),
        "best_success": float(success[best]),
        "mean_success": float(success.mean()),
        "best_connections": sum(1 for c in genome.connections.values() if c.enabled),
        "episodes": state.episodes,
        "env_steps": state.env_steps,
        "elapsed_s": state.train_s,
        "episodes_saved": state.episodes_saved,
    }


def _keeper(cfg: KukaBaselineConfig, run: RunDir, state: NeatState) -> ValidatedBest | None:
    """``keep.rule: validated``: the kept candidate so far (resumed: without the generations
    to evaluate again); None for ``keep.rule: last``."""
    if cfg.keep.rule != VALIDATED:
        return None
    v = cfg.evaluation
    return ValidatedBest.load(
        run.checkpoints / VALIDATION_FILE,
        v.validation_seed,
        v.validation_episodes,
        "generation",
        upto=state.generation - 1,
    )


def train_neat(
    cfg: KukaBaselineConfig,
    run: RunDir,
    workers: int = 1,
    resume: bool = False,
    quiet: bool = False,
    backend: str = "local",
    address: str | None = None,
    callback: Callback | None = None,
) -> dict[str, Any]:
    """Evolve NEAT networks per ``cfg`` in run directory ``run``; returns ``summary.json``'s dict.

    Genomes are scored by the GRN's :class:`~evodevo.grn.evaluator.Evaluator` over ``workers``
    processes (``backend="local"``) or Ray actors (``backend="ray"``, cluster ``address``).

    Budget: ``budget.env_steps`` and/or ``budget.minutes`` (checked after every generation, so a
    run ends within one generation past it), else ``neat.generations``. ``callback`` hears every
    generation's history and learning-curve rows once they are written.
    """
    import neat  # optional dependency: neat

    callback = callback if callback is not None else CallbackList()
    callback.init(run)

    ecfg = cfg.evaluator_config()
    # A run killed before its first generation's checkpoint has nothing to continue: start it.
    resume = resume and (run.path / "checkpoints" / STATE_FILE).is_file()
    if resume:
        encoder = load_frontend(ecfg, run.path)
    else:
        encoder = make_frontend(ecfg, cfg.seed)
        save_frontend(encoder, run.path)
    with Evaluator(ecfg, encoder, workers=workers, backend=backend, address=address) as ev:
        if resume:
            pop, state = _restore(run)
            ini = str(run / NEAT_INI)
        else:
            ini = write_neat_config(cfg, ev.n_actions, run)
            pop = neat.Population(neat_config(ini), seed=cfg.seed)
            state = NeatState()
        keeper = _keeper(cfg, run, state)
        reporter = RunReporter(run, cfg, state, quiet, callback, population=pop, keeper=keeper)
        pop.add_reporter(reporter)
        callback.on_steps(state.env_steps)
        fitness = NeatFitness(cfg, ev, ini, state, keeper)
        while _stop_reason(cfg, state) is None:
            pop.run(fitness, 1)
        reporter.write_outputs()
    return neat_summary(cfg, state, keeper)
