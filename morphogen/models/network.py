"""Mass-action reaction networks (Yamamoto et al. eqs. 2-3).

A network of ``n`` species and ``m`` reactions is given by the educt and product stoichiometric
matrices ``M_e``, ``M_p`` (shape ``(n, m)``), rate constants ``k`` and diffusion coefficients:

.. math::

    \\frac{ds}{dt} = M v,\\qquad M = M_p - M_e,\\qquad
    v_j = k_j \\prod_{l} s_l^{M_e(l, j)}

The matrices are the network's structure (fixed at construction); the rates ``k1..km`` and
diffusion coefficients ``D_<species>`` are runtime parameters, so a population of rate vectors is
one batched program.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Model


def mass_action(
    name: str,
    species: Sequence[str],
    educts: np.ndarray,
    products: np.ndarray,
    rates: Sequence[float],
    diffusion: Sequence[float],
    *,
    description: str = "",
    reference: str = "Yamamoto et al. eqs. 2-3",
    display: str | None = None,
    ground: tuple[float, ...] | None = None,
    excited: tuple[float, ...] | None = None,
) -> Model:
    """Build a :class:`Model` from stoichiometric matrices (Yamamoto eqs. 2-3).

    Args:
        educts: ``M_e``, non-negative integers, shape ``(n, m)``.
        products: ``M_p``, non-negative integers, shape ``(n, m)``.
        rates: default rate constants ``k_j``, length ``m`` (parameters ``k1..km``).
        diffusion: default diffusion coefficients, length ``n`` (parameters ``D_<species>``).
        ground, excited: homogeneous state and perturbation values, if known.
    """
    me = np.asarray(educts, dtype=np.int64)
    mp = np.asarray(products, dtype=np.int64)
    n = len(species)
    if me.shape != mp.shape or me.ndim != 2 or me.shape[0] != n:
        raise MorphogenError(
            f"stoichiometric matrices must both have shape (species={n}, reactions), "
            f"got {me.shape} and {mp.shape}"
        )
    if (me < 0).any() or (mp < 0).any():
        raise MorphogenError("stoichiometric matrices must be non-negative integers")
    m = me.shape[1]
    if len(rates) != m or len(diffusion) != n:
        raise MorphogenError(f"need {m} rate constants and {n} diffusion coefficients")
    net = mp - me
    rate_names = [f"k{j + 1}" for j in range(m)]
    diff_names = [f"D_{s}" for s in species]

    def reaction(u, p, c):
        fluxes = []
        for j in range(m):
            v = p[rate_names[j]] * jnp.ones_like(u[0])
            for lidx in range(n):
                if me[lidx, j]:
                    v = v * u[lidx] ** int(me[lidx, j])
            fluxes.append(v)
        rows = []
        for i in range(n):
            terms = [int(net[i, j]) * fluxes[j] for j in range(m) if net[i, j]]
            rows.append(sum(terms) if terms else jnp.zeros_like(u[0]))
        return jnp.stack(rows)

    params = dict(zip(rate_names, map(float, rates), strict=True))
    params.update(zip(diff_names, map(float, diffusion), strict=True))
    return Model(
        name=name,
        species=tuple(species),
        params=params,
        reaction=reaction,
        diffusion=lambda p, c: tuple(p[d] for d in diff_names),
        display=display,
        ground=(lambda p: ground) if ground is not None else None,
        excited=(lambda p: excited) if excited is not None else None,
        description=description,
        reference=reference,
    )


def yamamoto_activator_inhibitor() -> Model:
    """The activator-inhibitor-catalyst network of Yamamoto et al. §2.1 (their Fig. 1 spots).

    Reactions (the catalyst ``c`` is needed for autocatalysis and consumed by the inhibitor):

    ====  ======================  ===================
    R1    2a + c -> 3a + c        k1 = 0.01
    R2    2a -> 2a + h            k2 = sigma = 0.02
    R3    h + c -> h              k3 = 0.1 (their k2)
    R4    a -> 0                  k4 = mu_a = 0.01
    R5    h -> 0                  k5 = mu_h = 0.02
    R6    0 -> c                  k6 = rho_c = 0.1
    ====  ======================  ===================

    With ``c`` in quasi-steady state, ``c = rho_c / (k3 h)`` and the activator equation becomes
    Gierer-Meinhardt (Yamamoto eq. 4) with ``sigma_a = k1 rho_c / k3``; the homogeneous steady
    state is ``a = h = c = 1``. ``D_a = 0.005``, ``D_h = 0.2``, ``D_c = 0`` (their §2.1).
    The reaction scheme itself is drawn in a figure of the seed; this table is reconstructed
    from the text ("a catalyst C that is needed in the autocatalysis of A but is consumed by
    H") and reproduces eqs. 4-5 as stated.
    """
    #                R1 R2 R3 R4 R5 R6
    educts = np.array([[2, 2, 0, 1, 0, 0],   # a
                       [0, 0, 1, 0, 1, 0],   # h
                       [1, 0, 1, 0, 0, 0]])  # c
    products = np.array([[3, 2, 0, 0, 0, 0],
                         [0, 1, 1, 0, 0, 0],
                         [1, 0, 0, 0, 0, 1]])
    model = mass_action(
        "yamamoto-network",
        ("a", "h", "c"),
        educts,
        products,
        rates=(0.01, 0.02, 0.1, 0.01, 0.02, 0.1),
        diffusion=(0.005, 0.2, 0.0),
        description="mass-action activator-inhibitor-catalyst network: spots",
        display="a",
        ground=(1.0, 1.0, 1.0),
        excited=(2.0, 1.0, 1.0),
    )
    return replace(model, dt=1.0, t_end=3000.0, init="noise")
