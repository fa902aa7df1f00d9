"""Classic reaction-diffusion models with default parameters that form a pattern.

Every model is registered under its kebab-case command-line name in :data:`LIBRARY`. Grid
defaults assume ``dx = 1``; values taken from mesh case studies (Ringham et al.) are rescaled to a
unit-spaced grid, keeping their ratio ``D_inhibitor / D_activator``, and the docstring says so.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.genrd import genrd
from morphogen.models.model import Array, Model, Params
from morphogen.models.network import yamamoto_activator_inhibitor

LIBRARY: dict[str, Callable[[], Model]] = {}
"""Model factories by command-line name."""


def register(factory: Callable[[], Model]) -> Callable[[], Model]:
    """Add a model factory to :data:`LIBRARY` under its model's name."""
    LIBRARY[factory().name] = factory
    return factory


def get_model(name: str) -> Model:
    """The library model ``name``, a shipped trained neural RD rule ``neural:NAME``
    (:mod:`morphogen.models.neural_library`), or a clear error listing the known names."""
    if name.startswith("neural:"):
        from morphogen.models.neural_library import load_rule

        return load_rule(name)
    if name not in LIBRARY:
        from morphogen.models.neural_library import model_names

        known = ", ".join(sorted(LIBRARY) + model_names())
        raise MorphogenError(
            f"unknown model {name!r}; known models: {known} (or give a model file ending in "
            ".toml)"
        )
    return LIBRARY[name]()


def _stack(*rates: Array) -> Array:
    """The reaction rates as one array ``(S, *spatial)``.

    JAX is imported here, when a model's reaction is first evaluated, not when the library is
    imported: listing the models (``morphogen models``) stays fast.
    """
    import jax.numpy as jnp

    return jnp.stack(rates)


def _coefficients(*names: str) -> Callable[[Params, dict], tuple]:
    def diffusion(p: Params, c: dict) -> tuple:
        return tuple(p[n] for n in names)

    return diffusion


# Gray-Scott presets: (F, k) pairs of the WebGL explorer cited by Richard et al. (ref. [1]),
# with Du = 0.2097, Dv = 0.105, dx = 1.
_GS_EXPLORER = {
    "default": (0.037, 0.06),
    "solitons": (0.03, 0.062),
    "pulsating": (0.025, 0.06),
    "worms": (0.078, 0.061),
    "mazes": (0.029, 0.057),
    "holes": (0.039, 0.058),
    "chaos": (0.026, 0.051),
    "chaos-holes": (0.034, 0.056),
    "moving-spots": (0.014, 0.054),
    "spots-loops": (0.018, 0.051),
    "waves": (0.014, 0.045),
    "u-skate": (0.062, 0.06093),
}

# Richard et al. §5.2.2 with their stencil (0.3 * h^2 * Laplacian, see domains/stencils.py),
# converted to dx = 1: D_here = 0.3 * D_theirs / dx_theirs^2. Use with --stencil 9 and dt = 1.
_GS_RICHARD = {
    "richard-stripes": {"F": 0.04, "k": 0.06, "Du": 0.3, "Dv": 0.15},
    "richard-chaos": {"F": 0.018, "k": 0.051, "Du": 0.15, "Dv": 0.075},
    "richard-cells": {"F": 0.03, "k": 0.062, "Du": 0.15, "Dv": 0.075},
}


def _gray_scott_reaction(u, p, c):
    a, b = u[0], u[1]
    r = a * b * b
    return _stack(-r + p["F"] * (1.0 - a), r - (p["F"] + p["k"]) * b)


@register
def gray_scott() -> Model:
    """Gray-Scott (Skaggs eqs. 2.3-2.4; Richard et al. part II).

    .. math::
        \\dot u = -uv^2 + F(1-u) + D_u\\nabla^2 u,\\qquad
        \\dot v = uv^2 - (F+k)v + D_v\\nabla^2 v
    """
    presets = {name: {"F": f, "k": k} for name, (f, k) in _GS_EXPLORER.items()}
    presets.update(_GS_RICHARD)
    presets["skaggs-table-3.1"] = {"Du": 0.32768, "Dv": 0.16384}
    return Model(
        name="gray-scott",
        dt=1.0, t_end=6000.0, init="blobs",
        species=("u", "v"),
        params={"F": 0.037, "k": 0.06, "Du": 0.2097, "Dv": 0.105},
        reaction=_gray_scott_reaction,
        diffusion=_coefficients("Du", "Dv"),
        ground=lambda p: (1.0, 0.0),
        excited=lambda p: (0.5, 0.25),
        display="v",
        presets=presets,
        description="Gray-Scott autocatalysis: spots, stripes, mazes, solitons",
        reference="Skaggs 2022 eqs. 2.3-2.4; Richard et al. 2024 part II",
    )


