"""Turing analysis of a model: every homogeneous fixed point, its stability, the dispersion
relation on a grid and in continuous ``q``, the unstable band and the fastest wavelength.

For each fixed point ``u*`` (:func:`morphogen.models.fixed_points.fixed_points`, float64) the
linearised system's Fourier modes grow at the eigenvalues of ``J - κ² D`` (Murray,
Mathematical Biology II, ch. 2.3), ``J`` the reaction Jacobian at ``u*``. On the grid ``-κ²``
is the stencil's symbol at each of its modes (:func:`morphogen.models.linear.lattice_modes`,
:meth:`morphogen.domains.grid.Grid.symbol`); in continuous space ``κ = q``. The class, the
tolerance and the band follow :func:`morphogen.models.linear.stability`. Wavelengths are given
in cells and in length units (``dx`` per cell); continuous ``q`` is in 1/length.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.models.fixed_points import default_starts, fixed_points, homogeneous_params
from morphogen.models.linear import CLASSES, lattice_modes, stability_program
from morphogen.models.model import CENTRE, Model, Tensor, reaction_jacobian

CURVE_POINTS = 1000
"""Samples of the continuous dispersion relation, ``0 <= q <= π / dx``; the fastest ``q`` is
refined by the parabola through its sample and their neighbours, the band's edges by linear
interpolation of ``σ(q) - tol``."""


@dataclass(frozen=True)
class Band:
    """Unstable wavenumbers and their wavelengths (``None`` when nothing grows)."""

    kappa2: tuple[float, float]
    wavelength: tuple[float, float]
    wavelength_cells: tuple[float, float] | None = None
    modes: int | None = None


@dataclass(frozen=True)
class Fastest:
    """The fastest-growing mode with ``κ > 0``."""

    kappa2: float
    growth: float
    wavelength: float
    wavelength_cells: float | None = None
    mode: tuple[int, ...] | None = None


@dataclass(frozen=True)
class FixedPoint:
    """One homogeneous fixed point and its linear stability.

    Attributes:
        state: ``u*``, one value per species.
        eigenvalues: of ``J`` at ``u*`` (``κ = 0``), as ``[re, im]`` pairs, largest real part
            first.
        cls: ``turing``, ``stable``, ``unstable_k0`` or ``marginal``
            (:data:`morphogen.models.linear.CLASSES`).
        oscillatory: the leading eigenvalue at ``κ = 0`` is complex (Hopf side).
        singular: ``J`` is singular (a conserved quantity, a fold).
        growth0: ``σ(0)``, the homogeneous mode's growth rate.
        grid_band, grid_fastest: on the grid's modes.
        band, fastest: in continuous ``q`` (up to the grid's Nyquist ``π / dx``).
    """

    state: tuple[float, ...]
    eigenvalues: tuple[tuple[float, float], ...]
    cls: str
    oscillatory: bool
    singular: bool
    growth0: float
    grid_band: Band | None
    grid_fastest: Fastest
    band: Band | None
    fastest: Fastest


@dataclass(frozen=True)
class Analysis:
    """:func:`analyse`'s result. ``curves`` (not in :meth:`to_json`'s summary unless asked)
    hold the dispersion relation for plotting: ``q`` ``(Q,)`` and per fixed point ``sigma``
    ``(Q,)``; ``grid_kappa2`` ``(K,)``, the modes' true wavenumbers ``grid_q = 2π / λ``
    ``(K,)`` and per fixed point ``grid_sigma`` ``(K,)``."""

    model: str
    species: tuple[str, ...]
    params: dict[str, float]
    grid: dict[str, Any]
    fixed_points: tuple[FixedPoint, ...]
    curves: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def turing(self) -> tuple[FixedPoint, ...]:
        """The Turing-unstable fixed points."""
        return tuple(f for f in self.fixed_points if f.cls == "turing")

    def to_dict(self, *, curves: bool = False) -> dict[str, Any]:
        """Plain data (JSON-ready); ``curves=True`` adds the sampled dispersion relations."""
        out = {"model": self.model, "species": list(self.species), "params": self.params,
               "grid": self.grid, "fixed_points": [asdict(f) for f in self.fixed_points],
               "classes": list(CLASSES[:-1])}
        if curves:
            out["curves"] = {k: np.asarray(v).tolist() for k, v in self.curves.items()}
        return _finite(out)

    def to_json(self, *, curves: bool = False) -> str:
        """:meth:`to_dict` as JSON text (infinite wavelengths as ``null``)."""
        return json.dumps(self.to_dict(curves=curves), indent=1) + "\n"


def _finite(x: Any) -> Any:
    """``inf``/``nan`` floats become ``None`` (JSON has neither); tuples become lists."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def isotropic_diffusion(model: Model, params: Mapping[str, Any]) -> np.ndarray:
    """Each species' diffusion coefficient (spatial mean), shape ``(S,)``; a tensor, a
    negative or non-finite coefficient, or no diffusing species at all is refused."""
    coeffs = model.diffusion(dict(params), dict(CENTRE))
    out = []
    for name, c in zip(model.species, coeffs, strict=True):
        if isinstance(c, Tensor):
            raise MorphogenError(f"species {name!r} diffuses anisotropically; the Turing "
                                 "analysis needs one diffusion coefficient per species")
        value = float(np.mean(np.asarray(c, np.float64)))
        if not np.isfinite(value) or value < 0:
            raise MorphogenError(f"species {name!r} has diffusion coefficient {value}; it must "
                                 "be a non-negative number")
        out.append(value)
    if not any(out):
        raise MorphogenError(f"no species of {model.name} diffuses (every D is 0): there is no "
                             "diffusion-driven instability to analyse")
    return np.asarray(out)


