"""The fused CPU step (morphogen/solvers/fused.py): the same run as the JAX step within float32
rounding on every library model, only where it applies, and no user text in what it compiles.

Tolerance: after 300 steps each species of the fused state is within 1e-5 of that species'
largest magnitude in the JAX state (about 80 float32 roundings; the library models measured
at most 2e-6: contraction and library functions may round differently in the last bit).
"""

from __future__ import annotations

import io
import sys
import tokenize

import jax.numpy as jnp
import numpy as np
import pytest

import morphogen.engine.simulate as simulate_module
from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate, simulate_batch
from morphogen.models.library import LIBRARY, get_model
from morphogen.models.model import Model
from morphogen.solvers import fused
from morphogen.solvers.step import Noise
from tests.fused_support import needs_numba

RTOL = 1e-5
STEPS = 300



@pytest.fixture
def taken(monkeypatch):
    """Whether each simulate call took the fused step."""
    seen: list[bool] = []
    real = simulate_module.fused_step

    def spy(*args, **kwargs):
        step = real(*args, **kwargs)
        seen.append(step is not None)
        return step

    monkeypatch.setattr(simulate_module, "fused_step", spy)
    return seen


def _run(monkeypatch, mode, model, grid, u0, params, **options):
    monkeypatch.setenv(fused.ENV, mode)
    return simulate(model, grid, u0, params, steps=STEPS, **options).state


def _matches_jax(monkeypatch, taken, model, grid, u0, params, **options):
    """The run on the JAX step, then on the fused step: the fused one took its step and is
    within :data:`RTOL` of each species' scale."""
    want = _run(monkeypatch, "off", model, grid, u0, params, **options)
    got = _run(monkeypatch, "on", model, grid, u0, params, **options)
    assert taken == [False, True]
    scale = np.abs(want).max(axis=tuple(range(1, want.ndim)), keepdims=True)
    assert np.all(np.isfinite(got))
    assert np.all(np.abs(got - want) <= RTOL * scale), float(np.max(np.abs(got - want) / scale))


@needs_numba
@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_every_library_model_matches_the_jax_step(name, monkeypatch, taken):
    model = get_model(name)
    grid = Grid((24, 20))
    params = model.parameters({})
    u0 = make_initial(model.init, model, grid, params, seed=1, **dict(model.init_options))
    _matches_jax(monkeypatch, taken, model, grid, u0, params)


@needs_numba
@pytest.mark.parametrize("name,clamp", [("gray-scott", (0.0, 0.6)), ("turing", "model")])
def test_no_flux_nine_points_and_clamps_match_the_jax_step(name, clamp, monkeypatch, taken):
    model = get_model(name)
    grid = Grid((20, 24), dx=0.8, boundary="neumann", stencil=9)
    params = model.parameters({})
    u0 = make_initial(model.init, model, grid, params, seed=2)
    dt = 0.5 * model.dt
    _matches_jax(monkeypatch, taken, model, grid, u0, params, dt=dt, clamp=clamp)


def _x_and_t(u, p, c):
    return jnp.stack([p["a"] * c["x"] * (1.0 - u[0]) - u[0] * u[1] ** 2,
                      jnp.where(u[0] > 0.5, jnp.exp(-u[1]), u[1] * c["y"]) * jnp.cos(c["t"])
                      - p["a"] * u[1]])


@needs_numba
def test_coordinates_and_time_reach_the_kernel(monkeypatch, taken):
    model = Model(name="xt", species=("u", "v"), params={"a": 0.3, "D": 0.2},
                  reaction=_x_and_t, diffusion=lambda p, c: (p["D"], 0.5 * p["D"]))
    grid = Grid((16, 12))
    u0 = np.random.default_rng(3).random((2, 16, 12)).astype(np.float32)
    _matches_jax(monkeypatch, taken, model, grid, u0, dict(model.params), dt=0.1)


HOSTILE = '"); __import__("os").system("echo hacked") #'


def _hostile_reaction(u, p, c):
    return jnp.stack([p[HOSTILE] * (1.0 - u[0]), -u[1] * p["k\nimport os"]])


def _hostile_diffusion(p, c):
    return (p["D'''"], p["D'''"])


