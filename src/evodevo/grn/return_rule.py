"""Which model a Kuka learner returns: one rule for every learner of a table (SPEC §6).

Three rules, chosen per run (GRN: ``evolution.keep``; Kuka baselines: ``keep.rule``):

* ``last`` — what the run ends with: the GRN's and NEAT's last generation's best by training
  fitness, PPO's and TD3's final model (the thesis);
* ``record`` — the GRN only: the champion by lifetime training record
  (:meth:`evodevo.grn.evolution.Evolution.update_records`);
* ``validated`` — the candidate with the most successes on the same ``V`` greedy validation
  episodes (this module). The candidates are taken at fixed points of training: every
  generation's best by training fitness (GRN, NEAT), a snapshot every ``N`` env steps and the
  final model (PPO, TD3; ``N`` spreads ``keep.candidates`` over the step budget). On a tie the
  later candidate is kept, so a rule that cannot tell the candidates apart returns what
  ``last`` returns. On a task where success is rare or undefined (Pendulum) every candidate
  ties at 0 successes; ``evaluation.validation_score: return`` ranks the candidates by their
  mean validation return instead (GRN runs; the default ``successes`` is the rule above).

The validation episodes are clean, on **training objects**, and reset with
``derive(evaluation.validation_seed, i)``, ``i < evaluation.validation_episodes``: the same for
every candidate and every learner with the same two keys (the defaults are shared), and never
the held-out test objects or a seed outside the validation range
(:func:`evodevo.seed_split.require_validation`). They train
nothing and draw nothing from the training streams; they are counted apart from the training
budget (``validation_episodes`` in ``summary.json`` and the tables), and their time is not
training time.

:class:`ValidatedBest` scores candidates with the GRN's
:class:`~evodevo.grn.evaluator.Evaluator` (which runs GRN genomes, NEAT networks and saved SB3
models alike), keeps the best, writes ``validation.csv`` and saves its state without pickle
(:func:`evodevo.safe_io.save_state`). A learner hands it each candidate with the candidate's
state (a mapping of arrays and strings from which the learner rebuilds it: a GRN genome's
arrays, a NEAT genome's JSON, an SB3 candidate file's name). The state file is written
*before* the learner's own checkpoint, and a resume drops the candidates after the checkpoint
(:meth:`ValidatedBest.load` ``upto``), so a run killed between the two writes, or between
candidates, validates the dropped ones again and returns what an uninterrupted run returns.

>>> keeper = ValidatedBest(20_000, 3, "generation")
>>> [keeper.offer(at, k, {"name": f"g{at}"}) for at, k in [(0, 1), (1, 3), (2, 3), (3, 2)]]
[True, True, True, False]
>>> keeper.best_state, keeper.best_row["at"]
({'name': 'g2'}, 2)
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from evodevo.errors import CheckpointError, ConfigError
from evodevo.grn.config import VALIDATION_SCORES
from evodevo.grn.evaluator import Episode
from evodevo.runs import RunDir
from evodevo.safe_io import load_state, save_state
from evodevo.seed_split import range_label, require_validation
from evodevo.seeding import derive

if TYPE_CHECKING:
    from evodevo.grn.config import GrnConfig

__all__ = [
    "RULES",
    "VALIDATED",
    "SCORES",
    "STATE_FILE",
    "CSV_FILE",
    "CSV_FIELDS",
    "validation_episodes",
    "candidate_every",
    "ValidatedBest",
    "summary_fields",
    "rule_of",
    "describe_rule",
    "validation_of",
    "rules_sentence",
]

VALIDATED = "validated"
RULES = ("last", "record", VALIDATED)
"""Every model-return rule; ``record`` needs a population's lifetime records (the GRN)."""
SCORES = VALIDATION_SCORES
"""What ``validated`` ranks candidates by: validation successes (default) or mean return."""
STATE_FILE = "validation.safetensors"
"""The keeper's state, in the run's ``checkpoints/`` folder."""
CSV_FILE = "validation.csv"
CSV_FIELDS = [
    "candidate",
    "at",
    "successes",
    "mean_return",
    "episodes",
    "env_steps",
    "seconds",
    "kept_at",
    "kept_successes",
]
"""Columns of ``validation.csv``: one row per candidate, the kept one after it."""
_KIND = "validated_best"


def validation_episodes(first_seed: int, n: int) -> list[Episode]:
    """The validation episodes: clean, training objects, seeds ``derive(first_seed, i)``.

    >>> eps = validation_episodes(20_000, 2)
    >>> len(eps), eps[0].test_objects, eps[0].noisy, eps == validation_episodes(20_000, 2)
    (2, False, False, True)
    """
    return [Episode(derive(first_seed, i), noisy=False, test_objects=False) for i in range(n)]


