"""Regular 2D and 3D grids: coordinates, boundary conditions and the diffusion operator.

Arrays on a grid have shape ``(S, *shape)``; for a 2D grid ``shape = (ny, nx)`` and for 3D
``(nz, ny, nx)``. The coordinates ``x``, ``y``, ``z`` are cell-centre positions scaled to
``[0, 1]`` along the last, second-last and third-last axes.

Boundaries (per species):

- ``periodic``: the grid is a torus.
- ``neumann`` (no flux): cell-centred mirror ghost cells, so ``sum(u)`` is conserved exactly.
- ``dirichlet`` with value ``g``: the outermost ring of cells is held at ``g``.

The Laplacian is a finite-difference stencil (:mod:`morphogen.domains.stencils`) or, on
periodic grids, the pseudo-spectral operator ``-|k|^2`` (:mod:`morphogen.domains.spectral`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar, cast

import jax.numpy as jnp
import numpy as np

from morphogen.domains import spectral
from morphogen.domains.stencils import STENCILS, Neighbours, Stencil, padded, periodic
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Tensor

BOUNDARY_KINDS = ("periodic", "neumann", "dirichlet")


@dataclass(frozen=True)
class Boundary:
    """One species' boundary condition: ``kind`` in :data:`BOUNDARY_KINDS`, ``value`` for
    Dirichlet."""

    kind: str = "periodic"
    value: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in BOUNDARY_KINDS:
            raise MorphogenError(
                f"unknown boundary {self.kind!r}; use one of {', '.join(BOUNDARY_KINDS)}"
            )

    @classmethod
    def parse(cls, spec: Any) -> Boundary:
        """``'periodic'``, ``'neumann'``, ``'dirichlet'``, ``'dirichlet=0.5'``, a Boundary, or a
        ``(kind, value)`` pair."""
        if isinstance(spec, Boundary):
            return spec
        if isinstance(spec, tuple | list) and len(spec) == 2:
            return cls(str(spec[0]), float(spec[1]))
        text = str(spec).strip().lower()
        if "=" in text:
            kind, _, value = text.partition("=")
            try:
                return cls(kind.strip(), float(value))
            except ValueError:
                raise MorphogenError(f"boundary value in {spec!r} is not a number") from None
        return cls(text)


@dataclass(frozen=True, eq=False)
class Grid:
    """A regular grid.

    Args:
        shape: cells per axis, 2 or 3 axes, each at least 3.
        dx: cell spacing (the same on every axis).
        boundary: one spec for all species, or a mapping species -> spec (key ``"*"`` for the
            rest, periodic if absent).
        stencil: Laplacian stencil: ``5`` or ``9`` points in 2D, ``7`` in 3D, or
            ``"spectral"`` (periodic boundaries only, 2D or 3D).
    """

    kind: ClassVar[str] = "grid"
    shape: tuple[int, ...]
    dx: float = 1.0
    boundary: Any = "periodic"
    stencil: int | str | None = None
    _stencil: Stencil | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        shape = tuple(int(n) for n in self.shape)
        object.__setattr__(self, "shape", shape)
        if len(shape) not in (2, 3):
            raise MorphogenError(f"grid must be 2D or 3D, got shape {shape}")
        if any(n < 3 for n in shape):
            raise MorphogenError(f"every grid axis needs at least 3 cells, got {shape}")
        if not (np.isfinite(self.dx) and self.dx > 0):
            raise MorphogenError(f"dx must be a positive number, got {self.dx}")
        stencil = parse_stencil(self.stencil)
        object.__setattr__(self, "stencil", stencil)
        if isinstance(self.boundary, Mapping):
            kinds = {Boundary.parse(spec).kind for spec in self.boundary.values()}
            if "*" not in self.boundary:
                kinds.add("periodic")
        else:
            kinds = {Boundary.parse(self.boundary).kind}
        if stencil == spectral.SPECTRAL:
            if kinds != {"periodic"}:
                bad = sorted(kinds - {"periodic"})[0]
                raise MorphogenError(
                    f"the spectral stencil needs periodic boundaries, got {bad}; use "
                    f"--stencil {5 if len(shape) == 2 else 7} for {bad} boundaries")
            object.__setattr__(self, "_stencil", None)
            return
        points = stencil or (5 if len(shape) == 2 else 7)
        key = (len(shape), int(points))
        if key not in STENCILS:
            ok = sorted(p for d, p in STENCILS if d == len(shape))
            raise MorphogenError(
                f"no {points}-point stencil in {len(shape)}D; use one of {ok} or spectral"
            )
        object.__setattr__(self, "_stencil", STENCILS[key])

    @property
    def ndim(self) -> int:
        return len(self.shape)

    @property
    def spatial_shape(self) -> tuple[int, ...]:
        return self.shape

    @property
    def size(self) -> int:
        """Number of cells."""
        return int(np.prod(self.shape))

    def boundaries(self, species: Sequence[str]) -> tuple[Boundary, ...]:
        """The boundary condition of each species, in order."""
        if isinstance(self.boundary, Mapping):
            unknown = set(self.boundary) - set(species) - {"*"}
            if unknown:
                raise MorphogenError(
                    f"boundary given for unknown species {sorted(unknown)}; species are "
                    + ", ".join(species)
                )
            default = self.boundary.get("*", "periodic")
            return tuple(Boundary.parse(self.boundary.get(s, default)) for s in species)
        return tuple(Boundary.parse(self.boundary) for _ in species)

    @cached_property
    def coords(self) -> dict[str, np.ndarray]:
        """Cell-centre coordinates in ``[0, 1]``, each broadcastable to ``shape``."""
        names = ("x", "y", "z")
        out: dict[str, np.ndarray] = {}
        for i, name in enumerate(names[: self.ndim]):
            axis = self.ndim - 1 - i
            n = self.shape[axis]
            view = [1] * self.ndim
            view[axis] = n
            out[name] = ((np.arange(n) + 0.5) / n).reshape(view).astype(np.float32)
        if self.ndim == 2:
            out["z"] = np.zeros((1, 1), np.float32)
        return out

    @property
    def is_spectral(self) -> bool:
        """Whether the Laplacian is the pseudo-spectral one."""
        return self._stencil is None

    @property
    def _points(self) -> Stencil:
        """The finite-difference stencil; only called where :attr:`is_spectral` is false."""
        return cast(Stencil, self._stencil)

    def spectral_radius(self) -> float:
        """Largest eigenvalue of ``-Laplacian`` (unit diffusion), for the stability limit."""
        if self.is_spectral:
            return spectral.spectral_radius(self.shape, self.dx)
        return self._points.spectral_radius / self.dx**2

    @property
    def stochastic(self) -> bool:
        """Diffusion on a grid is deterministic (:meth:`diffusion_noise` is zero)."""
        return False

    def diffusion_noise(self, u: Array, coeffs: Sequence[Any], bcs: Sequence[Boundary],
                        dt: Array, key: Array) -> Array:
        """No flux noise on a grid: zeros, shape ``(S, *shape)``."""
        return jnp.zeros_like(u)

    def symbol(self, *k: np.ndarray) -> np.ndarray:
        """Eigenvalue of the Laplacian on the Fourier mode with angular wavenumbers per cell
        ``k`` (one array per axis, in ``[-pi, pi]``), in units of ``1 / dx^2``."""
        op = spectral.symbol if self.is_spectral else self._points.symbol
        return np.asarray(op(*k), np.float64) / self.dx**2

    def laplacian(self, f: Array, bc: Boundary) -> Array:
        """Discrete Laplacian of one field ``f`` (shape ``self.shape``)."""
        if self.is_spectral:
            return spectral.laplacian(f, self.dx)
        return self._points.apply(self._neighbours(f, bc), self.dx)

    def diffuse(self, u: Array, coeffs: Sequence[Any], bcs: Sequence[Boundary]) -> Array:
        """``div(D_i grad u_i)`` for every species; ``u`` has shape ``(S, *shape)``.

        A coefficient is a scalar or field (isotropic, ``D * Laplacian``) or a :class:`Tensor`
        (anisotropic, conservative face fluxes; 2D finite-difference grids only). When every
        coefficient is isotropic and every species pads the same way, the Laplacian runs once
        on the whole ``(S, *shape)`` array (one fused pass instead of one per species: 2-3x
        faster on CPU for Gray-Scott 256², ``bench/results/grid.json``).
        """
        if not any(isinstance(d, Tensor) for d in coeffs) and (
                self.is_spectral or len({_pad_mode(bc) for bc in bcs}) == 1):
            return _stack_coefficients(coeffs, u) * self._laplacian_all(u, bcs[0])
        out = []
        for i, (d, bc) in enumerate(zip(coeffs, bcs, strict=True)):
            if isinstance(d, Tensor):
                if self.is_spectral:
                    raise MorphogenError("anisotropic diffusion uses finite-difference face "
                                         "fluxes; use --stencil 5 instead of spectral")
                out.append(self._tensor_divergence(u[i], d, bc))
            else:
                out.append(d * self.laplacian(u[i], bc))
        return jnp.stack(out)

    def _laplacian_all(self, u: Array, bc: Boundary) -> Array:
        """Laplacian of every species of ``u`` (shape ``(S, *shape)``), padded alike."""
        if self.is_spectral:
            return spectral.laplacian(u, self.dx, self.ndim)
        return self._points.apply(self._neighbours(u, bc), self.dx)

    def _neighbours(self, u: Array, bc: Boundary) -> Neighbours:
        """What the stencil reads: wrapped shifts on a torus where it takes them (fused by XLA,
        :func:`morphogen.domains.stencils.periodic`), else slices of the ghost-padded field."""
        if bc.kind == "periodic" and self._points.shifts:
            return periodic(u, self.ndim)
        pad = ((0, 0),) * (u.ndim - self.ndim) + ((1, 1),) * self.ndim
        return padded(jnp.pad(u, pad, mode=_pad_mode(bc)), self.ndim)

    def hold(self, u: Array, bcs: Sequence[Boundary]) -> Array:
        """Apply Dirichlet values to the outermost ring of cells."""
        if not any(bc.kind == "dirichlet" for bc in bcs):
            return u
        ring = self._ring_mask
        rows = []
        for i, bc in enumerate(bcs):
            rows.append(jnp.where(ring, bc.value, u[i]) if bc.kind == "dirichlet" else u[i])
        return jnp.stack(rows)

    @cached_property
    def _ring_mask(self) -> np.ndarray:
        inner = tuple(slice(1, -1) for _ in self.shape)
        mask = np.ones(self.shape, bool)
        mask[inner] = False
        return mask

    def _tensor_divergence(self, f: Array, d: Tensor, bc: Boundary) -> Array:
        """Conservative ``div(D grad f)`` for a 2D tensor field (Ringham eq. 8 on a grid).

        Fluxes live on cell faces: ``J_x = D_xx df/dx + D_xy df/dy`` with ``df/dx`` the
        two-point difference across the face, ``df/dy`` the four-point average, and face
        coefficients averaged from the two cells; likewise for ``J_y``. No-flux boundaries set
        the boundary-face fluxes to zero, so mass is conserved exactly.
        """
        if self.ndim != 2:
            raise MorphogenError("anisotropic diffusion is available on 2D grids and meshes")
        h = self.dx
        g = _pad(f, bc)
        coef = [jnp.broadcast_to(jnp.asarray(c, g.dtype), self.shape) for c in d]
        cxx, cxy, cyy = (_pad(c, Boundary("neumann")) for c in coef)
        # x faces between columns j and j+1 (for j = 0..nx): shape (ny, nx+1)
        dfdx = (g[1:-1, 1:] - g[1:-1, :-1]) / h
        dfdy_x = (g[2:, 1:] + g[2:, :-1] - g[:-2, 1:] - g[:-2, :-1]) / (4 * h)
        jx = 0.5 * (cxx[1:-1, 1:] + cxx[1:-1, :-1]) * dfdx
        jx = jx + 0.5 * (cxy[1:-1, 1:] + cxy[1:-1, :-1]) * dfdy_x
        # y faces between rows i and i+1: shape (ny+1, nx)
        dfdy = (g[1:, 1:-1] - g[:-1, 1:-1]) / h
        dfdx_y = (g[1:, 2:] + g[:-1, 2:] - g[1:, :-2] - g[:-1, :-2]) / (4 * h)
        jy = 0.5 * (cyy[1:, 1:-1] + cyy[:-1, 1:-1]) * dfdy
        jy = jy + 0.5 * (cxy[1:, 1:-1] + cxy[:-1, 1:-1]) * dfdx_y
        if bc.kind == "neumann":
            jx = jx.at[:, 0].set(0.0).at[:, -1].set(0.0)
            jy = jy.at[0, :].set(0.0).at[-1, :].set(0.0)
        return (jx[:, 1:] - jx[:, :-1]) / h + (jy[1:, :] - jy[:-1, :]) / h


def parse_stencil(value: Any) -> int | str | None:
    """``None``, a number of points (``5``, ``"9"``) or ``"spectral"``, as given on the command
    line or in a run file."""
    if value is None or isinstance(value, int):
        return value
    text = str(value).strip().lower()
    if text == spectral.SPECTRAL:
        return spectral.SPECTRAL
    if text.isdigit():
        return int(text)
    raise MorphogenError(f"unknown stencil {value!r}; use 5, 9 (2D), 7 (3D) or spectral")


def _pad_mode(bc: Boundary) -> str:
    """Ghost cells: wrap for periodic, mirror (edge) for the others."""
    return "wrap" if bc.kind == "periodic" else "edge"


def _pad(f: Array, bc: Boundary) -> Array:
    """Pad one ghost cell on every side of one field."""
    return jnp.pad(f, 1, mode=_pad_mode(bc))


def _stack_coefficients(coeffs: Sequence[Any], u: Array) -> Array:
    """Isotropic coefficients as one array broadcastable against ``u`` (``(S, 1, ...)`` when all
    are scalars, ``(S, *shape)`` when some are fields)."""
    arrays = [jnp.asarray(d, u.dtype) for d in coeffs]
    if all(a.ndim == 0 for a in arrays):
        return jnp.stack(arrays).reshape((-1,) + (1,) * (u.ndim - 1))
    return jnp.stack([jnp.broadcast_to(a, u.shape[1:]) for a in arrays])
