"""The padded mass-action reaction term: network structure as runtime data (Yamamoto eqs. 2-3).

.. math::

    \\frac{ds}{dt} = (M_p - M_e)\\, v,\\qquad
    v_j = a_j\\, k_j \\prod_l s_l^{M_e(l, j)}

with ``a_j`` the slot's active flag. ``M_e``, ``M_p``, ``k`` and ``a`` are arrays handed in at run
time, so one compiled program evaluates a whole population of *different* topologies under
``vmap`` and a new topology never retraces. Entries of ``M_e`` are at most 3 (§4.2), so
``s^e`` is picked from ``1, s, s², s³`` by selects, which is exact for ``e ∈ {0, 1, 2, 3}``
(``0^0 = 1``; negative ``s`` stays well-defined) and matches the repeated products of the
fixed-structure :func:`morphogen.models.network.mass_action`.

It is the reference definition (tests, exports, the well-mixed relaxation of
:func:`morphogen.search.networks.evolve.homogeneous_states`); the evaluation integrates with the
faster population kernel of :mod:`morphogen.search.networks.lanes`, equal to float32 rounding.
"""

from __future__ import annotations

from typing import Any

import jax.numpy as jnp

from morphogen.models.model import Model
from morphogen.search.networks.genome import Genome, NetworkSpec, rates

Array = Any


def integer_power(s: Array, e: Array) -> Array:
    """``s ** e`` for integer ``e ∈ [0, 3]`` given at run time (broadcasting): ``s², s³`` are
    formed once and picked by selects."""
    s2 = s * s
    s3 = s2 * s
    return jnp.where(e == 0, 1.0, jnp.where(e == 1, s, jnp.where(e == 2, s2, s3)))


def fluxes(u: Array, k: Array, educts: Array) -> Array:
    """Reaction fluxes ``v``, shape ``(m, *spatial)``, of a state ``u`` of shape ``(n, *spatial)``.

    ``k`` has shape ``(m,)`` (zero for inactive slots), ``educts`` ``(n, m)``.
    """
    extra = (1,) * (u.ndim - 1)
    powers = integer_power(u[:, None], educts.reshape(educts.shape + extra))
    return k.reshape(k.shape + extra) * jnp.prod(powers, axis=0)


def padded_reaction(u: Array, k: Array, educts: Array, products: Array) -> Array:
    """``(M_p - M_e) v`` for state ``u`` ``(n, *spatial)``; returns the same shape."""
    v = fluxes(u, k, educts)
    net = (products - educts).astype(u.dtype)
    return jnp.tensordot(net, v, axes=(1, 0))


def genome_params(genome: Genome, spec: NetworkSpec) -> dict[str, Array]:
    """Runtime parameters of :func:`padded_model` for a genome (or a population): ``k``
    (inactive slots zeroed), ``Me``, ``Mp`` and ``D_<species>``."""
    lead = genome.mantissa.shape[:-1]
    out: dict[str, Array] = {"k": rates(genome), "Me": genome.educts, "Mp": genome.products}
    for s, d in zip(spec.species, spec.diffusion, strict=True):
        out[f"D_{s}"] = jnp.full(lead, d, jnp.float32)
    return out


def padded_model(spec: NetworkSpec, name: str = "network-genome") -> Model:
    """A :class:`Model` whose reaction reads the network from its parameters (``k``, ``Me``,
    ``Mp`` from :func:`genome_params`), for ``steppers.make_step`` and ``simulate.integrate``.

    Its default parameters are an empty network (static slots at rate 0); a population's
    parameters come from :func:`genome_params`, not from the defaults.
    """
    diff_names = [f"D_{s}" for s in spec.species]
    me, mp = spec.static_structure()
    params: dict[str, Any] = {"k": jnp.zeros(spec.m_max, jnp.float32), "Me": jnp.asarray(me),
                              "Mp": jnp.asarray(mp)}
    params.update(zip(diff_names, spec.diffusion, strict=True))

    def reaction(u, p, c):
        return padded_reaction(u, p["k"], p["Me"], p["Mp"])

    return Model(
        name=name,
        species=spec.species,
        params=params,
        reaction=reaction,
        diffusion=lambda p, c: tuple(p[d] for d in diff_names),
        display=spec.species[0],
        description="mass-action network with runtime structure (padded slots)",
        reference="Yamamoto et al. eqs. 2-3, §3.1",
    )
