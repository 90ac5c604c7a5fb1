"""The six variants of Chapter 3 as settings, not code paths (SPEC §1.2, §1.5).

A variant says whether laterals are gated (BIARM) or plain (PNN), whether the modules run
and modulate the learning rate, and which modules are ablated (held at 0.5).

>>> VARIANTS["no-da"].ablated
('DA',)
>>> get_variant("pnn").modulated
False
"""

from __future__ import annotations

from dataclasses import dataclass

from evodevo.errors import EvodevoError

__all__ = ["Variant", "VARIANTS", "get_variant"]


@dataclass(frozen=True)
class Variant:
    """One row of Tables 3.2 / 3.4.

    Attributes:
        name: CLI name.
        gated: BIARM gated laterals ``U (alpha * V h)``; else PNN laterals ``U h``.
        modulated: neuromodulator modules run and drive Eq. 3.7 and the context gate.
        ablated: modules held at ``modules.ablated_value`` (SPEC §1.5).
    """

    name: str
    gated: bool
    modulated: bool
    ablated: tuple[str, ...] = ()


VARIANTS: dict[str, Variant] = {
    "biarm": Variant("biarm", True, True),
    "pnn": Variant("pnn", False, False),
    "no-da": Variant("no-da", True, True, ("DA",)),
    "no-5ht": Variant("no-5ht", True, True, ("5HT",)),
    "no-ne": Variant("no-ne", True, True, ("NE",)),
    "no-ach": Variant("no-ach", True, True, ("ACh",)),
}


def get_variant(name: str) -> Variant:
    """The :class:`Variant` called ``name``, or an :class:`EvodevoError` listing the choices."""
    try:
        return VARIANTS[name]
    except KeyError:
        raise EvodevoError(
            f"unknown variant {name!r}; choose one of {', '.join(VARIANTS)}"
        ) from None
