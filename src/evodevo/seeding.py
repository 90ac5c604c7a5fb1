"""Seeds without global state: every stochastic part gets its own generator from the run seed.

Library code never calls ``np.random.seed``/``torch.manual_seed``; it derives independent
streams with :func:`child_seeds` (``numpy.random.SeedSequence``) and passes generators down.

>>> child_seeds(0, 3) == child_seeds(0, 3)
True
"""

from __future__ import annotations

import numpy as np
import torch

from evodevo.errors import EvodevoError

__all__ = ["child_seeds", "np_rng", "torch_gen", "derive", "parse_seeds"]


def child_seeds(seed: int, n: int, *key: int) -> list[int]:
    """``n`` independent 32-bit seeds derived from ``seed`` (and an optional integer ``key`` path)."""
    ss = np.random.SeedSequence([int(seed), *map(int, key)])
    return [int(s.generate_state(1)[0]) for s in ss.spawn(n)]


def derive(seed: int, *key: int) -> int:
    """One 32-bit seed derived from ``seed`` and an integer key path."""
    return int(np.random.SeedSequence([int(seed), *map(int, key)]).generate_state(1)[0])


def np_rng(seed: int, *key: int) -> np.random.Generator:
    """A NumPy generator for ``seed`` (and key path)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), *map(int, key)]))


def torch_gen(seed: int, *key: int) -> torch.Generator:
    """A CPU torch generator for ``seed`` (and key path)."""
    g = torch.Generator()
    g.manual_seed(derive(seed, *key))
    return g


def parse_seeds(text: str, name: str = "--seeds") -> list[int]:
    """A seed list as written in a config or on the command line.

    ``"0-4"`` → [0, 1, 2, 3, 4]; ``"0,2,7"`` → [0, 2, 7]; ``"3"`` → [3]. Seeds are
    non-negative; ``name`` is the option or config key named in the error.

    >>> parse_seeds("0-2,7")
    [0, 1, 2, 7]
    """
    out: list[int] = []
    try:
        for part in text.split(","):
            part = part.strip()
            if not part:
                continue
            if part.startswith("-"):
                raise EvodevoError(f"{name} {text!r}: seed {part} must be >= 0")
            if "-" in part:
                a, b = part.split("-", 1)
                lo, hi = int(a), int(b)
                if hi < lo:
                    raise ValueError
                out.extend(range(lo, hi + 1))
            else:
                out.append(int(part))
    except ValueError:
        raise EvodevoError(f"{name} {text!r} is not a seed list; use e.g. 0-4 or 0,1,5") from None
    if not out:
        raise EvodevoError(f"{name} {text!r} names no seed; use e.g. 0-4 or 0,1,5")
    return out
