"""PLY files in and out of mesh simulations (Ringham et al. §3.1: PLY in, coloured PLY out).

Reading (:func:`load_mesh`, :func:`ply_fields`) uses ``plyfile`` for ASCII and binary PLY and
keeps the file's vertex order exactly (nothing is merged or reordered, so per-vertex fields
stay aligned). Every per-vertex property other than ``x, y, z`` becomes a named field (a
prepattern): colour channels ``red, green, blue, alpha`` stored as bytes are scaled to [0, 1],
other scalars are kept as they are. Polygons with more than three corners are split into
triangle fans, with a warning. A field named like a species is that species' initial value; a
field named like a parameter is that parameter's value per vertex (:func:`apply_fields`).

Writing (:func:`save_ply`) produces binary PLY with vertex colours and every morphogen and field
as a named float property, atomically; :func:`morphogen.render.mesh_outputs.write_mesh_outputs`
adds the rendered picture.
"""

from __future__ import annotations

import warnings
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.models.model import Model, Params
from morphogen.util.io import check_input_file, ensure_writable_dir, write_atomic

COLOUR_CHANNELS = ("red", "green", "blue", "alpha")
_POSITION = ("x", "y", "z")


def _read(path: str | Path):
    from plyfile import PlyData

    p = Path(path)
    if not p.exists():
        raise MorphogenError(f"mesh file {p} does not exist")
    check_input_file(p, "mesh file", limit=float("inf"))  # a device or FIFO never ends
    check_declared_sizes(p)
    try:
        with open(p, "rb") as fh:
            return PlyData.read(fh)
    except MorphogenError:
        raise
    except Exception as exc:  # plyfile raises many types (PlyParseError, ValueError, EOFError)
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise MorphogenError(f"cannot read PLY file {p}: {reason}") from None


_SIZES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2, "ushort": 2,
          "uint16": 2, "int": 4, "int32": 4, "uint": 4, "uint32": 4, "float": 4, "float32": 4,
          "double": 8, "float64": 8}
MAX_HEADER = 1 << 16
"""Bytes of a PLY header read before the declared element counts are checked."""


def check_declared_sizes(path: Path) -> None:
    """Refuse a PLY file whose header declares more elements than its body can hold.

    Each element needs at least ``sum(scalar sizes) + sum(list count sizes)`` bytes in binary
    (a list may be empty) and two characters per property in ASCII (a digit and a separator),
    so ``sum(count × minimum)`` may not exceed the bytes after ``end_header``. A 188-byte file
    declaring 10⁸ faces is refused here, before any parser allocates for them. Headers this
    check cannot read are left to the parser's own errors.
    """
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(MAX_HEADER)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return
    body = size - (head.find(b"\n", end) + 1)
    lines = head[:end].decode("ascii", "replace").splitlines()
    ascii_format = any(line.split()[:2] == ["format", "ascii"] for line in lines if line.strip())
    needed = 0
    elements: list[list[Any]] = []  # [name, count, bytes per item]
    for line in lines:
        words = line.split()
        if len(words) == 3 and words[0] == "element" and words[2].isdigit():
            elements.append([words[1], int(words[2]), 0])
        elif elements and len(words) >= 3 and words[0] == "property":
            kind = words[2] if words[1] == "list" else words[1]
            elements[-1][2] += 2 if ascii_format else _SIZES.get(kind, 1)
    for name, count, minimum in elements:
        needed += count * max(minimum, 1)
        if needed > body:
            raise MorphogenError(
                f"PLY file {path} declares {count} {name} element(s), which need at least "
                f"{needed} bytes, but it has only {body} bytes after its header; the file is "
                "truncated or its header is wrong"
            )


def _vertex_element(ply, path) -> Any:
    try:
        vertex = ply["vertex"]
    except KeyError:
        raise MorphogenError(f"PLY file {path} has no vertex element") from None
    names = [prop.name for prop in vertex.properties]
    missing = [c for c in _POSITION if c not in names]
    if missing:
        raise MorphogenError(f"PLY file {path}: vertex element lacks {', '.join(missing)}")
    lists = [c for c in _POSITION if vertex.data[c].dtype == object]
    if lists:
        raise MorphogenError(f"PLY file {path}: vertex property {lists[0]} is a list; "
                             "coordinates must be scalar properties")
    return vertex


def _fields(vertex) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for prop in vertex.properties:
        if prop.name in _POSITION:
            continue
        data = vertex.data[prop.name]
        if data.dtype == object:  # list property: not a scalar field
            continue
        values = np.asarray(data, np.float64)
        if prop.name in COLOUR_CHANNELS and np.asarray(data).dtype == np.uint8:
            values = values / 255.0
        out[prop.name] = values
    return out


def ply_fields(path: str | Path) -> dict[str, np.ndarray]:
    """Every scalar per-vertex property of a PLY file except ``x, y, z``, each ``(V,)``."""
    ply = _read(path)
    return _fields(_vertex_element(ply, path))


