"""The server's start-up warm-up compiles exactly the program a page's first frame uses."""

from __future__ import annotations

import threading

from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim
from morphogen.web.warmup import warm_library


def test_warm_up_compiles_the_first_frame_a_page_will_ask_for():
    limits = Limits()
    stopped = threading.Event()
    stopped.set()
    # a server that is stopping compiles nothing
    assert warm_library(limits, ["gray-scott"], stopped, size=32) == {}
    took = warm_library(limits, ["gray-scott", "no-such-model"], threading.Event(), size=32)
    assert list(took) == ["gray-scott"]  # a model the live view refuses is skipped
    # a page's session on the default view finds the engine with the program already built
    sim = LiveSim(limits)
    sim.configure({"library": "gray-scott"}, size=32)
    assert sim.engine.advance[sim.steps_per_frame]._cache_size() == 1
