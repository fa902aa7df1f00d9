"""The :class:`Stepper` interface: what every fixed-step scheme provides, and the right-hand
side it advances.

A scheme advances

.. math:: \\partial_t u = R(u, p, x, t) + \\nabla\\cdot(D\\nabla u)

by one step ``dt`` at a time. As in diffrax's ``AbstractSolver`` and py-pde's registered
solvers, a scheme is one object, found by its name in :data:`morphogen.solvers.registry.SCHEMES`
(:func:`stepper`), that says

- its ``name`` and ``order`` (the registry row);
- ``limit(model, domain, params)``: its largest stable ``dt`` from the linearised system
  (:mod:`morphogen.solvers.stability`);
- ``amplification(z)``: its factor per step on a linear mode, ``z = dt λ`` (explicit schemes:
  any eigenvalue ``λ`` of the linearisation; schemes with implicit or exact diffusion: a
  diffusion eigenvalue ``λ = D λ(k)`` with no reaction);
- ``advance(model, domain)``: the pure deterministic update for that model on that domain, an
  :class:`Advance` whose ``invariants(p, t0, dt)`` is what the scheme precomputes once per run
  (ETDRK4's exponentials and φ-coefficients; nothing for the others) and whose call
  ``(u, p, t, dt, aux)`` takes one step.

:func:`morphogen.solvers.step.make_step` composes the update with noise, clamping and held
Dirichlet values. Adding a scheme is a module with one :class:`Stepper` subclass (it registers
itself by its ``name``) plus its row in the registry.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.registry import FIXED_STEP, SCHEMES, SchemeInfo


def make_rhs(model: Model, domain: Domain) -> Callable[[Array, Params, Array], Array]:
    """The deterministic right-hand side ``f(u, p, t)`` of the model on the domain.

    ``f = 0`` on held Dirichlet values (:func:`held_mask`): a state whose held cells carry
    their values keeps them through every stage of a Runge-Kutta step, so the boundary enters
    each stage and the scheme keeps its order (resetting it only after the step would leave the
    inner stages with drifted boundary values, an ``O(dt)`` error per unit time).
    """
    bcs = domain.boundaries(model.species)
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}
    held = held_mask(model, domain)

    def rhs(u: Array, p: Params, t: Array) -> Array:
        c = {**coords, "t": t}
        du = model.reaction(u, p, c) + domain.diffuse(u, model.diffusion(p, c), bcs)
        return du if held is None else jnp.where(held, 0.0, du)

    return rhs


def held_mask(model: Model, domain: Domain) -> np.ndarray | None:
    """Where ``domain.hold`` imposes Dirichlet values, shape ``(S, *spatial)``; ``None`` when
    nothing is held."""
    bcs = domain.boundaries(model.species)
    probe = np.full((len(model.species), *domain.spatial_shape), np.nan, np.float32)
    with jax.ensure_compile_time_eval():
        held = np.isfinite(np.asarray(domain.hold(jnp.asarray(probe), bcs)))
    return held if held.any() else None


def no_invariants(p: Params, t0: Array, dt: Array) -> None:
    """The invariants of a scheme that precomputes nothing."""
    return None


@dataclass(frozen=True, eq=False)
class Advance:
    """A scheme's deterministic update for one model on one domain.

    Attributes:
        update: ``update(u, p, t, dt, aux) -> u``, pure; ``aux`` is ``invariants(p, t, dt)``
            or ``None`` (then a scheme that needs them computes them itself).
        invariants: ``invariants(p, t0, dt)``, what stays the same at every step of a run with
            fixed ``dt``, computed once before the time loop.
    """

    update: Callable[[Array, Params, Array, Array, Any], Array]
    invariants: Callable[[Params, Array, Array], Any] = no_invariants

    def __call__(self, u: Array, p: Params, t: Array, dt: Array, aux: Any = None) -> Array:
        return self.update(u, p, t, dt, aux)


_STEPPERS: dict[str, type[Stepper]] = {}


class Stepper(ABC):
    """A fixed-step scheme (see the module docstring).

    The package's subclasses set ``name`` to a row of
    :data:`morphogen.solvers.registry.SCHEMES` and register themselves under it. A user's
    subclass (any other name or module) is not registered: pass an instance wherever a scheme
    name is taken (``make_step``, ``max_stable_dt``, ``simulate``); it is an explicit scheme
    unless it overrides :attr:`info` (e.g. ``implicit_diffusion=True``)."""

    name: ClassVar[str]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        row = SCHEMES.get(cls.__dict__.get("name", ""))
        if row is not None and row.module == cls.__module__:
            _STEPPERS[cls.name] = cls

    @property
    def info(self) -> SchemeInfo:
        """The scheme's registry row (a user's scheme: an explicit fixed-step row)."""
        row = SCHEMES.get(self.name)
        if row is not None and row.module == type(self).__module__:
            return row
        return SchemeInfo(self.name, 0, f"{self.name}, a scheme given as an object",
                          type(self).__module__)

    @property
    def order(self) -> int:
        """Global order of accuracy in ``dt``."""
        return self.info.order

    @abstractmethod
    def limit(self, model: Model, domain: Domain, params: Params, *,
              batched: bool = False) -> float:
        """Largest stable ``dt`` (with a safety margin); with ``batched`` every parameter has a
        leading batch axis and the bound holds for every member."""

    @abstractmethod
    def amplification(self, z: np.ndarray) -> np.ndarray:
        """Factor per step on a linear mode, ``z = dt λ``."""

    @abstractmethod
    def advance(self, model: Model, domain: Domain) -> Advance:
        """The deterministic update for ``model`` on ``domain``.

        Raises:
            MorphogenError: the scheme cannot carry this model on this domain.
        """


def scheme_name(scheme: str | Stepper) -> str:
    """The name of a scheme given by name or as a :class:`Stepper` object."""
    return scheme.name if isinstance(scheme, Stepper) else scheme


def stepper(name: str | Stepper) -> Stepper:
    """The fixed-step scheme called ``name``, imported from the module its registry row names
    (a :class:`Stepper` object is itself).

    Raises:
        MorphogenError: an unknown name, or a scheme chosen per run (``adaptive``, ``auto``).
    """
    if isinstance(name, Stepper):
        return name
    info = SCHEMES.get(name)
    if info is None:
        raise MorphogenError(f"unknown scheme {name!r}; use one of {', '.join(FIXED_STEP)}")
    if not info.fixed_step:
        raise MorphogenError(f"scheme {name} is chosen per run, not per step; pass it to "
                             f"simulate, or use one of {', '.join(FIXED_STEP)} here")
    if name not in _STEPPERS:
        importlib.import_module(info.module)
    return _STEPPERS[name]()
