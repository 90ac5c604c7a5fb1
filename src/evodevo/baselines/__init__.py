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
"""

from evodevo.trainers import register_trainer

# BIARM's sb3-dqn variant (architecture "sb3") is trained here, not by the method's trainer
register_trainer("sb3", "evodevo.baselines.sb3_dqn_tasks:train_sb3_tasks")
