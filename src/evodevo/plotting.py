"""matplotlib's pyplot on the Agg backend, imported when a figure is drawn.

Importing matplotlib costs about 0.4 s, which every CLI call and every spawned worker that
imports a module with figures would otherwise pay; choosing the Agg backend (files only, no
display) is then also no side effect of importing such a module.
"""

from __future__ import annotations

from typing import Any

__all__ = ["pyplot"]


def pyplot() -> Any:
    """``matplotlib.pyplot``, with the Agg backend selected first."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
