"""Classic reaction-diffusion models with default parameters that form a pattern.

Every model is registered under its kebab-case command-line name in :data:`LIBRARY`. Grid
defaults assume ``dx = 1``; values taken from mesh case studies (Ringham et al.) are rescaled to a
unit-spaced grid, keeping their ratio ``D_inhibitor / D_activator``, and the docstring says so.
"""

from __future__ import annotations

from collections.abc import Callable

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.genrd import genrd
from morphogen.models.model import Model, Params
from morphogen.models.network import yamamoto_activator_inhibitor

LIBRARY: dict[str, Callable[[], Model]] = {}
"""Model factories by command-line name."""


def register(factory: Callable[[], Model]) -> Callable[[], Model]:
    """Add a model factory to :data:`LIBRARY` under its model's name."""
    LIBRARY[factory().name] = factory
    return factory


def get_model(name: str) -> Model:
    """The library model ``name``, or a clear error listing the known names."""
    if name not in LIBRARY:
        raise MorphogenError(
            f"unknown model {name!r}; known models: {', '.join(sorted(LIBRARY))} "
            "(or give a model file ending in .toml)"
        )
    return LIBRARY[name]()


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
    return jnp.stack([-r + p["F"] * (1.0 - a), r - (p["F"] + p["k"]) * b])


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
    return jnp.stack([du, dv])


def _gm_ground(p) -> tuple[float, float]:
    """Homogeneous state of Skaggs eqs. 2.5-2.6: ``kappa mu v^3 + mu v - nu = 0``, ``u = v^2/nu``."""
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
