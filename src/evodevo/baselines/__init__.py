"""Baselines of SPEC §4 on the Kuka grasping benchmark, and the thesis' Table 4.2.

* :mod:`~evodevo.baselines.kuka_config` — the typed config (Table 4.1 defaults).
* :mod:`~evodevo.baselines.sb3_kuka` — PPO and TD3 of Stable-Baselines3 on the image.
* :mod:`~evodevo.baselines.neat_kuka` — NEAT of neat-python on the GRN's encoder features.
* :mod:`~evodevo.baselines.policies` — trained baselines as policies of the GRN evaluator.
* :mod:`~evodevo.baselines.kuka_runner` — run directories: train, resume, load for evaluation.
* :mod:`~evodevo.baselines.table_4_2` — the comparison table (Markdown and CSV).
* :mod:`~evodevo.baselines.sb3_dqn_tasks` — BIARM's ``sb3-dqn`` baseline: an SB3 DQN per task.
* :mod:`~evodevo.baselines.kuka_cnn` — the Table 4.1 image encoder of PPO and TD3.
* :mod:`~evodevo.baselines.sb3_files` — SB3 models and replay buffers saved without pickle.
* :mod:`~evodevo.baselines.neat_files` — NEAT genomes and populations as JSON.

Importing the package registers what the methods look up by name, so the methods never import
their baselines (the dependency points from here to them): BIARM's ``sb3`` trainer
(:mod:`evodevo.trainers`), the Kuka baselines' controllers and the scripted reference policies
(:mod:`evodevo.grn.controller`), and the loader of ``baseline`` runs that ``grn evaluate``
tests (:mod:`evodevo.grn.evaluation`). Stable-Baselines3 and sb3-contrib are optional: the
functions below import them when called.
"""

from __future__ import annotations

from typing import Any

from evodevo.baselines.kuka_runner import load_run
from evodevo.baselines.policies import (
    NeatPolicy,
    RememberingScriptedPolicy,
    Sb3Policy,
    ScriptedPolicy,
)
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import register_baseline, register_controller
from evodevo.grn.evaluation import register_run_loader
from evodevo.trainers import register_trainer

__all__ = ["train_sb3_dqn", "recurrent_ppo_policy"]


def train_sb3_dqn(*args: Any, **kwargs: Any) -> dict[str, Any]:
    """BIARM's ``sb3-dqn`` variant: :func:`evodevo.baselines.sb3_dqn_tasks.train_sb3_tasks`."""
    from evodevo.baselines.sb3_dqn_tasks import train_sb3_tasks  # optional dependency: SB3

    return train_sb3_tasks(*args, **kwargs)


def recurrent_ppo_policy(config: GrnConfig, n_actions: int) -> Any:
    """The controller of a RecurrentPPO run (:class:`~evodevo.baselines.recurrent_ppo.RecurrentPpoPolicy`)."""
    from evodevo.baselines.recurrent_ppo import (
        RecurrentPpoPolicy,  # optional dependency: sb3-contrib
    )

    return RecurrentPpoPolicy(config, n_actions)


register_trainer("sb3", train_sb3_dqn)
register_controller("sb3", Sb3Policy)
register_controller("neat", NeatPolicy)
register_controller("recurrent_ppo", recurrent_ppo_policy)
register_baseline("scripted", ScriptedPolicy)
register_baseline("scripted_memory", RememberingScriptedPolicy)
register_run_loader("baseline", load_run)