def candidate_every(max_steps: int | None, candidates: int, every_steps: int | None) -> int:
    """Env steps between a step-based learner's candidates (PPO, TD3).

    ``every_steps`` when given, else the step budget spread over ``candidates``.

    >>> candidate_every(13_500, 15, None), candidate_every(None, 15, 500)
    (900, 500)
    """
    if every_steps is not None:
        return int(every_steps)
    if max_steps is None:
        raise ConfigError(
            "keep.rule=validated with a wall-clock budget only needs keep.every_steps (env "
            "steps between candidates); set it, or give budget.env_steps"
        )
    return max(1, math.ceil(int(max_steps) / int(candidates)))


class ValidatedBest:
    """The candidate with the most validation successes so far (the later one on a tie), or
    with ``by="return"`` the highest mean validation return.

    Args:
        first_seed: ``evaluation.validation_seed`` (a GRN-style first seed, hashed with the
            episode index, so it alone names the range: validation only).
        episodes: ``evaluation.validation_episodes``, scored per candidate.
        unit: what a candidate's position ``at`` counts ("generation" or "env_steps").
        by: ``evaluation.validation_score``: "successes" or "return" (:data:`SCORES`).
    """

    def __init__(self, first_seed: int, episodes: int, unit: str, by: str = "successes") -> None:
        require_validation(first_seed, 1, "evaluation.validation_seed")
        if episodes < 1:
            raise ConfigError(f"evaluation.validation_episodes={episodes} must be >= 1")
        if by not in SCORES:
            raise ConfigError(
                f"evaluation.validation_score={by!r} is not one of {', '.join(SCORES)}"
            )
        self.first_seed = int(first_seed)
        self.n = int(episodes)
        self.unit = unit
        self.by = by
        self.episodes = validation_episodes(self.first_seed, self.n)
        self.rows: list[dict[str, Any]] = []
        """One per candidate: its index, position, successes and the kept one after it."""
        self.kept: list[tuple[int, dict[str, Any]]] = []
        """(row, state) of every candidate that was the best when it came and is not pruned:
        the last is the kept one; earlier ones let a resume drop later candidates."""

    # -- choosing ---------------------------------------------------------------------------
    @property
    def best_state(self) -> dict[str, Any] | None:
        """The state of the kept candidate (None before the first)."""
        return self.kept[-1][1] if self.kept else None

    @property
    def best_row(self) -> dict[str, Any] | None:
        """The ``validation.csv`` row of the kept candidate."""
        return self.rows[self.kept[-1][0]] if self.kept else None

    @property
    def episodes_run(self) -> int:
        """Validation episodes run so far (counted apart from the training budget)."""
        return self.n * len(self.rows)

    @property
    def env_steps(self) -> int:
        """Env steps of the validation episodes so far."""
        return sum(int(r["env_steps"]) for r in self.rows)

    @property
    def wall_s(self) -> float:
        """Seconds spent validating so far (not training time)."""
        return sum(float(r["seconds"]) for r in self.rows)

    def score(
        self, evaluator: Any, candidate: Any, config: GrnConfig | None = None
    ) -> tuple[int, int, float, float]:
        """``candidate`` on the validation episodes: successes, env steps, seconds and the
        mean episode return."""
        t0 = time.perf_counter()
        res = evaluator.evaluate([candidate], self.episodes, config=config)
        mean_return = float(res.reward.mean())
        return int(res.success.sum()), int(res.env_steps), time.perf_counter() - t0, mean_return

    def offer(
        self,
        at: int,
        successes: int,
        state: Mapping[str, Any],
        env_steps: int = 0,
        seconds: float = 0.0,
        mean_return: float = math.nan,
    ) -> bool:
        """Count candidate ``at`` with ``successes`` and ``mean_return`` (scored in
        ``env_steps`` and ``seconds``); keep ``state`` if it has the most successes so far, or
        with ``by="return"`` the highest mean return (ties go to this later candidate).
        Returns whether it is kept."""
        best = self.best_row
        if best is None:
            keep = True
        elif self.by == "return":
            kept_return = best["mean_return"]
            keep = kept_return is None or float(mean_return) >= float(kept_return)
        else:
            keep = successes >= int(best["successes"])
        if keep:
            self.kept.append((len(self.rows), dict(state)))
        kept = self.rows[self.kept[-1][0]] if not keep else None
        row = {
            "candidate": len(self.rows),
            "at": int(at),
            "successes": int(successes),
            "mean_return": None if math.isnan(mean_return) else float(mean_return),
            "episodes": self.n,
            "env_steps": int(env_steps),
            "seconds": float(seconds),
            "kept_at": int(at) if keep else int(kept["at"]),  # type: ignore[index]
            "kept_successes": int(successes) if keep else int(kept["successes"]),  # type: ignore[index]
        }
        self.rows.append(row)
        return keep

    def check(
        self,
        evaluator: Any,
        candidate: Any,
        at: int,
        state: Mapping[str, Any],
        config: GrnConfig | None = None,
    ) -> bool:
        """:meth:`score` then :meth:`offer`: whether ``candidate`` is now the kept one."""
        successes, env_steps, seconds, mean_return = self.score(evaluator, candidate, config)
        return self.offer(at, successes, state, env_steps, seconds, mean_return)

    def prune(self, upto: int | None = None) -> list[dict[str, Any]]:
        """Forget superseded states no resume can need; returns them (e.g. files to delete).

        Args:
            upto: the position of the learner's last saved checkpoint (None: every
                candidate is covered by one). The kept state as of ``upto`` and every later
                one stay.
        """
        covered = [
            i
            for i, (row, _) in enumerate(self.kept)
            if upto is None or self.rows[row]["at"] <= upto
        ]
        if not covered:
            return []
        first = covered[-1]
        dropped = [state for _, state in self.kept[:first]]
        self.kept = self.kept[first:]
        return dropped

    # -- files ------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Atomically write the rows and the kept states (:func:`evodevo.safe_io.save_state`)."""
        save_state(
            path,
            _KIND,
            {
                "first_seed": self.first_seed,
                "episodes": self.n,
                "unit": self.unit,
                "by": self.by,
                "rows": self.rows,
                "kept": [[row, state] for row, state in self.kept],
            },
        )

    @classmethod
    def load(
        cls,
        path: str | Path,
        first_seed: int,
        episodes: int,
        unit: str,
        upto: int | None,
        by: str = "successes",
    ) -> ValidatedBest:
        """The keeper saved at ``path``, without the candidates after position ``upto``.

        A missing file is a keeper with no candidate yet. ``upto`` is where the learner's
        checkpoint stands (the last generation or env step it covers; None: keep all).

        Raises:
            CheckpointError: the file is unreadable or was written for other episodes.
        """
        keeper = cls(first_seed, episodes, unit, by)
        if not Path(path).is_file():
            return keeper
        data = load_state(path, _KIND, "validation state", "delete it to validate again")
        if data.get("by", "successes") != by:
            raise CheckpointError(
                f"validation state {str(path)!r} ranks candidates by {data.get('by', 'successes')}, "
                f"not {by}; resume with the run's own config"
            )
        if (data.get("first_seed"), data.get("episodes"), data.get("unit")) != (
            keeper.first_seed,
            keeper.n,
            unit,
        ):
            raise CheckpointError(
                f"validation state {str(path)!r} was written for {data.get('episodes')} "
                f"episodes from seed {data.get('first_seed')}, not {keeper.n} from "
                f"{keeper.first_seed}; resume with the run's own config"
            )
        rows: list[dict[str, Any]] = [{"mean_return": None} | dict(r) for r in data["rows"]]
        keep = len([r for r in rows if upto is None or int(r["at"]) <= upto])
        keeper.rows = rows[:keep]
        keeper.kept = [(int(row), dict(state)) for row, state in data["kept"] if int(row) < keep]
        if keeper.rows and not keeper.kept:
            raise CheckpointError(
                f"validation state {str(path)!r} no longer holds the kept candidate of its "
                f"first {keep} candidates; delete it and start the run again"
            )
        return keeper

    def write_csv(self, run: RunDir) -> None:
        """``validation.csv`` in ``run``: one row per candidate."""
        run.write_csv(CSV_FILE, self.rows, CSV_FIELDS)

    def summary(self) -> dict[str, Any]:
        """What ``summary.json`` records of the selection (``return_rule``)."""
        best = self.best_row
        return {
            "rule": VALIDATED,
            "candidates": len(self.rows),
            "unit": self.unit,
            "episodes_per_candidate": self.n,
            "validation_seed": self.first_seed,
            "seed_range": range_label(self.first_seed),
            "validation_episodes": self.episodes_run,
            "validation_env_steps": self.env_steps,
            "validation_s": self.wall_s,
            "kept_at": None if best is None else int(best["at"]),
            "kept_successes": None if best is None else int(best["successes"]),
            "by": self.by,
            "kept_mean_return": None if best is None else best["mean_return"],
        }


