"""Triangle meshes as simulation domains (Ringham et al. §3.4).

A :class:`Mesh` plays the role a :class:`~morphogen.domains.grid.Grid` plays for images: arrays
on it have shape ``(S, V)`` (one value per species and vertex, in the file's vertex order), and
it supplies the diffusion operator, boundary conditions and the stability limit, so every model
(library or equation file) runs on it through :func:`morphogen.engine.simulate.simulate` unchanged.

Boundaries, per species (a spec, or a list of specs applied in order):

- ``neumann`` (alias ``no-flux``, the default): open boundaries are no-flux, mass is conserved.
- ``dirichlet=VALUE``: hold every open-boundary vertex at ``VALUE``.
- ``dirichlet=VALUE@SET``: hold the vertex set ``SET`` (``boundary``, ``all``, or a per-vertex
  field read as ``field > 0.5``, e.g. ``margin`` of a generated flower) at ``VALUE``, a number
  or the name of a field (its values on the set), e.g. Trichoglottis phase 2,
  ``{"u": "dirichlet=0@distal", "v": "dirichlet=30@distal"}``.

Anisotropy: a :class:`~morphogen.models.model.Tensor` coefficient ``(xx, xy, yy)`` is read in a
tangent frame per face whose first axis is the mesh's ``directions`` field (e.g. the gradient of
a positional-information field, Ringham et al. eq. 18); ``Tensor(l1, 0, l2)`` diffuses at rate
``l1`` along the direction and ``l2`` across it. Without ``directions`` the first axis is the
global x axis projected onto each face, so a flat mesh in the xy plane reads tensors as a grid
does.

Stochastic diffusion (Ringham et al. eqs. 14-17) is switched on with ``omega`` (one number, or
one per species); see :meth:`Mesh.diffusion_noise`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains import mesh_builders as builders
from morphogen.domains import mesh_geometry as geo
from morphogen.domains.mesh_operators import Operators
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Tensor

BUILTIN_SETS = ("boundary", "all")
"""Vertex sets every mesh has, besides its fields."""


@dataclass(frozen=True, eq=False)
class MeshBoundary:
    """One species' conditions on a mesh.

    Attributes:
        kind: ``neumann`` (nothing held) or ``dirichlet``.
        vertices: held vertex indices, ``(H,)``.
        values: their values, ``(H,)``.
        omega: Langevin size parameter of stochastic diffusion for this species, or ``None``.
    """

    kind: str
    vertices: np.ndarray
    values: np.ndarray
    omega: float | None = None

    @property
    def value(self) -> float:
        """The first held value (for display), 0 when nothing is held."""
        return float(self.values[0]) if len(self.values) else 0.0


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh domain.

    Args:
        vertices: positions, ``(V, 3)``. Kept exactly as given (never merged or reordered).
        faces: vertex indices of each triangle, ``(F, 3)``.
        boundary: one spec for all species or a mapping species -> spec or list of specs
            (module docstring).
        fields: named per-vertex arrays ``(V,)``: prepatterns, positional information, vertex
            sets (``> 0.5``); they travel with the mesh to PLY files and pipelines.
        directions: one vector per face, ``(F, 3)``, orienting anisotropic tensors.
        omega: Ringham's ``Omega`` for stochastic diffusion: a number, a mapping species ->
            number, or ``None`` (deterministic).
        name: for messages and outputs.

    Raises:
        MorphogenError: for non-manifold or degenerate meshes, or malformed fields.
    """

    kind: ClassVar[str] = "mesh"
    vertices: np.ndarray
    faces: np.ndarray
    boundary: Any = "neumann"
    fields: Mapping[str, np.ndarray] = field(default_factory=dict)
    directions: np.ndarray | None = None
    omega: float | Mapping[str, float] | None = None
    name: str = "mesh"

    def __post_init__(self) -> None:
        vertices = _frozen(np.asarray(self.vertices, np.float64))
        faces = np.asarray(self.faces)
        if faces.size and not np.issubdtype(faces.dtype, np.integer):
            raise MorphogenError(f"{self.name}: face indices must be integers")
        faces = _frozen(faces.astype(np.int64))
        geo.validate(vertices, faces, source=self.name)
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)
        fields = {}
        for key, values in dict(self.fields).items():
            arr = np.asarray(values, np.float64)
            if arr.shape != (len(vertices),):
                raise MorphogenError(
                    f"{self.name}: field {key!r} has shape {arr.shape}, expected "
                    f"({len(vertices)},) (one value per vertex)"
                )
            if not np.all(np.isfinite(arr)):
                raise MorphogenError(f"{self.name}: field {key!r} has non-finite values")
            fields[str(key)] = _frozen(arr)
        object.__setattr__(self, "fields", fields)
        if self.directions is not None:
            d = np.asarray(self.directions, np.float64)
            if d.shape != (len(faces), 3) or not np.all(np.isfinite(d)):
                raise MorphogenError(
                    f"{self.name}: directions must be finite with shape ({len(faces)}, 3)"
                )
            object.__setattr__(self, "directions", _frozen(d))
        for value in (self.omega.values() if isinstance(self.omega, Mapping) else [self.omega]):
            if value is not None and not (np.isfinite(value) and value > 0):
                raise MorphogenError(f"omega must be a positive number, got {value}")

    # --- shape and geometry -------------------------------------------------------------------

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def spatial_shape(self) -> tuple[int]:
        return (self.n_vertices,)

    @property
    def size(self) -> int:
        """Number of vertices."""
        return self.n_vertices

    @cached_property
    def coords(self) -> dict[str, np.ndarray]:
        """Raw vertex positions ``x, y, z`` in mesh units (not normalised), each ``(V,)``."""
        v = self.vertices.astype(np.float32)
        return {"x": v[:, 0], "y": v[:, 1], "z": v[:, 2]}

    @cached_property
    def ops(self) -> Operators:
        """The assembled operator data (built on first use)."""
        return Operators.build(self.vertices, self.faces, self.directions)

    @property
    def areas(self) -> np.ndarray:
        """Mixed Voronoi area of each vertex, ``(V,)``; ``sum(areas * u)`` is the mass of ``u``."""
        return self.ops.areas

    @cached_property
    def boundary_vertices(self) -> np.ndarray:
        """Vertices on open boundaries, sorted (empty for closed meshes)."""
        return geo.boundary_vertices(self.faces)

    @cached_property
    def edge_length(self) -> float:
        """Mean edge length."""
        e = geo.edge_vectors(self.vertices, self.faces)
        return float(np.linalg.norm(e, axis=2).mean())

    def mass(self, u: Array) -> Array:
        """Total amount ``sum_i A_i u_i`` over the last axis (conserved by diffusion)."""
        return jnp.tensordot(jnp.asarray(u), jnp.asarray(self.areas, jnp.asarray(u).dtype),
                             axes=(-1, 0))

    def face_gradient(self, values: np.ndarray) -> np.ndarray:
        """Per-face gradient of a per-vertex field (Ringham et al. eq. 7), ``(F, 3)``."""
        return geo.face_gradient(self.vertices, self.faces, values)

    def spectral_radius(self) -> float:
        """Largest eigenvalue of ``-Laplacian`` with unit diffusion (computed once)."""
        return self._spectral_radius

    @cached_property
    def _spectral_radius(self) -> float:
        return self.ops.spectral_radius()

    # --- builders (vertices and faces from morphogen.domains.mesh_builders) -------------------

    @classmethod
    def plane(cls, width: float = 1.0, height: float = 1.0, *, edge: float = 0.05,
              **mesh_args: Any) -> Mesh:
        """A flat ``width x height`` rectangle in right triangles of legs ``edge``."""
        return cls(*builders.plane(width, height, edge), **{"name": "plane", **mesh_args})

    @classmethod
    def disc(cls, radius: float = 1.0, *, edge: float = 0.05, **mesh_args: Any) -> Mesh:
        """A flat disc of ``radius``, quality triangles with edges about ``edge``."""
        return cls(*builders.disc(radius, edge), **{"name": "disc", **mesh_args})

    @classmethod
    def sphere(cls, radius: float = 1.0, *, subdivisions: int = 3, **mesh_args: Any) -> Mesh:
        """An icosphere of ``radius``: the icosahedron split ``subdivisions`` times."""
        return cls(*builders.sphere(radius, subdivisions), **{"name": "sphere", **mesh_args})

    # --- derived meshes -----------------------------------------------------------------------

    def replace(self, **changes: Any) -> Mesh:
        """A copy with some attributes changed (fields, boundary, directions, omega, name)."""
        return dataclasses.replace(self, **changes)

    def with_fields(self, **fields: np.ndarray) -> Mesh:
        """A copy with these per-vertex fields added or replaced."""
        return self.replace(fields={**self.fields, **fields})

    # --- vertex sets and boundaries -----------------------------------------------------------

    def vertex_set_names(self) -> list[str]:
        return [*BUILTIN_SETS, *self.fields]

    def vertex_set(self, name: str) -> np.ndarray:
        """Sorted vertex indices of a named set: ``boundary``, ``all`` or ``field > 0.5``."""
        if name == "boundary":
            return self.boundary_vertices
        if name == "all":
            return np.arange(self.n_vertices)
        if name in self.fields:
            return np.flatnonzero(self.fields[name] > 0.5)
        raise MorphogenError(
            f"{self.name}: no vertex set {name!r}; known: {', '.join(self.vertex_set_names())}"
        )

    def boundaries(self, species: Sequence[str]) -> tuple[MeshBoundary, ...]:
        """Each species' held vertices and values, and its ``omega``."""
        specs = self.boundary
        if isinstance(specs, Mapping):
            unknown = set(specs) - set(species)
            if unknown:
                raise MorphogenError(
                    f"boundary given for unknown species {sorted(unknown)}; species are "
                    + ", ".join(species)
                )
        omegas = self.omega
        if isinstance(omegas, Mapping):
            unknown = set(omegas) - set(species)
            if unknown:
                raise MorphogenError(f"omega given for unknown species {sorted(unknown)}")
        out = []
        for s in species:
            spec = specs.get(s, "neumann") if isinstance(specs, Mapping) else specs
            omega = omegas.get(s) if isinstance(omegas, Mapping) else omegas
            out.append(self._parse_boundary(spec, omega))
        return tuple(out)

    def _parse_boundary(self, spec: Any, omega: float | None) -> MeshBoundary:
        items = spec if isinstance(spec, list | tuple) and not _is_pair(spec) else [spec]
        held = np.full(self.n_vertices, np.nan)
        for item in items:
            kind, value, where = _split_spec(item)
            if kind == "neumann":
                continue
            idx = self.vertex_set(where)
            if len(idx) == 0:
                hint = (" (the mesh is closed; name a vertex set: dirichlet=VALUE@SET)"
                        if where == "boundary" else "")
                raise MorphogenError(f"dirichlet set {where!r} has no vertices{hint}")
            if isinstance(value, str):
                if value not in self.fields:
                    raise MorphogenError(
                        f"dirichlet value {value!r} is neither a number nor a field; fields: "
                        + (", ".join(self.fields) or "none")
                    )
                held[idx] = self.fields[value][idx]
            else:
                held[idx] = value
        idx = np.flatnonzero(~np.isnan(held))
        kind = "dirichlet" if len(idx) else "neumann"
        return MeshBoundary(kind, idx, held[idx], None if omega is None else float(omega))

    # --- operators (pure JAX) -----------------------------------------------------------------

    def diffuse(self, u: Array, coeffs: Sequence[Any], bcs: Sequence[MeshBoundary]) -> Array:
        """``div(D_i grad u_i)`` for every species; ``u`` has shape ``(S, V)``.

        A coefficient is a scalar (cotangent Laplacian), a per-vertex field (edge coefficient
        ``(D_i + D_j) / 2``), or a :class:`Tensor` (anisotropic flux per face, eqs. 8 and 18).
        """
        ops = self.ops
        out: list[Any] = [None] * len(coeffs)
        scalar = []
        for i, d in enumerate(coeffs):
            if isinstance(d, Tensor):
                out[i] = ops.tensor_divergence(u[i], ops.face_tensor(*d, u.dtype))
            elif isinstance(d, int | float) and d == 0:
                out[i] = jnp.zeros_like(u[i])
            elif jnp.size(d) == 1:
                scalar.append(i)
            else:
                out[i] = ops.laplacian_field(u[i], jnp.asarray(d, u.dtype))
        if scalar:
            lap = ops.laplacian(u[np.asarray(scalar)])
            for row, i in enumerate(scalar):
                out[i] = jnp.reshape(jnp.asarray(coeffs[i], u.dtype), ()) * lap[row]
        return jnp.stack(out)

    def hold(self, u: Array, bcs: Sequence[MeshBoundary]) -> Array:
        """Impose each species' Dirichlet values on its held vertices."""
        for i, bc in enumerate(bcs):
            if len(bc.vertices):
                u = u.at[i, bc.vertices].set(jnp.asarray(bc.values, u.dtype))
        return u

    @property
    def stochastic(self) -> bool:
        """Whether :meth:`diffusion_noise` is active (``omega`` set)."""
        if isinstance(self.omega, Mapping):
            return bool(self.omega)
        return self.omega is not None

    def diffusion_noise(self, u: Array, coeffs: Sequence[Any], bcs: Sequence[MeshBoundary],
                        dt: Array, key: Array) -> Array:
        """Chemical-Langevin increment of stochastic diffusion (Ringham et al. eq. 17), ``(S, V)``.

        Every flux component ``c(C) Z_C`` across a Voronoi border gets independent noise
        ``sqrt(c(C) |Z_C| dt / Omega) N(0, 1)``; mass moves between neighbours, so it is
        conserved. Concentrations below zero contribute no noise (``max(c, 0)``); values are not
        clipped. As ``Omega -> inf`` the increment vanishes and the deterministic scheme remains.
        """
        ops = self.ops
        keys = jax.random.split(key, len(coeffs))
        rows = []
        for i, (d, bc) in enumerate(zip(coeffs, bcs, strict=True)):
            if bc.omega is None or (isinstance(d, int | float) and d == 0):
                rows.append(jnp.zeros_like(u[i]))
                continue
            xx, xy, yy = d if isinstance(d, Tensor) else (d, 0.0, d)
            tensor = ops.face_tensor(xx, xy, yy, u.dtype)
            rows.append(ops.langevin_increment(u[i], tensor, dt, bc.omega, keys[i]))
        return jnp.stack(rows)


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr)
    arr.setflags(write=False)
    return arr