def _faces(ply, path) -> np.ndarray:
    try:
        face = ply["face"]
    except KeyError:
        raise MorphogenError(f"PLY file {path} has no faces (a point cloud cannot be simulated "
                             "on; triangulate it first)") from None
    names = [prop.name for prop in face.properties]
    key = next((n for n in ("vertex_indices", "vertex_index") if n in names), None)
    if key is None:
        raise MorphogenError(f"PLY file {path}: face element lacks vertex_indices")
    polygons = face.data[key]
    if polygons.dtype != object:
        raise MorphogenError(f"PLY file {path}: face property {key} must be a list of vertex "
                             "indices (property list uchar int ...)")
    if len(polygons) == 0:
        raise MorphogenError(f"PLY file {path} has no faces")
    if any(not np.issubdtype(np.asarray(p).dtype, np.integer) for p in polygons[:1]):
        raise MorphogenError(f"PLY file {path}: face property {key} holds non-integer indices; "
                             "declare it with an integer type (e.g. list uchar int)")
    sizes = np.array([len(p) for p in polygons])
    if sizes.min() < 3:
        raise MorphogenError(f"PLY file {path}: face {int(np.argmin(sizes))} has fewer than "
                             "3 corners")
    if sizes.max() == 3:
        return np.stack([np.asarray(p, np.int64) for p in polygons])
    warnings.warn(f"{path}: {int((sizes > 3).sum())} polygon(s) with more than 3 corners split "
                  "into triangle fans", stacklevel=3)
    tris = [[p[0], p[i], p[i + 1]] for p in polygons for i in range(1, len(p) - 1)]
    return np.asarray(tris, np.int64)


def load_mesh(path: str | Path, **mesh_args: Any) -> Mesh:
    """Read a PLY file (ASCII or binary) into a :class:`Mesh` with its fields.

    Extra keyword arguments go to :class:`Mesh` (``boundary``, ``omega``, ...).

    Raises:
        MorphogenError: missing or corrupt file, no faces, non-manifold or degenerate mesh.
    """
    ply = _read(path)
    vertex = _vertex_element(ply, path)
    vertices = np.stack([np.asarray(vertex.data[c], np.float64) for c in _POSITION], axis=1)
    faces = _faces(ply, path)
    fields = {**_fields(vertex), **mesh_args.pop("fields", {})}
    return Mesh(vertices, faces, fields=fields, name=mesh_args.pop("name", Path(path).name),
                **mesh_args)


def save_ply(
    path: str | Path,
    mesh: Mesh,
    *,
    colours: np.ndarray | None = None,
    fields: Mapping[str, np.ndarray] | None = None,
    binary: bool = True,
) -> Path:
    """Write a mesh with per-vertex colours ``(V, 3)`` uint8 and named float fields, atomically.

    The mesh's own fields are written too (after them, ``fields`` wins on a name clash); colour
    channel names are reserved for ``colours``.
    """
    from plyfile import PlyData, PlyElement

    data = {**mesh.fields, **(fields or {})}
    props: list[tuple[str, str]] = [("x", "f8"), ("y", "f8"), ("z", "f8")]
    columns: list[np.ndarray] = [mesh.vertices[:, i] for i in range(3)]
    if colours is not None:
        colours = np.asarray(colours)
        if colours.shape != (mesh.n_vertices, 3) or colours.dtype != np.uint8:
            raise MorphogenError(f"colours must be uint8 of shape ({mesh.n_vertices}, 3)")
        props += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
        columns += [colours[:, i] for i in range(3)]
    for name, values in data.items():
        if name in _POSITION or (colours is not None and name in COLOUR_CHANNELS):
            continue
        if not name.isidentifier():
            raise MorphogenError(f"field name {name!r} cannot be a PLY property name")
        values = np.asarray(values)
        if values.shape != (mesh.n_vertices,):
            raise MorphogenError(f"field {name!r} has shape {values.shape}, expected "
                                 f"({mesh.n_vertices},)")
        props.append((name, "f4"))
        columns.append(values.astype(np.float32))
    table = np.empty(mesh.n_vertices, dtype=props)
    for (name, _), col in zip(props, columns, strict=True):
        table[name] = col
    faces = np.empty(mesh.n_faces, dtype=[("vertex_indices", "i4", (3,))])
    faces["vertex_indices"] = mesh.faces.astype(np.int32)
    ply = PlyData([PlyElement.describe(table, "vertex"), PlyElement.describe(faces, "face")],
                  text=not binary)
    ensure_writable_dir(Path(path).parent)
    return write_atomic(path, ply.write)


def field_clashes(model: Model, mesh: Mesh) -> list[str]:
    """The mesh's fields named like one of the model's species or parameters, in the model's
    order (species first)."""
    return [n for n in (*model.species, *model.params) if n in mesh.fields]


def apply_fields(
    model: Model, mesh: Mesh, u0: np.ndarray, params: Params,
    names: Collection[str] | None = None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Use a mesh's fields named like species as initial values and like parameters as
    per-vertex parameter values; ``u0`` is ``(S, V)``. Returns new ``(u0, params)``.

    ``names`` limits this to the fields named there (a front end passes the ones the user
    asked for); ``None`` applies every field named like a species or parameter."""
    use = set(field_clashes(model, mesh) if names is None else names)
    u = np.array(u0, np.float32, copy=True)
    for i, s in enumerate(model.species):
        if s in mesh.fields and s in use:
            u[i] = mesh.fields[s]
    out = dict(params)
    for name in model.params:
        if name in mesh.fields and name in use:
            out[name] = np.asarray(mesh.fields[name], np.float32)
    return u, out