def summary_fields(rule: str, keeper: ValidatedBest | None) -> dict[str, Any]:
    """``return_rule`` and ``validation_episodes`` of a run's ``summary.json``.

    >>> summary_fields("last", None)
    {'return_rule': {'rule': 'last'}, 'validation_episodes': 0}
    """
    if keeper is None:
        return {"return_rule": {"rule": rule}, "validation_episodes": 0}
    return {"return_rule": keeper.summary(), "validation_episodes": keeper.episodes_run}


# -- stating the rule in a table ------------------------------------------------------------
def rule_of(saved: Mapping[str, Any]) -> str:
    """The rule of a run from its ``config.json`` (kind ``grn`` or ``baseline``).

    ``last``, ``record``, ``validated``, ``final pick`` (the GRN's
    ``evolution.final_pick_episodes``) or ``untrained`` (the trivial policies).

    >>> rule_of({"kind": "grn", "config": {"evolution": {"keep": "record"}}})
    'record'
    >>> rule_of({"kind": "baseline", "config": {"method": "zero"}})
    'untrained'
    """
    cfg = saved.get("config") or {}
    if saved.get("kind") == "baseline":
        if cfg.get("method") in ("zero", "random"):
            return "untrained"
        return str((cfg.get("keep") or {}).get("rule", "last"))
    evo = cfg.get("evolution") or {}
    if evo.get("keep", "last") == "last" and int(evo.get("final_pick_episodes", 0) or 0) > 0:
        return "final pick"
    return str(evo.get("keep", "last"))


