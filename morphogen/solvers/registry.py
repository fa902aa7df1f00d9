"""The time-stepping schemes by name: one JAX-free table that the command line, the run
settings, the web app and the engine all read.

Each row says what a user may ask for and what the engine must know before building a step:
its order of accuracy, whether it is a fixed-step scheme (built by
:func:`morphogen.solvers.step.make_step`) or one resolved per run (``adaptive``: error control;
``auto``: a choice between the others), whether diffusion is treated implicitly (so its step is
limited by the reaction alone), whether a population can advance with it in lock-step, and
whether the web app's live view offers it. The implementation of a scheme lives in the module
named by ``module``: a fixed-step scheme's :class:`~morphogen.solvers.base.Stepper` subclass, an
error-controlled scheme's ``embedded_pair(model, domain)`` (a diffrax adaptive solver,
:func:`morphogen.solvers.adaptive.solve`); adding a scheme is that module plus one row here.

The explicit schemes are the seeds' forward Euler (Skaggs §3.2, Ringham et al. eqs. 2-4) and
classic RK4; ``imex1``/``imex`` are semi-implicit Euler and ARS(2,2,2) (Ascher, Ruuth and
Spiteri 1997); ``etdrk4`` is Cox-Matthews ETDRK4 (φ-functions by series and closed forms);
``adaptive`` is Tsit5 under a PI controller, ``etdrk4-adaptive`` ETDRK4 with an embedded
exponential midpoint estimate under the same controller.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SchemeInfo:
    """What is known about a scheme without building it.

    Attributes:
        name: the name users type (``--scheme``, ``run.json``, the web menu).
        order: global order of accuracy in ``dt`` of the deterministic scheme.
        summary: one line for ``--help`` and the docs.
        module: the module that implements it.
        fixed_step: a per-step scheme that :func:`morphogen.solvers.step.make_step` builds;
            ``False`` for schemes resolved per run (``adaptive``, ``auto``).
        implicit_diffusion: diffusion solved implicitly or exactly, so the stable step is set by
            the reaction alone (:mod:`morphogen.solvers.stability`).
        population: a batch can advance with it in lock-step with one ``dt`` (search, atlas).
        live: offered by the web app's live view.
        error_control: its steps are chosen by an error controller from ``--rtol/--atol``
            (:mod:`morphogen.engine.adaptive_loop`).
        live_cost: the cost of one live-view step relative to Euler's, on periodic and on
            no-flux boundaries (measured on the server: Gray-Scott 256², docs/web.md), which
            the web page uses only to warn before a set-up that could not keep up.
    """

    name: str
    order: int
    summary: str
    module: str
    fixed_step: bool = True
    implicit_diffusion: bool = False
    population: bool = True
    live: bool = True
    error_control: bool = False
    live_cost: tuple[float, float] = (1.0, 1.0)


SCHEMES: dict[str, SchemeInfo] = {
    s.name: s
    for s in (
        SchemeInfo("euler", 1, "explicit (forward) Euler, the seeds' scheme",
                   "morphogen.solvers.explicit", live_cost=(1.0, 1.5)),
        SchemeInfo("rk4", 4, "classic explicit Runge-Kutta 4", "morphogen.solvers.explicit",
                   live_cost=(13.0, 14.0)),
        SchemeInfo("imex1", 1, "semi-implicit Euler: implicit diffusion, explicit reaction",
                   "morphogen.solvers.imex", implicit_diffusion=True, live_cost=(10.0, 13.0)),
        SchemeInfo("imex", 2, "ARS(2,2,2) implicit-explicit Runge-Kutta",
                   "morphogen.solvers.imex", implicit_diffusion=True, live_cost=(14.0, 38.0)),
        SchemeInfo("etdrk4", 4, "exponential time differencing RK4 (Cox-Matthews)",
                   "morphogen.solvers.etd", implicit_diffusion=True, live_cost=(26.0, 57.0)),
        SchemeInfo("adaptive", 5, "Tsit5 5(4) with error control (--rtol, --atol)",
                   "morphogen.solvers.adaptive", fixed_step=False, population=False,
                   live=False, error_control=True),
        SchemeInfo("etdrk4-adaptive", 4,
                   "etdrk4 with an embedded 2nd-order estimate setting the step (--rtol, --atol)",
                   "morphogen.solvers.etd_adaptive", fixed_step=False, implicit_diffusion=True,
                   population=False, live=False, error_control=True),
        SchemeInfo("auto", 0, "imex when the problem is stiff enough to pay, else euler",
                   "morphogen.solvers.auto", fixed_step=False, live=False),
    )
}
"""Every scheme, in the order menus list them."""

NAMES: tuple[str, ...] = tuple(SCHEMES)
"""All scheme names (``--scheme`` choices of ``simulate``)."""

FIXED_STEP: tuple[str, ...] = tuple(n for n, s in SCHEMES.items() if s.fixed_step)
"""Schemes that :func:`morphogen.solvers.step.make_step` builds."""

POPULATION: tuple[str, ...] = tuple(n for n, s in SCHEMES.items() if s.population)
"""Schemes a population (search, atlas) may ask for; ``auto`` is resolved on the population."""

LIVE: tuple[str, ...] = tuple(n for n, s in SCHEMES.items() if s.live)
"""Schemes the web app's live view offers."""

IMPLICIT_DIFFUSION: tuple[str, ...] = tuple(
    n for n, s in SCHEMES.items() if s.implicit_diffusion and s.fixed_step)
"""Fixed-step schemes whose step is limited by the reaction alone."""

ERROR_CONTROLLED: tuple[str, ...] = tuple(n for n, s in SCHEMES.items() if s.error_control)
"""Schemes whose steps an error controller chooses (``--rtol``, ``--atol``)."""
