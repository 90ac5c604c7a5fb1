"""Config loading, stats and the worker pool (shared foundation)."""

from __future__ import annotations

import itertools
import os
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pytest

from evodevo.config import doc, from_dict, load_config
from evodevo.errors import ConfigError, EvodevoError
from evodevo.parallel import WorkerPool
from evodevo.runs import RunDir, read_json
from evodevo.stats import (
    bootstrap_ci,
    fisher_exact,
    permutation_test,
    summarise,
    wilson_interval,
)


@dataclass
class Inner:
    rate: float = doc(0.1, "a rate")

    def validate(self) -> None:
        if not 0 <= self.rate <= 1:
            raise ConfigError(f"rate={self.rate} must lie in [0, 1]")


@dataclass
class Outer:
    n: int = doc(3, "a count")
    mode: Literal["a", "b"] = doc("a", "a mode")
    inner: Inner = field(default_factory=Inner)
    names: list[str] = doc(["x"], "names")


def test_from_dict_nested_and_types():
    cfg = from_dict(Outer, {"n": 5, "inner": {"rate": 0.5}, "names": "p,q"})
    assert cfg.n == 5 and cfg.inner.rate == 0.5 and cfg.names == ["p", "q"]


@pytest.mark.parametrize(
    "data, word",
    [
        ({"nn": 1}, "nn"),
        ({"inner": {"rte": 1}}, "inner.rte"),
        ({"n": "three"}, "n"),
        ({"n": 1.5}, "n"),
        ({"mode": "c"}, "mode"),
        ({"inner": {"rate": 2.0}}, "rate=2.0"),
    ],
)
def test_bad_values_name_the_key(data, word):
    with pytest.raises(ConfigError, match=word.replace(".", r"\.")):
        from_dict(Outer, data)