def analyse(model: Model, params: Mapping[str, Any] | None = None, *,
            size: int | tuple[int, ...] = 128, dx: float = 1.0, stencil: int | str | None = None,
            boundary: str = "periodic", starts: np.ndarray | None = None) -> Analysis:
    """Every homogeneous fixed point of ``model`` at ``params`` (default: its defaults) and its
    Turing analysis on a grid of ``size`` cells per side (or a shape) with spacing ``dx``
    (module docstring).

    Args:
        stencil: the Laplacian whose symbol is used (``5``/``9`` points in 2D, ``7`` in 3D,
            ``"spectral"``; the grid's default when ``None``).
        boundary: ``periodic`` or ``neumann`` (no-flux: cosine modes).
        starts: extra Newton starts ``(K, S)`` before :func:`default_starts`.

    Raises:
        MorphogenError: non-finite parameters, no diffusing species, a tensor diffusion, no
            fixed point, or a singular Jacobian at every fixed point.
    """
    params = dict(model.parameters() if params is None else params)
    for name, value in params.items():
        if not np.all(np.isfinite(np.asarray(value, np.float64))):
            raise MorphogenError(f"parameter {name} = {value!r} is not a finite number")
    shape = tuple(int(n) for n in np.atleast_1d(size))
    shape = shape * 2 if len(shape) == 1 else shape
    if boundary not in ("periodic", "neumann"):
        raise MorphogenError(f"boundary {boundary!r}: the analysis takes periodic or neumann")
    grid = Grid(shape, dx=dx, stencil=stencil, boundary=boundary)
    d = isotropic_diffusion(model, params)
    with jax.enable_x64(True):
        p64 = homogeneous_params(model, params, jnp.float64)
        scalar = {k: float(v) for k, v in p64.items() if not jnp.ndim(v)}
        tries = default_starts(model, scalar)
        if starts is not None:
            tries = np.concatenate([np.asarray(starts, np.float64).reshape(-1, len(d)), tries])
        tries = np.where(np.isfinite(tries), tries, 1.0)
        points = fixed_points(model, params, tries)
        if not len(points):
            raise MorphogenError(
                f"no homogeneous fixed point of {model.name} found at these parameters "
                f"({len(tries)} Newton starts and log-concentration Newton runs)")
        modes = lattice_modes(shape, grid.symbol, periodic=boundary == "periodic")
        q = np.linspace(0.0, np.pi / dx, CURVE_POINTS)
        found = [_one(model, p64, u, modes, q, d, dx) for u in points]
    if all(f[0].singular for f in found):
        raise MorphogenError(
            f"the Jacobian of {model.name} is singular at every fixed point found (a conserved "
            "quantity or a continuum of fixed points): linear stability cannot classify it")
    return Analysis(
        model=model.name, species=tuple(model.species),
        params={k: float(v) for k, v in scalar.items()},
        grid={"shape": list(shape), "dx": float(dx), "stencil": grid.stencil or "default",
              "boundary": boundary, "modes": len(modes.kappa2)},
        fixed_points=tuple(f[0] for f in found),
        curves={"q": q, "sigma": np.stack([f[1] for f in found]),
                "grid_kappa2": modes.kappa2, "grid_q": 2 * np.pi / (modes.wavelength * dx),
                "grid_sigma": np.stack([f[2] for f in found])})


