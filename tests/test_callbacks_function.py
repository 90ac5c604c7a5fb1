"""FunctionCallback: plain functions as callbacks (evodevo.callbacks)."""

from __future__ import annotations

import pytest

from evodevo.callbacks import CallbackList, FunctionCallback


def test_named_events_call_their_functions_and_the_others_do_nothing():
    seen: list[object] = []
    cb = CallbackList(
        [FunctionCallback(on_generation=seen.append, on_end=lambda: seen.append("end"))]
    )
    cb.init(owner="loop")
    cb.on_episode("ignored")
    cb.on_generation("g0")
    cb.on_end()
    assert seen == ["g0", "end"]


def test_an_unknown_event_is_refused_by_name():
    with pytest.raises(TypeError, match="on_epsiode"):
        FunctionCallback(on_epsiode=print)
