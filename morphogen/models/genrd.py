"""GenRD: Skaggs's generalised two-species rational reaction model (eqs. 3.1-3.2).

.. math::

    \\dot u = \\sum_{t=1}^{3} \\frac{\\sum_{i,j=0}^{2} \\alpha_{u,t,i,j} u^i v^j}
                               {\\sum_{i,j=0}^{2} \\beta_{u,t,i,j} u^i v^j} + D_u \\nabla^2 u

and likewise for ``v``. Parameters are named ``alpha_u1_ij`` / ``beta_u1_ij`` (species ``u`` or
``v``, term ``1..3``, powers ``i`` of ``u`` and ``j`` of ``v``): 108 coefficients plus ``Du``,
``Dv``.

Near-zero denominators are handled explicitly: each term is evaluated as
``N * B / (B^2 + eps^2)``, which equals ``N / B`` whenever ``|B| >> eps`` and is bounded
(``|N| / (2 eps)``), finite and differentiable when ``B`` crosses zero — never NaN and never an
uninitialised value. A term whose denominator is identically zero contributes nothing.

The defaults embed Gray-Scott (Skaggs eqs. 2.3-2.4, F = 0.037, k = 0.06) so GenRD forms a
pattern out of the box; the preset ``skaggs-table-3.1`` sets Skaggs's ``Du = Dv = 1``.
"""

from __future__ import annotations

import itertools

from morphogen.models.model import Model

EPS = 1e-6
"""Regularisation of GenRD denominators."""

SPECIES = ("u", "v")
TERMS = (1, 2, 3)
POWERS = tuple(itertools.product(range(3), range(3)))


def coefficient_name(kind: str, species: str, term: int, i: int, j: int) -> str:
    """``alpha_u1_02``: coefficient of ``u^0 v^2`` in the numerator of term 1 of ``du/dt``."""
    return f"{kind}_{species}{term}_{i}{j}"


def _gray_scott_embedding(f: float = 0.037, k: float = 0.06) -> dict[str, float]:
    p = {
        coefficient_name(kind, s, t, i, j): 0.0
        for kind in ("alpha", "beta")
        for s in SPECIES
        for t in TERMS
        for i, j in POWERS
    }
    for s in SPECIES:
        for t in TERMS:
            p[coefficient_name("beta", s, t, 0, 0)] = 1.0
    # du/dt = -u v^2 + F - F u ;  dv/dt = u v^2 - (F + k) v
    p[coefficient_name("alpha", "u", 1, 1, 2)] = -1.0
    p[coefficient_name("alpha", "u", 2, 0, 0)] = f
    p[coefficient_name("alpha", "u", 2, 1, 0)] = -f
    p[coefficient_name("alpha", "v", 1, 1, 2)] = 1.0
    p[coefficient_name("alpha", "v", 2, 0, 1)] = -(f + k)
    return p


def _polynomial(p, kind: str, s: str, t: int, powers_u, powers_v):
    return sum(
        p[coefficient_name(kind, s, t, i, j)] * powers_u[i] * powers_v[j] for i, j in POWERS
    )


def _reaction(u, p, c):
    import jax.numpy as jnp

    a, b = u[0], u[1]
    pu = (jnp.ones_like(a), a, a * a)
    pv = (jnp.ones_like(b), b, b * b)
    rates = []
    for s in SPECIES:
        total = jnp.zeros_like(a)
        for t in TERMS:
            num = _polynomial(p, "alpha", s, t, pu, pv)
            den = _polynomial(p, "beta", s, t, pu, pv)
            total = total + num * den / (den * den + EPS * EPS)
        rates.append(total)
    return jnp.stack(rates)


def genrd() -> Model:
    """The GenRD model (Skaggs eqs. 3.1-3.2, table 3.1)."""
    params = _gray_scott_embedding()
    params.update({"Du": 0.2097, "Dv": 0.105})
    return Model(
        name="genrd",
        dt=1.0,
        t_end=6000.0,
        init="blobs",
        species=SPECIES,
        params=params,
        reaction=_reaction,
        diffusion=lambda p, c: (p["Du"], p["Dv"]),
        ground=lambda p: (1.0, 0.0),
        excited=lambda p: (0.5, 0.25),
        display="v",
        presets={"skaggs-table-3.1": {"Du": 1.0, "Dv": 1.0}},
        description="GenRD: sums of three rational terms of degree <= 2 in u and v",
        reference="Skaggs 2022 eqs. 3.1-3.2, table 3.1",
    )
