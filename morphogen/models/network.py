"""Mass-action reaction networks (Yamamoto et al. eqs. 2-3).

A network of ``n`` species and ``m`` reactions is given by the educt and product stoichiometric
matrices ``M_e``, ``M_p`` (shape ``(n, m)``), rate constants ``k`` and diffusion coefficients:

.. math::

    \\frac{ds}{dt} = M v,\\qquad M = M_p - M_e,\\qquad
    v_j = k_j \\prod_{l} s_l^{M_e(l, j)}

The matrices are the network's structure (fixed at construction); the rates (``k1..km`` unless
named) and diffusion coefficients ``D_<species>`` are runtime parameters, so a population of rate
vectors is one batched program. :class:`ReactionNetwork` is the same network as plain data (names,
matrices, values), the common form of imported Antimony/SBML files, evolved genomes and the
hand-made network, from which models, files and drawings are made.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, replace

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
    rate_names: Sequence[str] | None = None,
) -> Model:
    """Build a :class:`Model` from stoichiometric matrices (Yamamoto eqs. 2-3).

    Args:
        educts: ``M_e``, non-negative integers, shape ``(n, m)``.
        products: ``M_p``, non-negative integers, shape ``(n, m)``.
        rates: default rate constants ``k_j``, length ``m`` (parameters ``k1..km``).
        diffusion: default diffusion coefficients, length ``n`` (parameters ``D_<species>``).
        ground, excited: homogeneous state and perturbation values, if known.
        rate_names: parameter names of the rates (default ``k1..km``); reactions may share a
            name (and then its value).
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
    rate_names = list(rate_names) if rate_names is not None else [f"k{j + 1}" for j in range(m)]
    if len(rate_names) != m:
        raise MorphogenError(f"need {m} rate names, got {len(rate_names)}")
    diff_names = [f"D_{s}" for s in species]

    def reaction(u, p, c):
        import jax.numpy as jnp

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


@dataclass(frozen=True, eq=False)
class ReactionNetwork:
    """A mass-action network as data: ``ds/dt = (M_p - M_e) v``, ``v_j = k_j Π_l s_l^{M_e(l,j)}``
    (Yamamoto eqs. 2-3), with the names a file or a model gives its parts.

    Attributes:
        name: model name.
        species: species names, length ``n``.
        educts, products: ``M_e``, ``M_p``, non-negative integers, shape ``(n, m)``.
        reaction_ids: reaction names, length ``m``.
        rate_names: the rate parameter of each reaction (reactions may share one).
        rates: the rate value of each reaction (equal for a shared name).
        diffusion: default diffusion coefficients (parameters ``D_<species>``), length ``n``.
        initial: homogeneous initial state, if known.
        display: the species shown by default.
        dt, t_end, init: suggested time step, simulated time and initial condition kind.
    """

    name: str
    species: tuple[str, ...]
    educts: np.ndarray
    products: np.ndarray
    reaction_ids: tuple[str, ...]
    rate_names: tuple[str, ...]
    rates: tuple[float, ...]
    diffusion: tuple[float, ...]
    initial: tuple[float, ...] | None = None
    display: str | None = None
    description: str = ""
    reference: str = "Yamamoto et al. eqs. 2-3"
    dt: float = 1.0
    t_end: float = 1000.0
    init: str = "noise"

    def __post_init__(self) -> None:
        from morphogen.models.expr import RESERVED

        n, m = len(self.species), len(self.reaction_ids)
        me, mp = np.asarray(self.educts), np.asarray(self.products)
        if me.shape != (n, m) or mp.shape != (n, m):
            raise MorphogenError(f"network {self.name!r}: stoichiometric matrices must have "
                                 f"shape ({n}, {m}), got {me.shape} and {mp.shape}")
        if (me < 0).any() or (mp < 0).any():
            raise MorphogenError(f"network {self.name!r}: negative stoichiometric entry")
        if len(self.rate_names) != m or len(self.rates) != m or len(self.diffusion) != n:
            raise MorphogenError(f"network {self.name!r}: need {m} rates and {n} diffusion "
                                 "coefficients")
        if self.initial is not None and len(self.initial) != n:
            raise MorphogenError(f"network {self.name!r}: need {n} initial values")
        names = list(self.species) + [f"D_{s}" for s in self.species]
        if len(set(names)) != len(names) or set(names) & set(self.rate_names):
            raise MorphogenError(f"network {self.name!r}: a name is used twice among species, "
                                 "rate parameters and D_<species>")
        for name in names + list(self.rate_names):
            if not name.isidentifier() or name.startswith("_") or name in RESERVED:
                raise MorphogenError(f"network {self.name!r}: name {name!r} is reserved or not "
                                     "an identifier in morphogen expressions (x, y, z, t, lap "
                                     "and function names are taken); rename it")
        shared: dict[str, float] = {}
        for rid, name, k in zip(self.reaction_ids, self.rate_names, self.rates, strict=True):
            if shared.setdefault(name, k) != k:
                raise MorphogenError(f"network {self.name!r}: rate {name!r} of reaction {rid} "
                                     f"has two values, {shared[name]} and {k}")

    @property
    def parameters(self) -> dict[str, float]:
        """Rates then ``D_<species>``: the model's default parameters."""
        out = dict(zip(self.rate_names, map(float, self.rates), strict=True))
        out.update((f"D_{s}", float(d)) for s, d in zip(self.species, self.diffusion,
                                                         strict=True))
        return out

    def model(self) -> Model:
        """The fixed-structure :func:`mass_action` model of this network."""
        initial = tuple(map(float, self.initial)) if self.initial is not None else None
        model = mass_action(self.name, self.species, self.educts, self.products, self.rates,
                            self.diffusion, rate_names=self.rate_names,
                            description=self.description, reference=self.reference,
                            display=self.display, ground=initial)
        return replace(model, dt=self.dt, t_end=self.t_end, init=self.init)


