"""Compiled live programs per model and grid, shared by every tab that shows them.

An :class:`Engine` holds one model on one grid with one time stepper, and per steps-per-frame
value the jitted frame program of :mod:`morphogen.web.live`. :func:`engine_for` keeps the last
:data:`ENGINES_SIZE` of them, so a page switching back to a model finds its programs compiled.

The engine's model remembers its homogeneous ground state per parameter set
(:func:`remembered_ground`). A model without a closed-form ``ground`` finds it by the damped
Newton iteration of :meth:`morphogen.models.model.Model.ground_state` (60 steps of
``u <- u - 0.7 J(u)^+ R(u)``, one compiled program per model: 0.2-1.3 s the first time in a
process, then under a millisecond; run op by op it took 2.3-2.6 s, then 0.3-0.5 s a call), and
the live view asks for it at every start (the initial condition, the explicit ``dt`` limit of
:func:`morphogen.solvers.stability.linear_limit`) and at every brush point (the ground or excited
state painted); remembering it leaves one solve per parameter set. FitzHugh-Nagumo and the
activator-inhibitor model of the library have no closed form, nor does a pasted model without
an ``[initial]`` table.
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.monitors import OVERFLOW
from morphogen.engine.simulate import integrate
from morphogen.models.model import Model
from morphogen.solvers.step import make_step
from morphogen.web.brush import painter

ENGINES_SIZE = 12
"""Engines kept (least recently used dropped first)."""
GROUNDS_SIZE = 64
"""Ground states remembered per engine (one per parameter set asked for)."""


@dataclass
class Engine:
    """Compiled programs for one model on one grid, shared by every tab that shows them.

    Attributes:
        model, grid: what is simulated; scheme: the time stepper's name.
        step: ``step(u, p, t, dt, key) -> u`` from :func:`morphogen.solvers.step.make_step`.
        advance: per steps-per-frame value, the jitted frame program (see :meth:`program`).
        paint: jitted ``paint(u, cx, cy, r, values) -> u``.
    """

    model: Model
    grid: Grid
    step: Callable
    scheme: str = "euler"
    advance: dict[int, Callable] = field(default_factory=dict)
    paint: Callable | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)

    def program(self, n: int) -> Callable:
        """``run(u, p, t, dt, key, show, lo, hi) -> (u, t, key, img, fmin, fmax, ok)``.

        ``u`` ``(S, n, n)``; ``img`` ``(n, n)`` uint8 of species ``show``; ``ok`` is false when
        any value is NaN, infinite or beyond the overflow bound.
        """
        with self.lock:
            if n not in self.advance:
                step = self.step

                def run(u, p, t, dt, key, show, lo, hi):
                    u, t, key = integrate(step, u, p, steps=n, dt=dt, t0=t, key=key)
                    f = jnp.take(u, show, axis=0)
                    ok = jnp.all(jnp.isfinite(u) & (jnp.abs(u) < OVERFLOW))
                    img = pixels(f, lo, hi)
                    return u, t, key, img, jnp.min(f), jnp.max(f), ok

                self.advance[n] = jax.jit(run)
            if self.paint is None:
                self.paint = jax.jit(painter(self.grid))
            return self.advance[n]


def pixels(f: Any, lo: Any, hi: Any) -> Any:
    """Grey levels 0..255 of ``f`` scaled from ``[lo, hi]`` (all 0 when ``hi <= lo``); the one
    mapping of both the jitted frame and the still picture."""
    scale = jnp.where(hi > lo, 255.0 / jnp.maximum(hi - lo, 1e-30), 0.0)
    return jnp.clip(jnp.round((f - lo) * scale), 0, 255).astype(jnp.uint8)


def remembered_ground(model: Model, size: int = GROUNDS_SIZE) -> Model:
    """``model`` with a ``ground`` that remembers :meth:`Model.ground_state` per parameter set.

    The key is the parameters' spatial means (what ``ground_state`` solves with) rounded to
    float32, the precision the live view computes in, so each set is solved once however often
    a start, a ``dt`` limit (taken of the parameters as the engine casts them) or a brush asks;
    the ``size`` latest sets are kept. A model with a closed-form ``ground`` is returned as it
    is.
    """
    if model.ground is not None:
        return model
    solved: OrderedDict[tuple, np.ndarray] = OrderedDict()
    lock = threading.Lock()

    def ground(params: Mapping[str, Any]) -> np.ndarray:
        key = tuple(sorted((k, float(np.float32(np.mean(np.asarray(v, np.float64)))))
                           for k, v in params.items()))
        with lock:
            if key in solved:
                solved.move_to_end(key)
                return solved[key].copy()
        value = model.ground_state(dict(key))
        with lock:
            solved[key] = value
            while len(solved) > size:
                solved.popitem(last=False)
        return value.copy()

    return dataclasses.replace(model, ground=ground)


_ENGINES: OrderedDict[tuple, Engine] = OrderedDict()
_ENGINES_LOCK = threading.Lock()


def engine_for(model: Model, key: str, shape: tuple[int, int], boundary: str,
               scheme: str = "euler", *, dx: float = 1.0,
               stencil: int | str | None = None) -> Engine:
    """The shared :class:`Engine` of a model (by cache key) on an ``(h, w)`` grid of spacing
    ``dx`` and Laplacian ``stencil`` with a time stepper of
    :data:`morphogen.solvers.registry.LIVE` (one the model, boundary or stencil cannot take is
    refused by :class:`~morphogen.domains.grid.Grid` or
    :func:`morphogen.solvers.step.make_step` with its one-line reason)."""
    ident = (key, tuple(shape), boundary, scheme, dx, stencil)
    with _ENGINES_LOCK:
        if ident in _ENGINES:
            _ENGINES.move_to_end(ident)
            return _ENGINES[ident]
    grid = Grid(tuple(shape), dx=dx, boundary=boundary, stencil=stencil)
    step = make_step(model, grid, scheme=scheme, clamp=model.clamp)
    eng = Engine(model=remembered_ground(model), grid=grid, step=step, scheme=scheme)
    with _ENGINES_LOCK:
        _ENGINES[ident] = eng
        while len(_ENGINES) > ENGINES_SIZE:
            _ENGINES.popitem(last=False)
    return eng