def describe_rule(saved: Mapping[str, Any], summary: Mapping[str, Any] | None = None) -> str:
    """A table cell naming a run's return rule, read from its ``config.json`` and summary.

    >>> describe_rule({"kind": "baseline", "config": {"method": "ppo"}})
    'last (the final model)'
    >>> describe_rule({"kind": "grn", "config": {"evolution": {"keep": "validated"},
    ...     "evaluation": {"validation_episodes": 20}}}, {"return_rule": {"candidates": 15}})
    'validated (best of 15 candidates on 20 validation episodes)'
    """
    rule = rule_of(saved)
    cfg = saved.get("config") or {}
    step_based = saved.get("kind") == "baseline" and cfg.get("method") != "neat"
    if rule == "last":
        return "last (the final model)" if step_based else "last (last generation's best)"
    if rule == "record":
        return "record (lifetime champion)"
    if rule == "final pick":
        n = (cfg.get("evolution") or {}).get("final_pick_episodes")
        return f"final pick (last elites on {n} training episodes)"
    if rule == VALIDATED:
        v = (cfg.get("evaluation") or {}).get("validation_episodes", 20)
        chosen = (summary or {}).get("return_rule") or {}
        count = chosen.get("candidates")
        of = f"best of {count} candidates" if count is not None else "best candidate"
        return f"validated ({of} on {v} validation episodes)"
    return rule


def validation_of(saved: Mapping[str, Any]) -> tuple[int, int] | None:
    """(episodes per candidate, first seed) of a ``validated`` run's config, else None."""
    if rule_of(saved) != VALIDATED:
        return None
    ev = (saved.get("config") or {}).get("evaluation") or {}
    return int(ev.get("validation_episodes", 20)), int(ev.get("validation_seed", 20_000))


def rules_sentence(saved: Sequence[Mapping[str, Any]]) -> str:
    """The caption's sentence on the return rules of a table's runs (SPEC §6).

    >>> grn = {"kind": "grn", "config": {"evolution": {"keep": "validated"}}}
    >>> ppo = {"kind": "baseline", "config": {"method": "ppo", "keep": {"rule": "validated"}}}
    >>> print(rules_sentence([grn, ppo, {"kind": "baseline", "config": {"method": "zero"}}]))
    Return rule: validated for every trained learner (validated: each generation's best, or for PPO/TD3 a snapshot every N env steps and the final model, scored on the same 20 clean training-object episodes with seeds derive(20000, i), validation range; the most successes kept, the later on a tie; validation episodes are not training budget).
    """
    rules = sorted({rule_of(s) for s in saved} - {"untrained"})
    if not rules:
        return "Return rule: none (untrained policies only)."
    if len(rules) == 1:
        text = f"Return rule: {rules[0]} for every trained learner"
    else:
        text = (
            f"Return rules differ between learners ({', '.join(rules)}; SPEC §6 asks for one "
            "per table): compare the learners with care"
        )
    val = sorted({v for s in saved if (v := validation_of(s)) is not None})
    if val:
        eps = "; ".join(
            f"{n} clean training-object episodes with seeds derive({seed}, i), "
            f"{range_label(seed)} range"
            for n, seed in val
        )
        same = "the same " if len(val) == 1 else "DIFFERENT episodes across runs: "
        text += (
            " (validated: each generation's best, or for PPO/TD3 a snapshot every N env steps "
            f"and the final model, scored on {same}{eps}; the most successes kept, the later on "
            "a tie; validation episodes are not training budget)"
        )
    return text + "."
