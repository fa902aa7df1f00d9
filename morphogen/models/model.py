"""The Model: species, parameters, reaction terms and diffusion coefficients.

A reaction-diffusion model is the system (Skaggs eq. 2.2; Yamamoto eq. 1)

.. math::

    \\partial_t u_i = R_i(u, p, x, t) + \\nabla\\cdot(D_i(p, x) \\nabla u_i),\\qquad i = 1..S

A :class:`Model` holds the pointwise part ``R`` and the coefficients ``D``; the domain (a grid or
a mesh) supplies the diffusion operator. Parameters are a runtime pytree (a dict of arrays), never
compile-time constants, so one compiled program serves a whole batch of parameter sets and
``jax.grad`` flows through them.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from morphogen.errors import MorphogenError

Array = Any
Params = Mapping[str, Array]
Coords = Mapping[str, Array]
"""Position and time: ``x``, ``y``, ``z`` (arrays broadcastable to the spatial shape) and ``t``."""

CENTRE: Coords = {"x": 0.5, "y": 0.5, "z": 0.5, "t": 0.0}
"""Where a homogeneous state is evaluated (ground states, Jacobians, time-step limits): the
centre of the unit square at ``t = 0``, for terms that read position or time."""


INITIAL_NAMES = ("uniform", "noise", "square", "blobs", "skaggs", "seeds", "random", "image", "npz")
"""The initial conditions a model file may suggest with ``init``: the names of the builders in
:data:`morphogen.engine.initial.INITIAL_KINDS` (kept here so that parsing a model needs no
engine)."""


class Tensor(NamedTuple):
    """A symmetric 2D diffusion tensor field ``[[xx, xy], [xy, yy]]`` (each scalar or field)."""

    xx: Array
    xy: Array
    yy: Array


Reaction = Callable[[Array, Params, Coords], Array]
"""``reaction(u, p, c)``: ``u`` has shape ``(S, *spatial)``; returns the same shape."""

Diffusion = Callable[[Params, Coords], tuple]
"""``diffusion(p, c)``: one coefficient per species (scalar, field, or :class:`Tensor`)."""


@dataclass(frozen=True, eq=False)
class Model:
    """A reaction-diffusion model.

    Attributes:
        name: kebab-case name (the command-line name for library models).
        species: species names, in state order; ``u`` arrays have shape ``(S, *spatial)``.
        params: default parameter values (floats), which form a pattern.
        reaction: pointwise reaction terms ``R(u, p, c) -> (S, *spatial)``.
        diffusion: per-species diffusion coefficients ``D(p, c)``.
        ground: the unperturbed state ``ground(p) -> S floats`` (a homogeneous steady state);
            initial conditions perturb it.
        excited: the perturbation values ``excited(p) -> S floats`` used by seeded initial
            conditions (squares, blobs, seed points).
        display: the species shown in images by default.
        presets: named parameter sets (partial; the rest come from ``params``).
        description: one line for ``morphogen models``.
        reference: the seed equation(s) it implements.
        source: the model file text, for models parsed from a file (so runs can be reproduced).
        dt: suggested time step (stable on a unit grid with the default parameters).
        t_end: suggested simulated time for the default parameters to form their pattern.
        init: suggested initial condition kind (see :mod:`morphogen.engine.initial`).
        init_options: options of that kind used unless the run gives its own (e.g. the blob
            density of a neural model's seed states).
        clamp: physical bounds the model itself declares (e.g. non-negative concentrations
            in Turk's formulation of Turing's model); used unless the caller overrides it.
        colours: the model's own picture of a state, ``state (S, *spatial) -> float RGB
            (*spatial, 3)`` in ``[0, 1]`` (e.g. a neural model's RGB channels); images use it
            unless a species or colour map is asked for. ``None``: the display species through
            a colour map.
    """

    name: str
    species: tuple[str, ...]
    params: Mapping[str, float]
    reaction: Reaction
    diffusion: Diffusion
    ground: Callable[[Params], tuple[float, ...]] | None = None
    excited: Callable[[Params], tuple[float, ...]] | None = None
    display: str | None = None
    presets: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    description: str = ""
    reference: str = ""
    source: str | None = None
    dt: float = 1.0
    t_end: float = 1000.0
    init: str = "noise"
    init_options: Mapping[str, Any] = field(default_factory=dict)
    clamp: tuple[float, float] | None = None
    colours: Callable[[np.ndarray], np.ndarray] | None = None

    def __post_init__(self) -> None:
        if not self.species:
            raise MorphogenError(f"model {self.name!r} has no species")
        if len(set(self.species)) != len(self.species):
            raise MorphogenError(f"model {self.name!r} repeats a species name: {self.species}")
        clash = set(self.species) & set(self.params)
        if clash:
            raise MorphogenError(
                f"model {self.name!r}: {sorted(clash)} used both as species and parameter"
            )
        if self.display is not None and self.display not in self.species:
            raise MorphogenError(f"model {self.name!r}: display species {self.display!r} unknown")

    @property
    def display_species(self) -> str:
        """The species rendered by default (the last one unless set)."""
        return self.display or self.species[-1]

    def species_index(self, name: str) -> int:
        """Index of species ``name`` in the state, or a clear error."""
        if name not in self.species:
            raise MorphogenError(
                f"unknown species {name!r} for model {self.name}; species are "
                + ", ".join(self.species)
            )
        return self.species.index(name)

    def parameters(
        self, overrides: Mapping[str, Any] | None = None, *, preset: str | None = None
    ) -> dict[str, Any]:
        """Default parameters, updated by a preset and then by ``overrides``.

        Raises:
            MorphogenError: for an unknown preset or parameter name.
        """
        out: dict[str, Any] = dict(self.params)
        if preset is not None:
            if preset not in self.presets:
                known = ", ".join(sorted(self.presets)) or "none"
                raise MorphogenError(
                    f"unknown preset {preset!r} for model {self.name}; presets: {known}"
                )
            out.update(self.presets[preset])
        for key, value in (overrides or {}).items():
            if key not in self.params:
                raise MorphogenError(
                    f"unknown parameter {key!r} for model {self.name}; parameters are "
                    + ", ".join(self.params)
                )
            out[key] = value
        return out

    def ground_state(self, params: Params) -> np.ndarray:
        """The unperturbed homogeneous state, shape ``(S,)``.

        Uses ``ground`` when given, otherwise a damped Newton iteration on ``R(u) = 0`` for
        spatially constant parameters, starting from ones.
        """
        scalar = {k: _scalar(v) for k, v in params.items()}
        if self.ground is not None:
            return np.asarray(self.ground(scalar), dtype=np.float64)
        return _newton_steady_state(self, scalar)

    def excited_state(self, params: Params) -> np.ndarray:
        """Values used inside seeded perturbations, shape ``(S,)``."""
        scalar = {k: _scalar(v) for k, v in params.items()}
        if self.excited is not None:
            return np.asarray(self.excited(scalar), dtype=np.float64)
        g = self.ground_state(scalar)
        return g + 0.5 * np.maximum(np.abs(g), 0.1)


def _scalar(value: Any) -> float:
    """A parameter's spatial mean: homogeneous states use the mean of a parameter field."""
    return float(np.mean(np.asarray(value, dtype=np.float64)))


def reaction_jacobian(model: Model, u: Array, params: Params, coords: Coords = CENTRE) -> Array:
    """The reaction's Jacobian at one homogeneous state ``u`` (shape ``(S,)``), shape ``(S, S)``:

    .. math:: J_{ij} = \\partial R_i / \\partial u_j\\,(u, p, x)

    (Murray, Mathematical Biology II, ch. 2: the ``J`` of the linearised system), by forward
    mode over the species axis (``jax.jacfwd``, ``S`` tangents). Pure JAX: ``jit`` and ``vmap``
    it over states and parameters. The one Jacobian of the package: the ground-state Newton
    iteration here, the dispersion relation of :mod:`morphogen.models.linear` and the time-step
    limits of :mod:`morphogen.solvers.stability` all use it.
    """
    import jax

    def f(v: Array) -> Array:
        return model.reaction(v.reshape(-1, 1), params, coords).reshape(-1)

    return jax.jacfwd(f)(u)


_NEWTON: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _newton_program(model: Model) -> Any:
    """The model's damped Newton iteration (60 steps of 0.7 times the least-squares step, from
    ``u = 1``) as one compiled program of the parameters, kept for the model's lifetime: op by
    op the 60 steps took 2.3 s the first time and 0.4 s per call after."""
    if model not in _NEWTON:
        import jax
        import jax.numpy as jnp

        def solve(p: Params) -> Array:
            def newton(_, u):
                jac = reaction_jacobian(model, u, p)
                r = model.reaction(u.reshape(-1, 1), p, CENTRE).reshape(-1)
                return u - 0.7 * jnp.linalg.lstsq(jac, r)[0]

            return jax.lax.fori_loop(0, 60, newton, jnp.ones(len(model.species), jnp.float32))

        _NEWTON[model] = jax.jit(solve)
    return _NEWTON[model]


def _newton_steady_state(model: Model, params: Params) -> np.ndarray:
    """A homogeneous steady state ``R(u) = 0`` by damped Newton steps (float32)."""
    p = {k: np.float32(v) for k, v in params.items()}
    u = np.asarray(_newton_program(model)(p), dtype=np.float64)
    if not np.all(np.isfinite(u)):
        return np.ones(len(model.species))
    return u
