"""Flowers made of organs: separate blades assembled into one mesh (Ringham et al. §2.1, §4.9).

An orchid flower (Phalaenopsis, Trichoglottis) has three sepals, two petals and a lip, each a
separate blade that morphogens cannot cross. :func:`assemble` places blades made by
:func:`~morphogen.flowers.shapes.petal` around the flower centre as disconnected components of
one :class:`~morphogen.domains.mesh.Mesh`: blade ``k`` is rotated about ``z`` so that its
midline points at angle ``a_k`` from the +x axis, its base moved ``offset_k`` out from the
centre and lifted by ``lift_k`` (later organs lie in front of earlier ones in a view from +z).
The blades' own fields (``s``, ``lateral``, sets ``margin``, ``base``, ``midline``) are kept,
and each vertex gets

- ``organ``: the organ's index (in the order given), and one 0/1 set per organ kind
  (``sepal``, ``petal``, ``lip``);
- ``r``: distance from the flower centre in the plane, divided by its maximum.

Diffusion on the assembled mesh stays inside each organ (no edge joins two organs), as
pigment patterns on separate tepals develop independently.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError

ORGAN_KINDS = ("sepal", "petal", "lip")


@dataclass(frozen=True)
class Organ:
    """One blade of a flower: its mesh (base on the x axis, midline along +y), kind, the
    direction of its midline (degrees from +x), the distance of its base from the centre and
    its height."""

    mesh: Mesh
    kind: str
    angle: float
    offset: float = 0.0
    lift: float = 0.0


def assemble(organs: Sequence[Organ], name: str = "flower") -> Mesh:
    """One mesh of disconnected organs, with fields ``organ``, ``r`` and a set per kind."""
    if not organs:
        raise MorphogenError("a flower needs at least one organ")
    kinds = sorted({o.kind for o in organs})
    unknown = [k for k in kinds if k not in ORGAN_KINDS]
    if unknown:
        raise MorphogenError(f"unknown organ kind {unknown[0]!r}; use one of "
                             f"{', '.join(ORGAN_KINDS)}")
    common = set.intersection(*(set(o.mesh.fields) for o in organs))
    verts, faces, fields = [], [], {k: [] for k in sorted(common) + ["organ", *ORGAN_KINDS]}
    start = 0
    for index, organ in enumerate(organs):
        v = organ.mesh.vertices
        a = np.radians(organ.angle - 90.0)  # the blade's +y axis turned to `angle`
        rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1]])
        shift = organ.offset * np.array([np.cos(np.radians(organ.angle)),
                                         np.sin(np.radians(organ.angle)), 0.0])
        verts.append(v @ rot.T + shift + [0.0, 0.0, organ.lift])
        faces.append(organ.mesh.faces + start)
        for key in common:
            fields[key].append(organ.mesh.fields[key])
        n = len(v)
        fields["organ"].append(np.full(n, float(index)))
        for kind in ORGAN_KINDS:
            fields[kind].append(np.full(n, float(organ.kind == kind)))
        start += n
    xyz = np.concatenate(verts)
    out = {k: np.concatenate(v) for k, v in fields.items()}
    radius = np.linalg.norm(xyz[:, :2], axis=1)
    out["r"] = radius / radius.max()
    return Mesh(xyz, np.concatenate(faces), fields=out, name=name)


def orchid(
    size: float = 1.0,
    *,
    edge: float = 0.02,
    petal_width: float = 1.0,
    sepal_width: float = 0.55,
    lip: float = 0.38,
) -> Mesh:
    """A Phalaenopsis-like orchid of ``size`` across (mesh units): a dorsal sepal up, two
    lateral sepals down-left and down-right, two broad rounded petals left and right in front
    of the sepals, and a small lip in front at the bottom.

    Blades are :func:`~morphogen.flowers.shapes.petal` outlines: sepals ``0.5 size`` long and
    ``sepal_width * 0.5 size`` wide, petals ``0.45 size`` long and ``petal_width * 0.45 size``
    wide (broad, un-notched), the lip ``lip * size`` long. Organ order: dorsal sepal, lateral
    sepals, petals, lip (``organ`` 0-5).
    """
    from morphogen.flowers.shapes import petal

    for label, value in (("size", size), ("petal_width", petal_width),
                         ("sepal_width", sepal_width), ("lip", lip)):
        if not (np.isfinite(value) and value > 0):
            raise MorphogenError(f"orchid: {label} must be a positive number, got {value}")
    if edge > 0.1 * size:
        raise MorphogenError(f"orchid: edge {edge} is too coarse for size {size}; use at most "
                             f"{0.1 * size:g}")
    half = 0.5 * size
    sepal = petal(half, sepal_width * half, edge=edge, notch=0.0, cup=0.05, curl=-0.05,
                  base_width=0.35)
    side = petal(0.9 * half, petal_width * 0.9 * half, edge=edge, notch=0.0, cup=0.06,
                 curl=-0.04, base_width=0.2)
    labellum = petal(lip * size, 0.7 * lip * size, edge=edge, notch=0.25, cup=0.25, curl=0.2,
                     base_width=0.3)
    gap = 0.04 * size
    return assemble([
        Organ(sepal, "sepal", 90.0, gap),
        Organ(sepal, "sepal", 215.0, gap),
        Organ(sepal, "sepal", 325.0, gap),
        Organ(side, "petal", 165.0, gap, 0.06 * size),
        Organ(side, "petal", 15.0, gap, 0.06 * size),
        Organ(labellum, "lip", 270.0, gap, 0.1 * size),
    ], name="orchid")
