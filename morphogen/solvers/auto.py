"""``scheme="auto"``: pick an explicit or a stiff-aware time stepper from the linearised system.

Explicit Euler, the scheme of every seed (Skaggs §3.2 hand-tunes ``dt`` per model, Table 3.3;
Ringham §2.2 eqs. 2-4 use forward Euler), is limited by diffusion: ``dt_E`` from
:func:`morphogen.solvers.step.max_stable_dt`, about ``dx² / (2 d D_max)`` on a ``d``-dimensional
grid. An IMEX step solves diffusion exactly in Fourier space and is limited by the reaction
alone: ``dt_R``, the Euler-disc limit of the reaction Jacobian's eigenvalues at the ground state
with the implicit margin (:data:`morphogen.solvers.stability.SAFETY_IMPLICIT`), i.e. the reaction's
time scale. The stiffness ratio

.. math:: s = dt_R / dt_E

says how many Euler steps one IMEX step replaces. An ARS(2,2,2) step (two FFT solves per
species, two reaction evaluations) costs 13 Euler steps at 128² and 22 at 256² on the 2-core
CPU (``bench/results/integrators.json``: the FFTs grow as ``N log N`` while XLA's explicit step
stays memory-bound), so ``auto`` chooses ``imex`` when ``s >`` :data:`AUTO_RATIO` on a grid
where the Fourier solve applies (periodic or no-flux boundaries, constant isotropic diffusion),
and ``euler`` otherwise. Schnakenberg with ``Dv/Du = 40`` at ``dx = 1`` has ``s ≈ 17.8``
(``euler``: ``imex`` at its limit ran 0.83x Euler's speed at 256²), at ``dx = 1/2`` ``s ≈ 71``
(``imex``); with ``Dv/Du = 80`` at ``dx = 1`` ``s ≈ 18`` (``euler``: the spots' Jacobian halves
the IMEX step to 0.051, :mod:`morphogen.solvers.pattern_limit`; ``imex`` at the ground state's
0.1 blew up); Gray-Scott's defaults ``s ≈ 9.8`` (``euler``).

With ``--rtol``/``--atol``, ``auto`` picks an error-controlled scheme instead
(:func:`choose_error_controlled`): ``etdrk4-adaptive`` where diffusion is solved exactly, else
``adaptive``.

On meshes, and on grids with Dirichlet boundaries or spatially varying or anisotropic
diffusion, each implicit solve is a conjugate-gradient iteration (:mod:`morphogen.solvers.imex_cg`)
whose cost grows with the step, so the threshold there is :data:`AUTO_RATIO_CG`.
"""

from __future__ import annotations

import jax.numpy as jnp

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Model, Params, Tensor
from morphogen.solvers.registry import POPULATION, SCHEMES
from morphogen.solvers.step import max_stable_dt

AUTO_RATIO = 25.0
"""Stiffness ratio ``dt_R / dt_E`` above which ``auto`` picks ``imex`` (Fourier solves): above
the 13-22 Euler steps an ``imex`` step costs at 128²-256²."""

AUTO_RATIO_CG = 25.0
"""The same where ``imex`` solves diffusion by conjugate gradients (meshes; grids with
Dirichlet, varying or anisotropic diffusion). On Ringham's Mimulus mesh at 23 000 vertices
(``bench/results/imex_mesh.json``, docs/schemes-mesh.md) an ``imex`` step cost 18-21 Euler
steps at a ratio of 17.6 (0.84x Euler's speed); with the iteration count growing as the ratio's
square root, that breaks even near 19-25; at 85 000 vertices (ratio 59) ``imex`` was 1.76x
faster."""

STIFF_SCHEME = "imex"
"""The stiff-aware scheme ``auto`` picks: second order and cheaper per step than ETDRK4."""


def stiffness_ratio(model: Model, domain: Domain, params: Params, *, batched: bool = False
                    ) -> float:
    """``dt_R / dt_E``: the reaction-limited (IMEX) step over the explicit Euler limit."""
    explicit = max_stable_dt(model, domain, params, "euler", batched=batched)
    reaction = max_stable_dt(model, domain, params, STIFF_SCHEME, batched=batched)
    return reaction / explicit


def fourier_solves(model: Model, domain: Domain, params: Params, *, batched: bool = False
                   ) -> bool:
    """Whether every species' implicit solve is the exact Fourier one: a grid, periodic or
    no-flux boundaries, constant isotropic diffusion."""
    if domain.kind != "grid":
        return False
    if any(bc.kind not in ("periodic", "neumann") for bc in domain.boundaries(model.species)):
        return False
    coords = {**{k: jnp.asarray(v) for k, v in domain.coords.items()}, "t": 0.0}
    first = {k: jnp.asarray(v)[0] if batched else jnp.asarray(v) for k, v in params.items()}
    return not any(isinstance(d, Tensor) or jnp.ndim(d) > 0
                   for d in model.diffusion(first, coords))


def choose_scheme(model: Model, domain: Domain, params: Params, *, batched: bool = False) -> str:
    """``imex`` when :func:`stiffness_ratio` exceeds :data:`AUTO_RATIO` (Fourier solves) or
    :data:`AUTO_RATIO_CG` (conjugate-gradient solves), else ``euler``."""
    try:
        ratio = stiffness_ratio(model, domain, params, batched=batched)
    except MorphogenError:
        return "euler"
    fourier = fourier_solves(model, domain, params, batched=batched)
    return STIFF_SCHEME if ratio > (AUTO_RATIO if fourier else AUTO_RATIO_CG) else "euler"


def choose_error_controlled(model: Model, domain: Domain, params: Params, *,
                            batched: bool = False) -> str:
    """``auto`` with ``--rtol``/``--atol``: ``etdrk4-adaptive`` where diffusion is solved
    exactly in Fourier space (:func:`fourier_solves`, all species periodic or all no-flux), so
    that the step is set by the reaction's accuracy alone; ``adaptive`` (Tsit5) elsewhere."""
    if fourier_solves(model, domain, params, batched=batched):
        mirror = {bc.kind for bc in domain.boundaries(model.species)}
        if len(mirror) == 1:
            return "etdrk4-adaptive"
    return "adaptive"


def population_scheme(scheme: str, model: Model, domain: Domain, params: Params, *,
                      batched: bool = False, where: str = "search") -> str:
    """The fixed-step scheme a population (search, atlas) runs: ``auto`` resolved by
    :func:`choose_scheme` on ``params``, ``adaptive`` refused with a one-line error (each member
    would take its own steps, while a population advances in lock-step with one ``dt``)."""
    if scheme == "auto":
        return choose_scheme(model, domain, params, batched=batched)
    if scheme in SCHEMES and not SCHEMES[scheme].population:
        raise MorphogenError(f"scheme {scheme} runs one state at a time; {where} advances a "
                             f"population with one dt: use {', '.join(POPULATION)}")
    return scheme