def _gm_reaction(u, p, c):
    a, b = u[0], u[1]
    rho = p["rho"]
    du = rho * (b * b - p["nu"] * a)
    dv = rho * (b * b / (a * (1.0 + p["kappa"] * b * b)) - p["mu"] * b)
    return _stack(du, dv)


def _gm_ground(p) -> tuple[float, float]:
    """Homogeneous state of Skaggs eqs. 2.5-2.6: ``kappa mu v^3 + mu v = nu``, ``u = v^2/nu``."""
    roots = np.roots([p["kappa"] * p["mu"], 0.0, p["mu"], -p["nu"]])
    v = float(max(r.real for r in roots if abs(r.imag) < 1e-9))
    return (v * v / p["nu"], v)


@register
def gierer_meinhardt() -> Model:
    """Gierer-Meinhardt as written by Skaggs (eqs. 2.5-2.6).

    .. math::
        \\dot u = \\rho(v^2 - \\nu u) + D_u\\nabla^2 u,\\qquad
        \\dot v = \\rho\\left[\\frac{v^2}{u(1+\\kappa v^2)} - \\mu v\\right] + D_v\\nabla^2 v

    Here ``v`` is the self-enhancing activator and ``u`` the inhibitor it produces. Table 3.1
    lists the diffusion constants 0.05 and 2.0; a Turing pattern needs the inhibitor to diffuse
    faster, so the defaults give the inhibitor ``u`` the 2.0 and the activator ``v`` the 0.05
    (the preset ``skaggs-table-3.1`` keeps the literal labels ``Du = 0.05, Dv = 2.0``, which form
    no pattern by linear stability). Gene defaults are the centres of Skaggs table 3.2's ranges.
    """
    return Model(
        name="gierer-meinhardt",
        dt=0.05, t_end=500.0, init="noise",
        species=("u", "v"),
        params={"rho": 0.5, "mu": 0.975, "nu": 0.9, "kappa": 0.5, "Du": 2.0, "Dv": 0.05},
        reaction=_gm_reaction,
        diffusion=_coefficients("Du", "Dv"),
        ground=_gm_ground,
        display="v",
        presets={"skaggs-table-3.1": {"Du": 0.05, "Dv": 2.0}},
        description="Gierer-Meinhardt activator-inhibitor with saturation (Skaggs form)",
        reference="Skaggs 2022 eqs. 2.5-2.6, tables 3.1-3.3",
    )


def _schnakenberg_reaction(u, p, c):
    a, b = u[0], u[1]
    r = a * a * b
    return _stack(p["a"] - a + r, p["b"] - r)


@register
def schnakenberg() -> Model:
    """Schnakenberg (Murray, Mathematical Biology II, eq. 2.8, non-dimensional form).

    .. math::
        \\dot u = a - u + u^2 v + D_u\\nabla^2 u,\\qquad \\dot v = b - u^2 v + D_v\\nabla^2 v

    Homogeneous state ``u* = a + b``, ``v* = b / (a + b)^2``.
    """
    return Model(
        name="schnakenberg",
        dt=0.005, t_end=60.0, init="noise",
        species=("u", "v"),
        params={"a": 0.1, "b": 0.9, "Du": 1.0, "Dv": 40.0},
        reaction=_schnakenberg_reaction,
        diffusion=_coefficients("Du", "Dv"),
        ground=lambda p: (p["a"] + p["b"], p["b"] / (p["a"] + p["b"]) ** 2),
        display="u",
        description="Schnakenberg substrate-depletion model: spots and stripes",
        reference="Murray 2003, Mathematical Biology II, eq. 2.8",
    )


def _brusselator_reaction(u, p, c):
    a, b = u[0], u[1]
    r = a * a * b
    return _stack(p["a"] - (p["b"] + 1.0) * a + r, p["b"] * a - r)