def to_toml(net: ReactionNetwork) -> str:
    """A morphogen model file (``docs/equations.md``) with the network's equations written out,
    ``ds_i/dt = Σ_j (M_p - M_e)_ij k_j Π_l s_l^{M_e(l,j)} + D_i ∇² s_i``."""
    me, mp = np.asarray(net.educts), np.asarray(net.products)
    flux = []
    for j, k in enumerate(net.rate_names):
        powers = [s if me[i, j] == 1 else f"{s}**{me[i, j]}"
                  for i, s in enumerate(net.species) if me[i, j]]
        flux.append("*".join([k, *powers]))
    lines = [f"name = {json.dumps(net.name, ensure_ascii=False)}"]
    if net.description:
        lines.append(f"description = {json.dumps(net.description, ensure_ascii=False)}")
    lines += [f"reference = {json.dumps(net.reference, ensure_ascii=False)}",
              f"species = [{', '.join(json.dumps(s) for s in net.species)}]"]
    if net.display:
        lines.append(f"display = {json.dumps(net.display, ensure_ascii=False)}")
    lines += [f"dt = {net.dt!r}", f"t_end = {net.t_end!r}",
              f"init = {json.dumps(net.init, ensure_ascii=False)}", "",
              "[parameters]"]
    lines += [f"{k} = {v!r}" for k, v in net.parameters.items()]
    lines += ["", "[equations]"]
    for i, s in enumerate(net.species):
        terms = []
        for j in range(len(net.reaction_ids)):
            c = int(mp[i, j]) - int(me[i, j])
            if c:
                sign = "-" if c < 0 else "+"
                terms.append(f"{sign} {abs(c)}*{flux[j]}" if abs(c) > 1 else f"{sign} {flux[j]}")
        terms.append(f"+ D_{s}*lap({s})")
        equation = " ".join(terms).removeprefix("+ ")
        lines.append(f"{s} = {json.dumps(equation, ensure_ascii=False)}")
    if net.initial is not None:
        lines += ["", "[initial]"]
        lines += [f"{s} = {float(v)!r}" for s, v in zip(net.species, net.initial, strict=True)]
    return "\n".join(lines) + "\n"


def yamamoto_network() -> ReactionNetwork:
    """The activator-inhibitor-catalyst network of :func:`yamamoto_activator_inhibitor` as data."""
    #                R1 R2 R3 R4 R5 R6
    educts = np.array([[2, 2, 0, 1, 0, 0],   # a
                       [0, 0, 1, 0, 1, 0],   # h
                       [1, 0, 1, 0, 0, 0]])  # c
    products = np.array([[3, 2, 0, 0, 0, 0],
                         [0, 1, 1, 0, 0, 0],
                         [1, 0, 0, 0, 0, 1]])
    return ReactionNetwork(
        "yamamoto-network", ("a", "h", "c"), educts, products,
        reaction_ids=tuple(f"R{j + 1}" for j in range(6)),
        rate_names=tuple(f"k{j + 1}" for j in range(6)),
        rates=(0.01, 0.02, 0.1, 0.01, 0.02, 0.1), diffusion=(0.005, 0.2, 0.0),
        initial=(1.0, 1.0, 1.0), display="a",
        description="mass-action activator-inhibitor-catalyst network: spots",
        reference="Yamamoto et al. §2.1, eqs. 2-5", dt=1.0, t_end=3000.0)


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
    net = yamamoto_network()
    model = mass_action(
        net.name,
        net.species,
        net.educts,
        net.products,
        rates=net.rates,
        diffusion=net.diffusion,
        description=net.description,
        display=net.display,
        ground=net.initial,
        excited=(2.0, 1.0, 1.0),
    )
    return replace(model, dt=net.dt, t_end=net.t_end, init="noise")
