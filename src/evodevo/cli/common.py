"""Helpers shared by the CLI sub-commands: seed ranges, list options, process set-up."""

from __future__ import annotations

from evodevo.errors import EvodevoError

__all__ = ["parse_seeds", "parse_list"]


def parse_seeds(text: str) -> list[int]:
    """``"0-4"`` → [0, 1, 2, 3, 4]; ``"0,2,7"`` → [0, 2, 7]; ``"3"`` → [3]."""
    out: list[int] = []
    try:
        for part in text.split(","):
            part = part.strip()
            if not part:
                continue
            if "-" in part[1:]:
                a, b = part.split("-", 1) if not part.startswith("-") else (part, part)
                lo, hi = int(a), int(b)
                if hi < lo:
                    raise ValueError
                out.extend(range(lo, hi + 1))
            else:
                out.append(int(part))
    except ValueError:
        raise EvodevoError(f"--seeds {text!r} is not a seed list; use e.g. 0-4 or 0,1,5") from None
    if not out:
        raise EvodevoError(f"--seeds {text!r} names no seed; use e.g. 0-4 or 0,1,5")
    return out


def parse_list(text: str | None) -> list[str] | None:
    """Comma-separated list, or None when not given."""
    if text is None:
        return None
    items = [t.strip() for t in text.split(",") if t.strip()]
    return items or None