def test_load_config_file_errors(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_config(Outer, tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("n: [1,\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(Outer, bad)
    good = tmp_path / "good.yaml"
    good.write_text("n: 7\ninner:\n  rate: 0.2\n")
    cfg = load_config(Outer, good, {"inner": {"rate": 0.3}})
    assert cfg.n == 7 and cfg.inner.rate == 0.3


def test_wilson_hand_worked():
    # p = 0.5, n = 100: centre 0.5, half-width 1.96*sqrt(.25/100 + 1.96^2/40000)/(1+1.96^2/100)
    lo, hi = wilson_interval(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-4) and hi == pytest.approx(0.5962, abs=1e-4)
    assert wilson_interval(0, 10)[0] == pytest.approx(0.0, abs=1e-12)
    assert wilson_interval(10, 10)[1] == pytest.approx(1.0)


def test_bootstrap_and_summary():
    lo, hi = bootstrap_ci([1.0, 2.0, 3.0, 4.0], seed=1)
    # the exact bootstrap distribution: the mean of 4 draws with replacement, all 4**4 equally
    # likely; its 2.5 % and 97.5 % quantiles are 1.5 and 3.5 (means lie on a 0.25 grid)
    means = np.sort([np.mean(c) for c in itertools.product([1.0, 2.0, 3.0, 4.0], repeat=4)])
    exact = (np.quantile(means, 0.025), np.quantile(means, 0.975))
    assert exact == (1.5, 3.5)
    assert abs(lo - exact[0]) <= 0.25 and abs(hi - exact[1]) <= 0.25
    s = summarise([1.0, 3.0])
    assert s.mean == 2.0 and s.std == pytest.approx(1.4142, abs=1e-4) and s.n == 2


def test_fisher_exact_extreme():
    assert fisher_exact(10, 10, 0, 10) < 1e-4
    assert fisher_exact(5, 10, 5, 10) == pytest.approx(1.0)


def test_paired_sign_flip_is_exact_for_few_pairs():
    # 3 pairs, all differences positive: of the 8 sign patterns only the two with all signs
    # equal reach |mean| = observed, so p = 2/8 (the smallest p three seeds can give).
    assert permutation_test([3.0, 5.0, 4.0], [1.0, 1.0, 1.0], paired=True) == 0.25
    # differences 2, 2, -1 (sum 3): sign patterns give sums ±5, ±3, ±1, ±1; four of the
    # eight reach |sum| >= 3, p = 0.5
    assert permutation_test([3.0, 3.0, 0.0], [1.0, 1.0, 1.0], paired=True) == 0.5
    # identical samples: every pattern ties, p = 1
    assert permutation_test([1.0, 2.0], [1.0, 2.0], paired=True) == 1.0


def test_rundir_roundtrip(tmp_path):
    run = RunDir(tmp_path / "r")
    run.write_config({"a": 1}, kind="test")
    run.write_csv("m.csv", [{"x": 1, "y": 2}])
    assert run.read_config()["config"] == {"a": 1}
    assert run.read_csv("m.csv") == [{"x": "1", "y": "2"}]
    (tmp_path / "r" / "summary.json").write_text("{trunc")
    with pytest.raises(EvodevoError, match="corrupt"):
        read_json(tmp_path / "r" / "summary.json")


def _die_once(x: int) -> int:
    marker = f"{os.environ['EVODEVO_TEST_MARK']}.{x}"
    if x == 2 and not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)  # simulate a killed worker
    return x * x


def test_pool_survives_a_dead_worker(tmp_path, monkeypatch):
    monkeypatch.setenv("EVODEVO_TEST_MARK", str(tmp_path / "mark"))
    with WorkerPool(2, max_retries=1) as pool:
        assert pool.map(_die_once, [0, 1, 2, 3]) == [0, 1, 4, 9]
        assert pool.restarts >= 1


def _always_die(x: int) -> int:
    os._exit(1)


def test_pool_gives_up_with_clear_error():
    with (
        WorkerPool(2, max_retries=1) as pool,
        pytest.raises(EvodevoError, match="gave up|giving up"),
    ):
        pool.map(_always_die, [1])


def _square(x: int) -> int:
    return x * x


def _ray_die_once(x: int) -> int:
    marker = f"{os.environ.get('EVODEVO_TEST_MARK', '/tmp/evodevo-ray')}.{x}"
    if x == 1 and not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return x * x


def _niceness(_: int) -> int:
    """The process' nice value as ``ps`` shows it (``os.nice(0)`` reads only this thread's)."""
    with open(f"/proc/{os.getpid()}/stat") as fh:
        return int(fh.read().rsplit(")", 1)[1].split()[16])


def test_ray_pool_matches_local_and_survives_dead_actor(tmp_path, monkeypatch):
    pytest.importorskip("ray")
    from evodevo.parallel import make_pool

    monkeypatch.setenv("EVODEVO_TEST_MARK", str(tmp_path / "mark"))
    with make_pool("local", 1) as local:
        expected = local.map(_square, range(5))
    with make_pool("ray", 2) as pool:
        assert pool.map(_square, range(5)) == expected
        assert pool.map(_ray_die_once, [0, 1, 2]) == [0, 1, 4]
        assert pool.restarts >= 1
        # Ray's default would renice its workers to 15 (starved beside any busy process)
        if os.path.exists("/proc/self/stat"):
            assert pool.map(_niceness, [0, 1]) == [_niceness(0)] * 2


def test_make_pool_rejects_unknown_backend():
    from evodevo.parallel import make_pool

    with pytest.raises(EvodevoError, match="unknown backend"):
        make_pool("dask", 2)


def test_graceful_stop_turns_first_signal_into_a_flag():
    import signal

    from evodevo.signals import GracefulStop, StopRequested

    before = signal.getsignal(signal.SIGTERM)
    with GracefulStop() as stop:
        stop.check("generation 1", "resume with --resume")  # nothing requested: no error
        os.kill(os.getpid(), signal.SIGTERM)
        assert stop.requested and stop.signal_name == "SIGTERM"
        with pytest.raises(StopRequested, match="after generation 2; resume with --resume"):
            stop.check("generation 2", "resume with --resume")
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is before
