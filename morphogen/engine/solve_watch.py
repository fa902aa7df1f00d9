"""Whether the iterative implicit-diffusion solves of an IMEX run converge.

A conjugate-gradient (or BiCGSTAB) solve of :mod:`morphogen.solvers.imex_cg` stops at its tolerance
or after :data:`~morphogen.solvers.imex_cg.CG_MAXITER` iterations, whichever comes first; inside the
compiled time loop nothing can be reported. So between two compiled chunks, :class:`SolveWatch`
repeats the first solve of the next step exactly as the step does it — right-hand side
``b = u + gamma dt R(u)``, ``c = gamma dt`` (``gamma = 1 - 1/sqrt 2`` for ARS(2,2,2), 1 for
``imex1``), warm start ``x0 = u`` — and measures its final residual against its stopping
threshold ``max(tol ||rhs||, atol)``. A ratio above :data:`REPORT_RATIO` means the solve
stopped at the cap, far from its tolerance: the run goes on (its diffusion is then less
accurate than documented, not unstable), and :meth:`SolveWatch.warning` says which species,
at which step, by how much, and what to do. The probe costs one solve per chunk (a chunk is up
to 250 steps).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.engine.monitors import Chunk, Monitor
from morphogen.models.model import Array, Model, Params
from morphogen.solvers import imex_cg
from morphogen.solvers.base import held_mask, stepper
from morphogen.solvers.imex import IMEX_SCHEMES
from morphogen.solvers.imex_cg import ImplicitDiffusion

REPORT_RATIO = 10.0
"""Residual over the stopping threshold above which an unconverged solve is reported (the
recomputed residual of a converged float32 solve can exceed its recursive one slightly)."""


@lru_cache(maxsize=32)
def _probe(model: Model, domain: Any, scheme: str) -> tuple[ImplicitDiffusion, Any]:
    """The domain's implicit solver and the compiled probe of a step's first solve, kept per
    model, domain and scheme like the step itself (a run does not trace and compile it again)."""
    solver = ImplicitDiffusion(domain, model.species, held_mask(model, domain))
    gamma = stepper(scheme).gamma
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}
    bcs = domain.boundaries(model.species)

    def probe(u: Array, p: Params, t: Array, dt: Array) -> Array:
        c = {**coords, "t": t}
        u = domain.hold(u, bcs)
        b = u + gamma * dt * model.reaction(u, p, c)
        return solver.residual_ratios(b, tuple(model.diffusion(p, c)), gamma * dt, u)

    return solver, jax.jit(probe)


class SolveWatch(Monitor):
    """Probe the next step's first implicit solve between chunks (a monitor of
    :mod:`morphogen.engine.monitors`); remember the worst one."""

    def __init__(self, model: Model, probe: Any, params: Params):
        self.model, self.probe, self.params = model, probe, params
        self.worst = 0.0
        self.where: tuple[int, str] | None = None

    @classmethod
    def for_run(cls, model: Model, domain: Any, params: Params, scheme: str, batched: bool
                ) -> SolveWatch | None:
        """A watch for a run of an IMEX scheme with an iterative solve on one state, else
        ``None``. ``params`` are the run's, as its steps receive them."""
        if batched or scheme not in IMEX_SCHEMES:
            return None
        solver, probe = _probe(model, domain, scheme)
        coords = {**domain.coords, "t": 0.0}
        coeffs = model.diffusion({k: jnp.asarray(v) for k, v in params.items()}, coords)
        if not any(solver.iterative(i, d) for i, d in enumerate(coeffs)):
            return None
        return cls(model, probe, params)

    def check(self, chunk: Chunk) -> None:
        """Probe the solve of the step that follows ``chunk``."""
        u = chunk.u
        ratios = np.asarray(self.probe(u, self.params, chunk.t, jnp.asarray(chunk.dt, u.dtype)),
                            np.float64)
        i = int(np.argmax(ratios))
        if np.isfinite(ratios[i]) and ratios[i] > max(self.worst, REPORT_RATIO):
            self.worst, self.where = float(ratios[i]), (chunk.step, self.model.species[i])

    def warning(self) -> str | None:
        """One line naming the worst unconverged solve, or ``None`` if every probe converged."""
        if self.where is None:
            return None
        step, name = self.where
        cap = imex_cg.CG_MAXITER
        return (f"the implicit diffusion solve of species {name} stopped at its "
                f"{cap}-iteration cap with a residual {self.worst:.3g}x its tolerance "
                f"(after step {step}); diffusion is less accurate than documented: use a "
                "smaller --dt")