def _is_pair(spec: Any) -> bool:
    return len(spec) == 2 and isinstance(spec[0], str) and not isinstance(spec[1], str)


def _split_spec(spec: Any) -> tuple[str, float | str, str]:
    """``(kind, value, set)`` from ``neumann``, ``dirichlet=V``, ``dirichlet=V@SET``, a grid
    :class:`~morphogen.domains.grid.Boundary` or a ``(kind, value)`` pair."""
    if hasattr(spec, "kind") and hasattr(spec, "value"):
        spec = (spec.kind, spec.value)
    if isinstance(spec, tuple | list):
        kind, value, where = str(spec[0]), spec[1], "boundary"
    else:
        text = str(spec).strip()
        head, _, where = text.partition("@")
        kind, _, value = head.partition("=")
        where = where.strip() or "boundary"
    kind = kind.strip().lower()
    if kind in ("neumann", "no-flux", "noflux"):
        return "neumann", 0.0, where
    if kind == "periodic":
        raise MorphogenError("periodic boundaries need a grid; on a mesh use neumann or dirichlet")
    if kind != "dirichlet":
        raise MorphogenError(
            f"unknown mesh boundary {spec!r}; use neumann or dirichlet=VALUE[@SET]"
        )
    if isinstance(value, str):
        value = value.strip()
        if not value:
            raise MorphogenError(f"boundary {spec!r} needs a value: dirichlet=VALUE[@SET]")
        try:
            value = float(value)
        except ValueError:
            return "dirichlet", value, where
    return "dirichlet", float(value), where
