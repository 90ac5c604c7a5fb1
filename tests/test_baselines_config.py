"""The baselines' typed config: Table 4.1 defaults, the shipped YAML, errors naming the key."""

from __future__ import annotations

from pathlib import Path

import pytest

import evodevo.baselines  # noqa: F401  (registers the baselines' controllers)
from evodevo.baselines.kuka_config import CONTROLLERS, METHODS, KukaBaselineConfig
from evodevo.config import load_config, to_dict
from evodevo.errors import ConfigError
from evodevo.grn.controller import controller_names
from evodevo.seed_split import TEST_SEED

ROOT = Path(__file__).resolve().parents[1]


def test_table_4_1_defaults_and_the_shipped_yaml_agree():
    cfg = KukaBaselineConfig()
    assert (cfg.ppo.ent_coef, cfg.ppo.gamma, cfg.ppo.clip_range, cfg.ppo.learning_rate) == (
        0.01,
        0.993,
        0.07,
        2e-4,
    )
    assert (cfg.td3.buffer_size, cfg.td3.batch_size, cfg.td3.actor_lr, cfg.td3.critic_lr) == (
        50_000,
        128,
        1e-4,
        1e-3,
    )
    assert (cfg.neat.population, cfg.neat.generations, cfg.neat.weight_mutate_rate) == (12, 15, 0.8)
    shipped = load_config(KukaBaselineConfig, ROOT / "configs" / "baselines_kuka.yaml")
    assert to_dict(shipped) == to_dict(cfg)


@pytest.mark.parametrize("method", METHODS)
def test_each_method_evaluates_with_the_grn_test_seeds(method):
    cfg = KukaBaselineConfig(method=method)
    ev = cfg.evaluator_config()
    assert ev.controller == CONTROLLERS[method] and ev.controller in controller_names()
    assert ev.evaluation.test_seed == TEST_SEED and ev.env.kwargs == {"max_steps": 8}


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"method": "sac"}, "method: 'sac' is not accepted"),
        ({"budget": {"env_steps": 0}}, "env_steps=0 must be > 0"),
        ({"budget": {"minutes": -2}}, "minutes=-2.0 must be > 0"),
        ({"ppo": {"gamma": 1.5}}, "gamma=1.5 must lie in"),
        ({"neat": {"population": 1}}, "population=1 must be >= 2"),
        ({"td3": {"lr": 1e-3}}, "unknown config key td3.lr"),
    ],
)
def test_bad_values_name_the_key(overrides, message):
    with pytest.raises(ConfigError, match=message):
        load_config(KukaBaselineConfig, None, overrides)


@pytest.mark.parametrize("path", sorted((ROOT / "configs").glob("baselines_kuka*.yaml")))
def test_every_shipped_baseline_config_loads(path):
    cfg = load_config(KukaBaselineConfig, path)
    assert cfg.ppo.gamma == 0.993 and cfg.td3.actor_lr == 1e-4  # Table 4.1 kept in every variant