@register
def brusselator() -> Model:
    """Brusselator (Prigogine & Lefever 1968; Murray II §2.6).

    .. math::
        \\dot u = a - (b+1)u + u^2 v + D_u\\nabla^2 u,\\qquad
        \\dot v = bu - u^2 v + D_v\\nabla^2 v

    Turing-unstable for ``(1 + a sqrt(Du/Dv))^2 < b < 1 + a^2``; homogeneous state ``(a, b/a)``.
    """
    return Model(
        name="brusselator",
        dt=0.01, t_end=60.0, init="noise",
        species=("u", "v"),
        params={"a": 4.5, "b": 7.5, "Du": 2.0, "Dv": 16.0},
        reaction=_brusselator_reaction,
        diffusion=_coefficients("Du", "Dv"),
        ground=lambda p: (p["a"], p["b"] / p["a"]),
        display="u",
        description="Brusselator: hexagonal spots near the Turing threshold",
        reference="Prigogine & Lefever 1968; Murray 2003 vol. II §2.6",
    )


def _fhn_reaction(u, p, c):
    a, b = u[0], u[1]
    return _stack(a - a**3 - b + p["alpha"], p["epsilon"] * (a - p["a1"] * b - p["a0"]))


@register
def fitzhugh_nagumo() -> Model:
    """FitzHugh-Nagumo in its reaction-diffusion (Turing) form (FitzHugh 1961; Nagumo 1962).

    .. math::
        \\dot u = u - u^3 - v + \\alpha + D_u\\nabla^2 u,\\qquad
        \\dot v = \\varepsilon(u - a_1 v - a_0) + D_v\\nabla^2 v

    With ``epsilon * a1 > 1`` and ``a1 < 1`` the homogeneous state is stable and a fast-diffusing
    inhibitor ``v`` gives labyrinthine stripes.
    """
    return Model(
        name="fitzhugh-nagumo",
        dt=0.01, t_end=100.0, init="noise",
        species=("u", "v"),
        params={"alpha": 0.0, "epsilon": 4.0, "a1": 0.5, "a0": 0.0, "Du": 1.0, "Dv": 20.0},
        reaction=_fhn_reaction,
        diffusion=_coefficients("Du", "Dv"),
        excited=lambda p: (0.5, 0.0),
        display="u",
        description="FitzHugh-Nagumo excitable medium in the Turing regime: labyrinths",
        reference="FitzHugh 1961; Nagumo et al. 1962",
    )


def _activator_inhibitor_reaction(u, p, c):
    a, h = u[0], u[1]
    da = p["rho_a"] * a * a / (h + p["kappa"]) + p["rho_a0"] - p["mu_a"] * a
    dh = p["rho_h"] * a * a + p["rho_h0"] - p["mu_h"] * h
    return _stack(da, dh)


@register
def activator_inhibitor() -> Model:
    """Activator-inhibitor (Ringham et al. eq. 19; Gierer & Meinhardt 1972).

    .. math::
        \\dot a = \\rho_a\\frac{a^2}{h+\\kappa} + \\rho_{a0} - \\mu_a a + D_a\\nabla^2 a,\\qquad
        \\dot h = \\rho_h a^2 + \\rho_{h0} - \\mu_h h + D_h\\nabla^2 h

    Reaction rates are Ringham's *Mimulus* values (fig. 13, ``rho_a0 = 0.0125``); their mesh
    diffusion ``D_a = 2.5e-5``, ``D_h = 1e-3`` is rescaled to a unit grid keeping the ratio 40.
    """
    return Model(
        name="activator-inhibitor",
        dt=0.2, t_end=2000.0, init="noise",
        species=("a", "h"),
        params={"rho_a": 0.05, "rho_a0": 0.0125, "kappa": 0.0, "mu_a": 0.05, "rho_h": 0.05,
                "rho_h0": 0.0, "mu_h": 0.08, "Da": 0.025, "Dh": 1.0},
        reaction=_activator_inhibitor_reaction,
        diffusion=_coefficients("Da", "Dh"),
        display="a",
        presets={
            "mimulus": {"rho_a0": 0.0125, "kappa": 0.0, "Da": 2.5e-5, "Dh": 1e-3},
            "digitalis": {"kappa": 0.001, "Da": 4.0e-5, "Dh": 1.5e-3},
        },
        description="Gierer-Meinhardt activator-inhibitor with basal production: spots",
        reference="Ringham et al. 2021 eq. 19, figs. 13-14",
    )


