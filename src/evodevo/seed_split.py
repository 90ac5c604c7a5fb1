"""Seeds in three disjoint ranges: training, validation and a locked final test (SPEC §6).

Every number evodevo reports names the range its episodes came from:

* **training** — run seeds ``0 .. 9,999``. A run derives its training episodes, its
  exploration and its initial weights from its run seed (:mod:`evodevo.seeding`).
* **validation** — first evaluation seeds ``10,000 .. 999,999``. Everything that tunes, picks
  a champion or a column, or chooses a protocol reads episodes from here only. The seeds
  ``10,000 ..`` on which evodevo's earlier protocols and presets were tuned lie here: numbers
  measured on them are validation numbers.
* **test** — first evaluation seeds ``1,000,000 .. 1,999,999``, locked: only the final tables
  read them. :data:`TEST_SEED` is the default of every command that reports.

A "first seed" is what a config or a command takes (``eval.seed``, ``evaluation.test_seed``,
``--test-seed``): BIARM's episode ``j`` resets with ``first + j``, so ``first .. first + n - 1``
must lie inside one range; a GRN test episode ``i`` resets with ``derive(first, i)``, a hash of
the pair, so there the first seed alone names the range. Training episodes are hashes of the
run seed (32-bit); one lands by chance on a BIARM validation or test reset seed with
probability about 1/4,000 per task, and then only its first reset is shared.

>>> range_of(1_000_000, 20).name
'test'
>>> range_of(20_000, 20).name
'validation'
>>> require_selection(10_000, 20, "eval.validation_seed")
>>> require_selection(1_000_000, 20, "eval.validation_seed")
Traceback (most recent call last):
...
evodevo.seed_split.SeedSplitError: eval.validation_seed=1000000 reads the locked test range (first seeds 1000000..1999999); tuning, champion and column picking may read validation seeds only (10000..999999; SPEC §6)
>>> require_validation(5, 1, "evaluation.validation_seed")
Traceback (most recent call last):
...
evodevo.seed_split.SeedSplitError: evaluation.validation_seed=5 lies in the training range; selection reads validation seeds only (10000..999999; SPEC §6)
"""

from __future__ import annotations

from dataclasses import dataclass

from evodevo.errors import ConfigError

__all__ = [
    "SeedRange",
    "SeedSplitError",
    "TRAINING",
    "VALIDATION",
    "TEST",
    "RANGES",
    "TEST_SEED",
    "VALIDATION_SEED",
    "range_of",
    "range_label",
    "require_selection",
    "require_validation",
]


class SeedSplitError(ConfigError):
    """Seeds that cross the split: selection reading the test range, or a span over two ranges."""


@dataclass(frozen=True)
class SeedRange:
    """A half-open range ``[first, stop)`` of first seeds with a name."""

    name: str
    first: int
    stop: int

    def __contains__(self, seed: object) -> bool:
        return isinstance(seed, int) and self.first <= seed < self.stop

    def describe(self) -> str:
        """``"test (first seeds 1000000..1999999)"``."""
        return f"{self.name} (first seeds {self.first}..{self.stop - 1})"


TRAINING = SeedRange("training", 0, 10_000)
VALIDATION = SeedRange("validation", 10_000, 1_000_000)
TEST = SeedRange("test", 1_000_000, 2_000_000)
RANGES: tuple[SeedRange, ...] = (TRAINING, VALIDATION, TEST)

#: First seed of the locked final test: the default of every command that reports a number.
TEST_SEED = TEST.first
#: First seed of the validation episodes that BIARM's column picking reads by default.
VALIDATION_SEED = 20_000


def range_of(first: int, n: int = 1) -> SeedRange:
    """The range holding the seeds ``first .. first + n - 1``.

    Raises:
        SeedSplitError: the seeds lie beyond every range or span two of them.
    """
    last = int(first) + max(int(n), 1) - 1
    for r in RANGES:
        if int(first) in r:
            if last not in r:
                raise SeedSplitError(
                    f"seeds {first}..{last} span the {r.name} range and the next one; start "
                    f"them at least {n} seeds before {r.stop} or at {r.stop} (SPEC §6)"
                )
            return r
    raise SeedSplitError(
        f"seed {first} lies beyond every range: "
        + ", ".join(r.describe() for r in RANGES)
        + " (SPEC §6)"
    )


def range_label(first: int, n: int = 1) -> str:
    """The range name for a table caption (``"test"``), or ``"outside the split"``."""
    try:
        return range_of(first, n).name
    except SeedSplitError:
        return "outside the split"


def require_selection(first: int, n: int, what: str) -> None:
    """Refuse selection (tuning, champion or column picking, protocol choice) on test seeds.

    Args:
        first: first seed the selection reads.
        n: how many consecutive seeds it reads (1 for a hashed GRN key).
        what: the config key or option, named in the error.

    Raises:
        SeedSplitError: any of the seeds lies in the locked test range.
    """
    last = int(first) + max(int(n), 1) - 1
    if int(first) <= TEST.stop - 1 and last >= TEST.first:
        raise SeedSplitError(
            f"{what}={first} reads the locked test range (first seeds {TEST.first}.."
            f"{TEST.stop - 1}); tuning, champion and column picking may read validation seeds "
            f"only ({VALIDATION.first}..{VALIDATION.stop - 1}; SPEC §6)"
        )


def require_validation(first: int, n: int, what: str) -> None:
    """Selection seeds that lie inside the validation range, nowhere else.

    :func:`require_selection` first (the locked test range is refused with its own message),
    then the training range and seeds beyond every range.

    Raises:
        SeedSplitError: any of the seeds lies outside the validation range.
    """
    require_selection(first, n, what)
    try:
        where = range_of(first, n).name
    except SeedSplitError:
        where = "no range"
    if where != VALIDATION.name:
        raise SeedSplitError(
            f"{what}={first} lies in the {where} range; selection reads validation seeds only "
            f"({VALIDATION.first}..{VALIDATION.stop - 1}; SPEC §6)"
        )
