"""Flowers made of organs: separate blades assembled into one mesh (Ringham et al. §2.1, §4.9).

An orchid flower (Phalaenopsis, Trichoglottis) has three sepals, two petals and a lip, each a
separate blade that morphogens cannot cross. :func:`assemble` places blades made by
:func:`~morphogen.flowers.shapes.petal` around the flower centre as disconnected components of
one :class:`~morphogen.domains.mesh.Mesh`: blade ``k`` is rotated about ``z`` so that its
midline points at angle ``a_k`` from the +x axis, its base moved ``offset_k`` out from the
centre and lifted by ``lift_k`` (later organs lie in front of earlier ones in a view from +z);
``tilt_k`` first turns the blade about its base line, raising its tip towards +z. A whole
corolla (e.g. an :func:`~morphogen.flowers.shapes.urn`) is an organ too, placed as it is with
``angle = 90``. The organs' own fields (``s``, ``lateral``, sets ``margin``, ``base``,
``midline``, ...) are kept; a field that some organ lacks is 0 on that organ. Each vertex gets

- ``organ``: the organ's index (in the order given), and one 0/1 set per organ kind
  (``sepal``, ``petal``, ``lip``, ``column``, ``corolla``);
- ``r``: distance from the flower centre in the plane, divided by its maximum.

These replace same-named fields of the organs (a corolla's ``r`` or ``petal``).

Diffusion on the assembled mesh stays inside each organ (no edge joins two organs), as
pigment patterns on separate tepals develop independently.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError

ORGAN_KINDS = ("sepal", "petal", "lip", "column", "corolla")


@dataclass(frozen=True)
class Organ:
    """One organ of a flower: its mesh (a blade: base on the x axis, midline along +y), kind,
    the direction of its midline (degrees from +x), the distance of its base from the centre,
    its height and its tilt (degrees, about the base line)."""

    mesh: Mesh
    kind: str
    angle: float
    offset: float = 0.0
    lift: float = 0.0
    tilt: float = 0.0


def assemble(organs: Sequence[Organ], name: str = "flower") -> Mesh:
    """One mesh of disconnected organs, with fields ``organ``, ``r`` and a set per kind."""
    if not organs:
        raise MorphogenError("a flower needs at least one organ")
    kinds = sorted({o.kind for o in organs})
    unknown = [k for k in kinds if k not in ORGAN_KINDS]
    if unknown:
        raise MorphogenError(f"unknown organ kind {unknown[0]!r}; use one of "
                             f"{', '.join(ORGAN_KINDS)}")
    names = sorted(set().union(*(o.mesh.fields for o in organs)))
    verts, faces, fields = [], [], {k: [] for k in names + ["organ", *ORGAN_KINDS]}
    start = 0
    for index, organ in enumerate(organs):
        v = organ.mesh.vertices
        t = np.radians(organ.tilt)
        v = np.stack([v[:, 0], v[:, 1] * np.cos(t) - v[:, 2] * np.sin(t),
                      v[:, 1] * np.sin(t) + v[:, 2] * np.cos(t)], 1)
        a = np.radians(organ.angle - 90.0)  # the blade's +y axis turned to `angle`
        rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1]])
        shift = organ.offset * np.array([np.cos(np.radians(organ.angle)),
                                         np.sin(np.radians(organ.angle)), 0.0])
        verts.append(v @ rot.T + shift + [0.0, 0.0, organ.lift])
        faces.append(organ.mesh.faces + start)
        n = len(v)
        for key in names:
            fields[key].append(organ.mesh.fields.get(key, np.zeros(n)))
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
    column: float = 0.0,
) -> Mesh:
    """A Phalaenopsis-like orchid of ``size`` across (mesh units): a dorsal sepal up, two
    lateral sepals down-left and down-right, two broad rounded petals left and right in front
    of the sepals, and a small lip in front at the bottom.

    Blades are :func:`~morphogen.flowers.shapes.petal` outlines: sepals ``0.5 size`` long and
    ``sepal_width * 0.5 size`` wide, petals ``0.45 size`` long and ``petal_width * 0.45 size``
    wide (broad, un-notched), the lip ``lip * size`` long. Organ order: dorsal sepal, lateral
    sepals, petals, lip (``organ`` 0-5). With ``column > 0`` a column (the fused stamens and
    style, Ringham §4.10) ``column * size`` long is added last (``organ`` 6): a narrow, strongly
    cupped blade from the centre over the lip, in front of every other organ.
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
    if not (np.isfinite(column) and 0 <= column <= 0.3):
        raise MorphogenError(f"orchid: column must be from 0 to 0.3 (of the size), got {column}")
    gap = 0.04 * size
    organs = [
        Organ(sepal, "sepal", 90.0, gap),
        Organ(sepal, "sepal", 215.0, gap),
        Organ(sepal, "sepal", 325.0, gap),
        Organ(side, "petal", 165.0, gap, 0.06 * size),
        Organ(side, "petal", 15.0, gap, 0.06 * size),
        Organ(labellum, "lip", 270.0, gap, 0.1 * size),
    ]
    if column > 0:
        length = column * size
        if edge > 0.25 * length:
            raise MorphogenError(f"orchid: edge {edge} is too coarse for a column of length "
                                 f"{length:g}; use at most {0.25 * length:g}")
        stem = petal(length, 0.45 * length, edge=edge, notch=0.0, cup=0.4, curl=0.1,
                     base_width=0.6)
        organs.append(Organ(stem, "column", 270.0, 0.0, 0.16 * size))
    return assemble(organs, name="orchid")