def _turing_reaction(u, p, c):
    a, b = u[0], u[1]
    return _stack(p["rho"] * (p["alpha"] - a * b), p["rho"] * (a * b - b - p["beta"]))


@register
def turing() -> Model:
    """Turing's model (Ringham et al. eq. 20; Turing 1952).

    .. math::
        \\dot u = \\rho(\\alpha - uv) + D_u\\nabla^2 u,\\qquad
        \\dot v = \\rho(uv - v - \\beta) + D_v\\nabla^2 v

    Homogeneous state ``v* = alpha - beta``, ``u* = alpha / v*``. Rates are Ringham's
    *Kohleria* values (fig. 16, ``alpha = 16``); their mesh diffusion (``D_u = 0.18``,
    ``D_v = 0.0375``) is rescaled to a unit grid keeping the ratio 4.8.

    Concentrations are bounded below by zero, as in Turk (1991)'s use of this model: without the
    bound the linear instability drives ``v`` negative and the ``uv`` term diverges (measured:
    blow-up by ``t ~ 600`` at the defaults). The bound is declared by the model (``clamp``) and
    reported in ``run.json``; pass ``clamp=None`` (``--clamp none``) to run without it.
    """
    return Model(
        name="turing",
        dt=0.25, t_end=2500.0, init="noise", clamp=(0.0, 1e6),
        species=("u", "v"),
        params={"rho": 0.035, "alpha": 16.0, "beta": 12.0, "Du": 0.72, "Dv": 0.15},
        reaction=_turing_reaction,
        diffusion=_coefficients("Du", "Dv"),
        ground=lambda p: (p["alpha"] / (p["alpha"] - p["beta"]), p["alpha"] - p["beta"]),
        display="v",
        presets={"kohleria": {"Du": 0.18, "Dv": 0.0375}},
        description="Turing's 1952 model: spots (high alpha) to stripes (low alpha)",
        reference="Ringham et al. 2021 eq. 20, fig. 16; Turing 1952",
    )


def _activator_substrate_reaction(u, p, c):
    a, s = u[0], u[1]
    r = p["rho"] * s * a * a
    return _stack(r + p["rho_a0"] - p["mu_a"] * a, -r + p["rho_s0"] - p["mu_s"] * s)


@register
def activator_substrate() -> Model:
    """Activator-substrate (Ringham et al. eq. 22; Gierer & Meinhardt 1972).

    .. math::
        \\dot a = \\rho s a^2 + \\rho_{a0} - \\mu_a a + D_a\\nabla^2 a,\\qquad
        \\dot s = -\\rho s a^2 + \\rho_{s0} - \\mu_s s + D_s\\nabla^2 s

    Equivalent to Gray-Scott with ``s = u``, ``a = v``, ``F = rho_s0 = mu_s``,
    ``k = mu_a - F``. Reaction rates are Ringham's *Phalaenopsis* values (fig. 20); their mesh
    diffusion (``D_a = 0.25``, ``D_s = 0.5``, preset ``phalaenopsis``) is scaled by 1/4 for a
    unit grid, where seed points (``--init seeds``) then coalesce into spots as in their fig. 20.
    """
    return Model(
        name="activator-substrate",
        dt=0.3, t_end=3000.0, init="seeds",
        species=("a", "s"),
        params={"rho": 1.0, "rho_a0": 0.0, "mu_a": 0.145, "rho_s0": 0.082, "mu_s": 0.082,
                "Da": 0.0625, "Ds": 0.125},
        reaction=_activator_substrate_reaction,
        diffusion=_coefficients("Da", "Ds"),
        ground=lambda p: (0.0, p["rho_s0"] / p["mu_s"]),
        excited=lambda p: (1.0, 0.5),
        display="a",
        presets={"phalaenopsis": {"Da": 0.25, "Ds": 0.5}},
        description="activator-substrate (Gray-Scott regime): coalescing spots from seeds",
        reference="Ringham et al. 2021 eq. 22, fig. 20",
    )


register(genrd)
register(yamamoto_activator_inhibitor)
