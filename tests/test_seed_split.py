"""Seeds in three disjoint ranges (SPEC §6): reported numbers read the locked test range,
everything that selects reads validation seeds only, and a selection that reads the test range
is refused."""

from __future__ import annotations

import pytest
import torch

from evodevo.config import from_dict
from evodevo.errors import ConfigError
from evodevo.grn.config import GrnConfig
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.config import BiarmConfig, EvalConfig
from evodevo.neuromod.protocol_sweep import SweepSpec
from evodevo.neuromod.variants import get_variant
from evodevo.seed_split import (
    TEST,
    TEST_SEED,
    TRAINING,
    VALIDATION,
    SeedSplitError,
    range_label,
    range_of,
    require_selection,
)


def test_ranges_are_disjoint_and_ordered() -> None:
    assert TRAINING.stop == VALIDATION.first
    assert VALIDATION.stop == TEST.first
    assert TEST_SEED in TEST
    assert range_of(0).name == "training"
    assert range_of(10_000, 20).name == "validation"
    assert range_of(TEST_SEED, 20).name == "test"
    assert range_label(5_000_000) == "outside the split"


def test_a_span_across_two_ranges_is_refused() -> None:
    with pytest.raises(SeedSplitError, match="span the validation range"):
        range_of(999_990, 20)


@pytest.mark.parametrize("first", [TEST.first, TEST.first + 500, TEST.first - 5])
def test_selection_on_the_test_range_is_refused(first: int) -> None:
    with pytest.raises(SeedSplitError, match="locked test range"):
        require_selection(first, 20, "some.key")


def test_biarm_reports_on_the_test_range_and_picks_columns_on_validation() -> None:
    cfg = BiarmConfig()
    assert range_of(cfg.eval.seed, cfg.eval.episodes) is TEST
    assert range_of(cfg.eval.validation_seed, cfg.eval.validation_episodes) is VALIDATION
    assert cfg.eval.seed_range == "test"


def test_biarm_column_picking_on_test_seeds_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="eval.validation_seed=1000000"):
        from_dict(EvalConfig, {"seed": 10_000, "validation_seed": TEST_SEED}).validate()


def test_grn_tests_on_the_locked_range_by_default() -> None:
    assert GrnConfig().evaluation.test_seed in TEST


def test_the_protocol_sweep_reads_validation_seeds_and_refuses_the_test_range() -> None:
    spec = SweepSpec.from_dict(
        {"protocols": {"a": {}}, "tasks": ["CartPole-v1"], "variants": ["pnn"], "seeds": "0"}
    )
    assert range_of(spec.run_config("a", "CartPole-v1").eval.seed, 20) is VALIDATION
    bad = SweepSpec.from_dict(
        {
            "protocols": {"peek": {"eval": {"seed": TEST_SEED}}},
            "tasks": ["CartPole-v1"],
            "variants": ["pnn"],
            "seeds": "0",
        }
    )
    with pytest.raises(SeedSplitError, match="protocol 'peek' eval.seed"):
        bad.run_config("peek", "CartPole-v1")


@pytest.mark.parametrize(("variant", "reads_earlier"), [("single", False), ("pnn", True)])
def test_the_single_task_reference_reads_nothing_from_earlier_columns(
    variant: str, reads_earlier: bool
) -> None:
    """Changing column 1 changes column 2's Q-values under PNN, never under ``single``."""
    cfg = BiarmConfig()
    cfg.network.lateral_init = "xavier"  # non-zero laterals from the start
    cfg.network.lateral_scale = 1.0
    x = torch.linspace(-1, 1, 8).reshape(1, 8)
    qs = []
    for shift in (0.0, 0.5):
        agent = BiarmAgent(cfg, get_variant(variant), obs_dim=8, seed=0)
        agent.begin_task(2)
        with torch.no_grad():
            for p in agent.net.parameters():
                p.add_(shift)
        agent.begin_task(3)
        qs.append(agent.greedy_q(x, 1).clone())
    assert (not torch.equal(qs[0], qs[1])) is reads_earlier