def urn_flower(
    sepals: int = 5,
    *,
    sepal_length: float = 0.22,
    sepal_width: float = 0.16,
    tilt: float = 40.0,
    edge: float = 0.02,
    **corolla: Any,
) -> Mesh:
    """An :func:`~morphogen.flowers.shapes.urn` corolla (keyword arguments ``corolla``) with a
    calyx of ``sepals`` small blades around the pedicel (Arctostaphylos, Ringham §4.2): each
    sepal starts at the urn's pedicel ring, between two lobes, raised by ``tilt`` degrees
    towards the corolla and lowered by a quarter of its length to lie under the urn.
    """
    from morphogen.flowers.shapes import petal, urn

    if not (isinstance(sepals, int | np.integer) and 0 <= sepals <= 20):
        raise MorphogenError(f"sepals must be an integer from 0 to 20, got {sepals}")
    for label, value in (("sepal_length", sepal_length), ("sepal_width", sepal_width)):
        if not (np.isfinite(value) and value > 0):
            raise MorphogenError(f"urn_flower: {label} must be a positive number, got {value}")
    if not 0 <= tilt <= 90:
        raise MorphogenError(f"urn_flower: tilt must be in [0, 90] degrees, got {tilt}")
    body = urn(edge=edge, **corolla)
    organs = [Organ(body, "corolla", 90.0)]
    if sepals:
        blade = petal(sepal_length, sepal_width, edge=edge, notch=0.0, cup=0.1, curl=0.0,
                      base_width=0.5)
        lobes = int(np.max(body.fields["lobe"])) + 1
        ring = float(np.linalg.norm(body.vertices[body.fields["base"] > 0.5, :2], axis=1).mean())
        for k in range(sepals):
            angle = 360.0 * (k + 0.5 * (sepals == lobes)) / sepals
            organs.append(Organ(blade, "sepal", angle, 0.9 * ring, -0.25 * sepal_length, tilt))
    return assemble(organs, name="urn-flower")


def dianthus(
    petals: int = 5,
    length: float = 1.0,
    *,
    width: float = 0.8,
    base_width: float = 0.12,
    teeth: int = 5,
    tooth_depth: float = 0.05,
    toothed_from: float = 0.65,
    tilt: float = 8.0,
    cup: float = 0.05,
    curl: float = 0.05,
    edge: float = 0.02,
) -> Mesh:
    """A Dianthus barbatus flower (Ringham §4.4, fig. 12): ``petals`` separate, toothed
    :func:`~morphogen.flowers.shapes.petal` blades (``length`` long, ``width`` wide, narrow
    claws of ``base_width``; ``teeth`` teeth each side of the tip, ``tooth_depth`` deep, from
    ``toothed_from`` of the length) spread around the centre like the spokes of a wheel:
    petal ``k`` points at ``90 + 360 k / petals`` degrees, its claw ``0.06 length`` from the
    centre, raised by ``tilt`` degrees, each a little above the one before (they overlap near
    their widest part, as on the plant). Fields and sets as for :func:`assemble`; each petal
    keeps its own ``s``, ``lateral``, ``margin``, ``base`` and ``midline``.
    """
    from morphogen.flowers.shapes import petal

    if not (isinstance(petals, int | np.integer) and 2 <= petals <= 12):
        raise MorphogenError(f"dianthus: petals must be an integer from 2 to 12, got {petals}")
    if not 0 <= tilt <= 60:
        raise MorphogenError(f"dianthus: tilt must be in [0, 60] degrees, got {tilt}")
    blade = petal(length, width, edge=edge, notch=0.0, base_width=base_width, cup=cup,
                  curl=curl, teeth=teeth, tooth_depth=tooth_depth, toothed_from=toothed_from)
    organs = [Organ(blade, "petal", 90.0 + 360.0 * k / petals, 0.06 * length,
                    0.01 * length * k, tilt) for k in range(petals)]
    return assemble(organs, name=f"dianthus-{petals}")