@needs_numba
def test_no_user_text_reaches_the_compiler(monkeypatch, taken):
    model = Model(name=HOSTILE, species=(HOSTILE + "u", "v = 1\nexec('')"),
                  params={HOSTILE: 0.1, "k\nimport os": 0.2, "D'''": 0.2},
                  reaction=_hostile_reaction, diffusion=_hostile_diffusion)
    code = fused.kernel_source(model, list(model.params), boundary="periodic", stencil=5,
                               dx=1.0, clamp=None)
    allowed = {"def", "for", "in", "range", "if", "else", "return", "np", "njit",
               "advance", "advance_all", "cur", "nxt", "steps", "tc", "dt", "xs", "ys", "qs",
               "xc", "yc", "m", "out", "clock", "x", "xl", "xr", "i", "w", "h", "y", "yn",
               "ys_", "shape", "_", "maximum",
               "minimum", "exp", "not", "and", "or", "True", "False", "mode", "stmxcsr",
               "ldmxcsr", "FTZ_DAZ", "uint32"}
    for token in tokenize.generate_tokens(io.StringIO(code.source).readline):
        assert token.type != tokenize.STRING
        if token.type == tokenize.NAME:
            assert token.string in allowed or (
                token.string.rstrip("0123456789") in {"k", "q", "s", "l", "v", "t", "rc", "rn",
                                                      "rs", "ro"}
                and token.string[-1].isdigit()), token.string
        if token.type == tokenize.NUMBER:
            assert token.string.isdigit()
    grid = Grid((12, 12))
    u0 = np.random.default_rng(4).random((2, 12, 12)).astype(np.float32)
    _matches_jax(monkeypatch, taken, model, grid, u0, dict(model.params), dt=0.5)


@pytest.mark.parametrize("change", [
    {"scheme": "rk4"}, {"noise": Noise(0.01)}, {"boundary": "dirichlet=0.5"},
    {"boundary": {"u": "periodic", "v": "neumann"}}, {"stencil": "spectral"},
    {"shape": (8, 8, 8)}, {"field": True}, {"mode": "off"},
])
def test_a_run_it_does_not_cover_takes_the_jax_path(change, monkeypatch):
    monkeypatch.setenv(fused.ENV, change.get("mode", "on"))
    model = get_model("gray-scott")
    grid = Grid(change.get("shape", (12, 12)), boundary=change.get("boundary", "periodic"),
                stencil=change.get("stencil"))
    params = {k: jnp.float32(v) for k, v in model.params.items()}
    if "field" in change:
        params["F"] = jnp.full(grid.shape, 0.03, jnp.float32)
    step = fused.fused_step(model, grid, params, scheme=change.get("scheme", "euler"),
                            noise=change.get("noise"), clamp=None, dtype=np.float32, steps=10)
    assert step is None


def test_short_runs_batches_and_float64_take_the_jax_path(monkeypatch, taken):
    monkeypatch.delenv(fused.ENV, raising=False)
    model = get_model("gray-scott")
    grid = Grid((16, 16))
    params = {k: jnp.float32(v) for k, v in model.params.items()}
    options = {"scheme": "euler", "noise": None, "clamp": None}
    assert fused.fused_step(model, grid, params, dtype=np.float32, steps=100, **options) is None
    monkeypatch.setenv(fused.ENV, "on")
    assert fused.fused_step(model, grid, params, dtype=np.float64, steps=100, **options) is None
    u0 = make_initial("blobs", model, grid, params, seed=0)
    simulate_batch(model, grid, np.stack([u0, u0]), {k: np.full(2, v) for k, v in
                                                       model.params.items()}, steps=5)
    assert taken == []  # a batch never asks


def test_without_numba_the_jax_path_runs(monkeypatch, taken):
    monkeypatch.setitem(sys.modules, "numba", None)  # `import numba` fails
    model = get_model("gray-scott")
    grid = Grid((16, 16))
    params = model.parameters({})
    u0 = make_initial("blobs", model, grid, params, seed=0)
    got = _run(monkeypatch, "on", model, grid, u0, params)
    want = _run(monkeypatch, "off", model, grid, u0, params)
    assert taken == [False, False]
    assert np.array_equal(got, want)
