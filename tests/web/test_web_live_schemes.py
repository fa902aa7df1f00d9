"""Live frames under the schemes with exact diffusion: one compiled program, then none.

A frame of ETDRK4 or IMEX is one call of the frame program compiled with the engine; the
exponentials and φ-coefficients are computed inside it, once per frame, so later frames, a
parameter change or a new ``dt`` trace and compile nothing (counted with JAX's compile events,
never timed), and the frames equal :func:`morphogen.engine.simulate.simulate`.
"""

from __future__ import annotations

import jax.monitoring
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models.library import get_model
from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim


@pytest.fixture
def compiles():
    """JAX's trace, lowering and compile events while the test runs, by name."""
    seen: list[str] = []

    def listen(event: str, _seconds: float, **_kwargs) -> None:
        if event.startswith("/jax/core/compile/"):
            seen.append(event)

    jax.monitoring.register_event_duration_secs_listener(listen)
    yield seen
    jax.monitoring.unregister_event_duration_listener(listen)


@pytest.mark.parametrize("scheme,boundary", [("etdrk4", "periodic"), ("etdrk4", "neumann"),
                                             ("imex", "neumann")])
def test_frames_after_the_first_compile_nothing_and_equal_simulate(compiles, scheme, boundary):
    sim = LiveSim(Limits())
    state = sim.configure({"library": "gray-scott"}, size=24, height=20, boundary=boundary,
                          scheme=scheme, init="noise", seed=2)
    n = sim.steps_per_frame
    sim.frame()
    model, grid = get_model("gray-scott"), Grid((20, 24), boundary=boundary)
    params = model.parameters()
    u0 = make_initial("noise", model, grid, params, seed=2)
    ref = simulate(model, grid, u0, params, steps=2 * n, dt=state["dt"], scheme=scheme).state
    sim.frame()
    np.testing.assert_allclose(sim.state(), ref, rtol=1e-5, atol=1e-6)
    sim.set_params({"F": 0.03})
    sim.set_dt(0.5 * state["dt"])
    compiles.clear()
    for _ in range(3):
        sim.frame()
    assert sim.error is None and compiles == []
    assert sim.engine.program(n)._cache_size() == 1