def _one(model: Model, p64: dict, u: np.ndarray, modes: Any, q: np.ndarray, d: np.ndarray,
         dx: float) -> tuple[FixedPoint, np.ndarray, np.ndarray]:
    """One fixed point's :class:`FixedPoint`, continuous ``σ(q)`` and grid ``σ(κ²)``."""
    u64 = jnp.asarray(u, jnp.float64)[None]
    batch = jax.tree.map(lambda a: a[None], p64)
    program = stability_program(model)
    grid_st, line_st = (jax.tree.map(lambda a: a[0], program(batch, u64, jnp.asarray(k2),
                                                             jnp.ones(1, bool)))
                        for k2 in (modes.kappa2, q**2))
    jac = np.asarray(reaction_jacobian(model, u64[0], p64))
    lam = np.linalg.eigvals(jac)
    lam = lam[np.argsort(-lam.real, kind="stable")]
    sv = np.linalg.svd(jac, compute_uv=False)
    sigma = np.asarray(grid_st.sigma)
    unstable = np.asarray(grid_st.unstable)
    fast = int(grid_st.fastest)
    grid_band = None
    if unstable.any():
        k2 = modes.kappa2[unstable]
        cells = modes.wavelength[unstable]
        grid_band = Band(kappa2=(float(k2.min()), float(k2.max())),
                         wavelength=(float(cells.min() * dx), float(cells.max() * dx)),
                         wavelength_cells=(float(cells.min()), float(cells.max())),
                         modes=int(unstable.sum()))
    grid_fastest = Fastest(kappa2=float(modes.kappa2[fast]), growth=float(sigma[fast]),
                           wavelength=float(modes.wavelength[fast] * dx),
                           wavelength_cells=float(modes.wavelength[fast]),
                           mode=tuple(int(m) for m in modes.index[fast]))
    line = np.asarray(line_st.sigma)
    band = _band(q, line, np.asarray(line_st.unstable), float(line_st.tol))
    qf, growth = _vertex(q, line, int(line_st.fastest))
    fastest = Fastest(kappa2=float(qf**2), growth=growth, wavelength=float(2 * np.pi / qf),
                      wavelength_cells=float(2 * np.pi / qf / dx))
    point = FixedPoint(
        state=tuple(float(x) for x in u),
        eigenvalues=tuple((float(z.real), float(z.imag)) for z in lam),
        cls=CLASSES[int(grid_st.cls)], oscillatory=bool(grid_st.oscillatory),
        singular=bool(sv.min() <= 1e-12 * max(sv.max(), 1e-300)),
        growth0=float(sigma[0]), grid_band=grid_band, grid_fastest=grid_fastest, band=band,
        fastest=fastest)
    return point, line, sigma


def _band(q: np.ndarray, sigma: np.ndarray, up: np.ndarray, tol: float) -> Band | None:
    """The continuous unstable band: the first and last unstable samples, each edge moved to
    where ``σ - tol`` crosses 0 between it and its stable neighbour."""
    if not up.any():
        return None
    idx = np.flatnonzero(up)

    def cross(a: int, b: int) -> float:
        fa, fb = sigma[a] - tol, sigma[b] - tol
        return float(q[a] + (q[b] - q[a]) * fa / (fa - fb)) if fa != fb else float(q[b])

    lo = cross(idx[0] - 1, idx[0]) if idx[0] > 1 else float(q[idx[0]])
    hi = cross(idx[-1] + 1, idx[-1]) if idx[-1] + 1 < len(q) else float(q[idx[-1]])
    return Band(kappa2=(lo**2, hi**2), wavelength=(2 * np.pi / hi, 2 * np.pi / lo))


def _vertex(q: np.ndarray, sigma: np.ndarray, i: int) -> tuple[float, float]:
    """The maximum of the parabola through samples ``i - 1, i, i + 1`` (the sample itself at
    the ends)."""
    if i <= 0 or i + 1 >= len(q):
        return float(q[i]), float(sigma[i])
    a, b, c = sigma[i - 1], sigma[i], sigma[i + 1]
    curve = a - 2 * b + c
    if curve >= 0:
        return float(q[i]), float(b)
    shift = 0.5 * (a - c) / curve
    top = q[i] + shift * (q[1] - q[0])
    return (float(top), float(b - 0.25 * (a - c) * shift)) if top > 0 else (float(q[i]), float(b))
