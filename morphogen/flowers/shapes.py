"""Procedural flower shapes: petal blades, radial corollas and tubes with lobes.

Ringham et al. model shapes in Blender (§3.2); these generators give usable shapes without it.
Each returns a :class:`~morphogen.domains.mesh.Mesh` of nearly equilateral triangles whose
edges average ``edge`` (mesh units; the flower is about 1 unit across, so ``edge = 0.01`` gives
roughly 10^4-10^5 vertices), with per-vertex fields for prepatterns and named vertex sets
(fields of 0/1 used as ``dirichlet=VALUE@SET`` targets, sources and sinks):

============  ==========================================================================
petal         fields ``s`` (0 at the base, 1 at the tip), ``lateral`` (-1..1 across);
              sets ``margin``, ``base``, ``midline``
corolla       fields ``r`` (0 centre .. 1 outer tip), ``theta``, ``petal`` (index), ``phi``
              (-1..1 across each petal); sets ``margin``, ``throat``, ``midline``
tube          fields ``s`` (0 base, 1 at the mouth of the tube, >1 on the lobes), ``theta``,
              ``side`` (``sin theta``: -1 lower, +1 upper), ``lobe``; sets ``margin``,
              ``base``, ``throat``, ``tube``, ``midline``
urn           as ``tube``: a bulging body narrowing to the mouth, small recurved lobes
bell          as ``tube``: a wide bell opening into broad lobes (Platycodon)
two_lipped    as ``tube``: small upper lobes, large lower ones (Digitalis)
bilabiate     as ``tube``: an upper lip bent back, a lower lip held forward, deep clefts
              between them (Mimulus); set ``upper_lip``
dianthus      separate toothed petals round the centre (:mod:`morphogen.flowers.organs`)
============  ==========================================================================
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers.meshing import triangulate

SHAPES = ("petal", "corolla", "tube", "urn", "bell", "two_lipped", "bilabiate", "urn_flower",
          "orchid", "dianthus")
"""Shapes a pipeline's ``[mesh] shape`` accepts (``urn_flower``, ``orchid`` and ``dianthus``:
:mod:`morphogen.flowers.organs`)."""


def _check(edge: float, **positive: float) -> None:
    if not (np.isfinite(edge) and 1e-4 <= edge <= 0.5):
        raise MorphogenError(f"edge must be between 1e-4 and 0.5 (mesh units), got {edge}")
    for name, value in positive.items():
        if not (np.isfinite(value) and value > 0):
            raise MorphogenError(f"{name} must be a positive number, got {value}")


def _near(values: np.ndarray, target: float, tol: float) -> np.ndarray:
    return (np.abs(values - target) <= tol).astype(float)


def petal(
    length: float = 1.0,
    width: float = 0.7,
    *,
    edge: float = 0.02,
    base_width: float = 0.12,
    notch: float = 0.06,
    cup: float = 0.12,
    curl: float = 0.15,
    teeth: int = 0,
    tooth_depth: float = 0.04,
    toothed_from: float = 0.6,
) -> Mesh:
    """A single, bilaterally symmetric petal blade along +y, its base on the x axis.

    The outline is ``x(u) = b cos^2(u/2) + (w/2) sin(u) ((1 - cos u)/2)^0.4``,
    ``y(u) = L (1 - cos u)/2`` for ``u`` in ``[0, pi]`` (obovate: narrow claw of half-width
    ``b``, broad blade), mirrored, with a tip notch of depth ``notch * L``. In 3D the blade is
    cupped across (``z += cup (x/(w/2))^2 w/2``) and curled along (``z += curl (y/L)^2 L``).

    ``teeth > 0`` cuts the distal margin (where ``y > toothed_from * L``) into triangular
    teeth (Dianthus barbatus): a tooth at the tip and ``teeth`` more on each side, equally
    spaced along the margin, the notches between them ``tooth_depth * L`` deep (measured along
    the inward normal) and fading out over the last half tooth.
    """
    _check(edge, length=length, width=width)
    if not (isinstance(teeth, int | np.integer) and 0 <= teeth <= 40):
        raise MorphogenError(f"teeth must be an integer from 0 to 40, got {teeth}")
    if teeth and not (0 < tooth_depth < 0.3 and 0 < toothed_from < 1):
        raise MorphogenError(f"tooth_depth must be in (0, 0.3) and toothed_from in (0, 1), got "
                             f"{tooth_depth}, {toothed_from}")
    u = np.linspace(0.0, np.pi, 400 + 60 * teeth)
    t = (1.0 - np.cos(u)) / 2.0
    b = base_width * width / 2.0
    x = b * np.cos(u / 2) ** 2 + width / 2.0 * np.sin(u) * t**0.4
    y = length * t - notch * length * np.exp(-((x / (0.18 * width)) ** 2)) * t**8
    if teeth:
        x, y = _teeth(x, y, teeth, tooth_depth * length, toothed_from * length)
    right = np.stack([x, y], 1)
    left = right[::-1][1:] * [-1.0, 1.0]
    loop = np.vstack([right, left])
    pts, tri, boundary = triangulate([loop], lambda p: np.full(len(p), edge))
    px, py = pts[:, 0], pts[:, 1]
    z = cup * (px / (width / 2)) ** 2 * width / 2 + curl * (py / length) ** 2 * length
    base = boundary & (py <= 1e-9 + 1e-6 * length)
    fields = {
        "s": py / length,
        "lateral": px / (width / 2),
        "margin": (boundary & ~base).astype(float),
        "base": base.astype(float),
        "midline": _near(px, 0.0, 0.5 * edge),
    }
    return Mesh(np.stack([px, py, z], 1), tri, fields=fields, name="petal")


def _teeth(x: np.ndarray, y: np.ndarray, teeth: int, depth: float,
           start: float) -> tuple[np.ndarray, np.ndarray]:
    """Cut triangular teeth into the right half outline ``(x, y)`` (base to tip) where
    ``y > start``: tooth tips at arc lengths ``k S / (teeth + 1/2)`` from the tip (``S`` the
    arc length of that part), notches half-way between, moved ``depth`` along the inward
    normal; the depth fades to 0 over the last half tooth, so the outline stays smooth."""
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    from_tip = arc[-1] - arc
    span = np.interp(start, y, from_tip) if y.max() > start else 0.0
    phase = from_tip / max(span, 1e-12) * (teeth + 0.5)
    wave = 2.0 * np.abs(phase - np.round(phase))  # 0 at tooth tips, 1 at notches
    fade = np.clip(teeth + 0.5 - phase, 0.0, 0.5) / 0.5
    cut = depth * wave * fade * (from_tip < span)
    tx, ty = np.gradient(x), np.gradient(y)
    norm = np.maximum(np.hypot(tx, ty), 1e-300)
    return x - cut * ty / norm, y + cut * tx / norm  # the left normal (-ty, tx) points inwards


def _lobes(theta: np.ndarray, n: int, notch: float, teeth: int, fringe: float,
           scales: Sequence[float] | None,
           point: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-angle lobe profile in [0, 1], lobe index and position across the lobe (-1..1).

    ``point`` in [0, 1] blends the rounded lobe with the triangle ``1 - |across|``: 0 is
    rounded, 1 a straight-sided point; in between the lobe keeps round shoulders and ends in a
    tip of half-angle ``atan(1 / point)`` in these (angle, length) units."""
    sector = 2.0 * np.pi / n
    index = np.floor((theta + sector / 2) / sector).astype(int) % n
    phi = (theta - index * sector + np.pi) % (2 * np.pi) - np.pi
    across = phi / (sector / 2)
    # ~sqrt(cos) rounds the lobe; the eps blend turns the cusp it would leave at the sinus
    # between lobes into a corner of finite angle (no sliver triangles there)
    eps = 0.15
    base = np.cos(np.clip(across, -1, 1) * np.pi / 2)
    shape = (np.sqrt(base + eps**2) - eps) / (np.sqrt(1 + eps**2) - eps)
    if point:
        shape = (1.0 - point) * shape + point * (1.0 - np.clip(np.abs(across), 0, 1))
    shape = shape - notch * np.exp(-((across / 0.2) ** 2))
    if teeth and fringe:
        shape = shape * (1.0 - fringe * np.abs(np.sin(across * teeth * np.pi / 2)))
    if scales is not None:
        if len(scales) != n:
            raise MorphogenError(f"need {n} lobe scales, got {len(scales)}")
        shape = shape * np.asarray(scales, np.float64)[index]
    return shape, index, across


def corolla(
    petals: int = 5,
    radius: float = 1.0,
    *,
    edge: float = 0.02,
    depth: float = 0.45,
    eye: float = 0.0,
    notch: float = 0.12,
    teeth: int = 0,
    fringe: float = 0.0,
    cup: float = 0.15,
) -> Mesh:
    """A radially symmetric corolla of ``petals`` fused petals (Primula, Dianthus), in the xy
    plane facing +z.

    Outline ``r(theta) = R (1 - depth + depth * lobe(theta))`` with rounded lobes, a notch of
    ``notch`` at each tip (Primula), optional ``teeth`` per petal cut ``fringe`` deep
    (Dianthus). ``eye > 0`` leaves a central hole of that fraction of ``R`` (the throat). The
    corolla is a shallow bowl, ``z = cup R (r/R)^2``.
    """
    _check(edge, radius=radius)
    if not (isinstance(petals, int | np.integer) and 2 <= petals <= 40):
        raise MorphogenError(f"petals must be an integer from 2 to 40, got {petals}")
    if not 0 <= eye < 1 - depth:
        raise MorphogenError(f"eye must be in [0, {1 - depth:g}) (inside the petal bases)")
    theta = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    shape, _, _ = _lobes(theta, petals, notch, teeth, fringe, None)
    r_out = radius * (1 - depth + depth * shape)
    loops = [np.stack([r_out * np.cos(theta), r_out * np.sin(theta)], 1)]
    holes = []
    if eye > 0:
        ring = np.linspace(0, 2 * np.pi, 400, endpoint=False)
        loops.append(eye * radius * np.stack([np.cos(ring), np.sin(ring)], 1))
        holes.append([0.0, 0.0])
    pts, tri, boundary = triangulate(loops, lambda p: np.full(len(p), edge), holes=holes)
    r = np.linalg.norm(pts, axis=1)
    th = np.arctan2(pts[:, 1], pts[:, 0]) % (2 * np.pi)
    _, index, across = _lobes(th, petals, notch, teeth, fringe, None)
    z = cup * radius * (r / radius) ** 2
    inner = boundary & (r < radius * (eye + 1e-3)) if eye > 0 else r <= max(0.12, 2 * edge)
    fields = {
        "r": r / radius,
        "theta": th,
        "petal": index.astype(float),
        "phi": across,
        "margin": (boundary & ~inner).astype(float),
        "throat": inner.astype(float),
        "midline": ((np.abs(across) * np.pi / petals * r <= 0.5 * edge)
                    & (r > radius * max(eye, 0.05))).astype(float),
    }
    return Mesh(np.stack([pts[:, 0], pts[:, 1], z], 1), tri, fields=fields,
                name=f"corolla-{petals}")


def _profile(length, radius, mouth, flare, bend, lobe_length):
    """Profile of the surface of revolution: arc length ``s`` -> (rho, z), tube then limb."""
    s = np.linspace(0.0, length + bend + lobe_length, 4000)
    cone = np.arctan2(mouth - radius, length)
    # direction angle from the axis: the cone angle along the tube, then turning outwards
    turn = np.clip((s - length) / bend, 0.0, 1.0)
    angle = cone + (np.radians(flare) - cone) * (3 * turn**2 - 2 * turn**3)
    ds = np.diff(s, prepend=0.0)
    rho = radius + np.cumsum(np.sin(angle) * ds)
    z = np.cumsum(np.cos(angle) * ds)
    return s, rho, z


def tube(
    lobes: int = 5,
    length: float = 1.0,
    radius: float = 0.22,
    *,
    mouth: float | None = None,
    lobe_length: float = 0.45,
    lobe_scales: Sequence[float] | None = None,
    edge: float = 0.02,
    flare: float = 75.0,
    bend: float = 0.25,
    notch: float = 0.05,
    point: float = 0.0,
) -> Mesh:
    """A corolla tube along +z with a flaring limb of ``lobes`` lobes (Digitalis,
    Arctostaphylos, Mimulus-like); ``lobe_scales`` makes it bilateral (e.g. two small upper
    and three large lower lobes); ``point`` (0-1) sharpens the lobe tips (0: rounded).

    The surface of revolution (radius ``radius`` at the base to ``mouth`` at the throat over
    ``length``, then turning outwards by ``flare`` degrees over ``bend``) is meshed through its
    conformal plane: the annulus ``r = exp(int ds / rho(s))``, ``theta``, meshed with planar
    edge ``edge * r / rho``, maps to the surface with equal stretch in both directions, so the
    near-equilateral planar triangles stay near-equilateral on the surface.
    """
    _check(edge, length=length, radius=radius, lobe_length=lobe_length, bend=bend)
    if not (isinstance(lobes, int | np.integer) and 2 <= lobes <= 40):
        raise MorphogenError(f"lobes must be an integer from 2 to 40, got {lobes}")
    if not 0 < flare <= 120:
        raise MorphogenError(f"flare must be in (0, 120] degrees, got {flare}")
    if not 0 <= point <= 1:
        raise MorphogenError(f"point must be in [0, 1] (0 rounded, 1 pointed), got {point}")
    mouth = radius * 1.3 if mouth is None else mouth
    _check(edge, mouth=mouth)
    s, rho, z = _profile(length, radius, mouth, flare, bend, lobe_length)
    return _revolve(s, rho, z, length, length + 0.25 * bend, bend * 0.75 + lobe_length,
                    lobes=lobes, notch=notch, lobe_scales=lobe_scales, edge=edge,
                    name=f"tube-{lobes}", point=point)


def _revolve(s, rho, z, length, limb_start, limb_span, *, lobes, notch, lobe_scales, edge,
             name, point=0.0, offset=0.0, cleft=None, lips=None):
    """Mesh the surface of revolution of the profile ``s -> (rho, z)`` up to the lobed rim
    ``s = limb_start + limb_span * lobe(theta - offset)``, through its conformal plane (see
    ``tube``); ``length`` is the arc length of the throat (``s = 1`` there). ``cleft(theta)``
    lowers the rim (deeper sinuses); ``lips(arc, theta)`` returns ``(rho, z)`` replacing the
    profile (a limb bent differently per angle)."""
    log_r = np.concatenate([[0.0], np.cumsum(np.diff(s) / (0.5 * (rho[1:] + rho[:-1])))])
    theta = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    shape, _, _ = _lobes(theta - offset, lobes, notch, 0, 0.0, lobe_scales, point)
    s_max = limb_start + limb_span * np.clip(shape, 0, None)
    if cleft is not None:
        s_max = s_max - cleft(theta)
    if s_max.max() > s[-1]:
        s_max = np.minimum(s_max, s[-1])
    r_out = np.exp(np.interp(s_max, s, log_r))
    ring = np.linspace(0, 2 * np.pi, max(int(2 * np.pi * rho[0] / edge), 12), endpoint=False)
    loops = [np.stack([r_out * np.cos(theta), r_out * np.sin(theta)], 1),
             np.stack([np.cos(ring), np.sin(ring)], 1)]

    def size(p):
        r = np.linalg.norm(p, axis=1)
        return edge * r / np.interp(np.log(np.maximum(r, 1e-12)), log_r, rho)

    pts, tri, boundary = triangulate(loops, size, holes=[[0.0, 0.0]])
    r = np.linalg.norm(pts, axis=1)
    arc = np.interp(np.log(r), log_r, s)
    th = np.arctan2(pts[:, 1], pts[:, 0]) % (2 * np.pi)
    radial, height = (np.interp(arc, s, rho), np.interp(arc, s, z)) if lips is None \
        else lips(arc, th)
    xyz = np.stack([radial * np.cos(th), radial * np.sin(th), height], 1)
    _, index, across = _lobes(th - offset, lobes, notch, 0, 0.0, lobe_scales, point)
    base = boundary & (r < 1.0 + 1e-6)
    fields = {
        "s": arc / length,
        "theta": th,
        "side": np.sin(th),
        "lobe": index.astype(float),
        "margin": (boundary & ~base).astype(float),
        "base": base.astype(float),
        "throat": _near(arc, length, 0.6 * edge),
        "tube": (arc <= length).astype(float),
        "midline": (np.abs(across) * np.pi / lobes * radial <= 0.5 * edge).astype(float),
    }
    return Mesh(xyz, tri, fields=fields, name=name)


def urn(
    lobes: int = 5,
    length: float = 1.0,
    *,
    radius: float = 0.12,
    belly: float = 0.4,
    waist: float = 0.4,
    mouth: float = 0.14,
    lobe_length: float = 0.12,
    flare: float = 110.0,
    edge: float = 0.02,
    notch: float = 0.0,
) -> Mesh:
    """An urn-shaped corolla along +z (Arctostaphylos, Erica): from a pedicel ring of
    ``radius`` the body bulges to ``belly`` at ``waist * length`` and narrows to ``mouth`` at
    ``length``, then ``lobes`` short lobes (``lobe_length`` beyond the mouth, fused over their
    first 30 %) turn outwards by ``flare`` degrees.

    Body profile: ``rho = radius + (belly - radius) sin(pi/2 z/z_b)`` below the belly
    (``z_b = waist * length``), ``rho = mouth + (belly - mouth) cos(pi/2 (z - z_b)/(L - z_b))``
    above it; the lobes continue from the mouth's direction, turning smoothly to ``flare``
    over their first half. Fields and sets as for :func:`tube` (``s = 1`` at the mouth).
    """
    _check(edge, length=length, radius=radius, belly=belly, mouth=mouth,
           lobe_length=lobe_length)
    if not (isinstance(lobes, int | np.integer) and 2 <= lobes <= 40):
        raise MorphogenError(f"lobes must be an integer from 2 to 40, got {lobes}")
    if not 0.1 <= waist <= 0.9:
        raise MorphogenError(f"waist must be in [0.1, 0.9] (fraction of the length), got {waist}")
    if not (belly > radius and belly > mouth):
        raise MorphogenError(f"belly ({belly}) must be wider than radius ({radius}) and mouth "
                             f"({mouth}) for an urn")
    if not 0 < flare <= 150:
        raise MorphogenError(f"flare must be in (0, 150] degrees, got {flare}")
    zb = waist * length
    zz = np.linspace(0.0, length, 3000)
    body = np.where(zz < zb, radius + (belly - radius) * np.sin(0.5 * np.pi * zz / zb),
                    mouth + (belly - mouth) * np.cos(0.5 * np.pi * (zz - zb) / (length - zb)))
    seg = np.hypot(np.diff(body), np.diff(zz))
    s_body = np.concatenate([[0.0], np.cumsum(seg)])
    start = np.arctan2(body[-1] - body[-2], zz[-1] - zz[-2])  # the neck's angle from the axis
    t = np.linspace(0.0, lobe_length * 1.05, 1000)[1:]
    turn = np.clip(t / (0.5 * lobe_length), 0.0, 1.0)
    angle = start + (np.radians(flare) - start) * (3 * turn**2 - 2 * turn**3)
    dt = t[1] - t[0]
    rho = np.concatenate([body, body[-1] + np.cumsum(np.sin(angle)) * dt])
    z = np.concatenate([zz, length + np.cumsum(np.cos(angle)) * dt])
    s = np.concatenate([s_body, s_body[-1] + t])
    if rho.min() <= 0:
        raise MorphogenError("urn: the lobes turn back through the axis; lower flare or "
                             "lobe_length")
    # the lobes are fused over their first 30 % (no sinus down to the mouth itself)
    return _revolve(s, rho, z, s_body[-1], s_body[-1] + 0.3 * lobe_length, 0.7 * lobe_length,
                    lobes=lobes, notch=notch, lobe_scales=None, edge=edge, name=f"urn-{lobes}")


def bell(
    lobes: int = 5,
    length: float = 0.7,
    *,
    radius: float = 0.18,
    mouth: float = 0.55,
    flare: float = 62.0,
    bend: float = 0.3,
    lobe_length: float = 0.55,
    notch: float = 0.0,
    point: float = 0.0,
    edge: float = 0.02,
) -> Mesh:
    """A bell-shaped, partially fused corolla (Platycodon, Ringham §4.1): a :func:`tube` that
    widens from ``radius`` to a wide ``mouth`` and opens by ``flare`` degrees into ``lobes``
    broad, un-notched lobes, rounded (``point = 0``) or ending in a point (Platycodon's are
    broadly triangular: ``point`` about 0.6). Fields and sets as for :func:`tube`."""
    mesh = tube(lobes, length, radius, mouth=mouth, lobe_length=lobe_length, edge=edge,
                flare=flare, bend=bend, notch=notch, point=point)
    return mesh.replace(name=f"bell-{lobes}")


def two_lipped(
    lobes: int = 5,
    length: float = 0.9,
    *,
    upper: float = 0.7,
    lower: float = 1.2,
    radius: float = 0.22,
    mouth: float | None = None,
    flare: float = 45.0,
    bend: float = 0.25,
    lobe_length: float = 0.35,
    notch: float = 0.05,
    edge: float = 0.02,
) -> Mesh:
    """A two-lipped tube (Digitalis, Mimulus; Ringham §4.5-4.6): a :func:`tube` whose lobes
    pointing up (``sin theta_k > 0.1`` for lobe ``k`` at ``theta_k = 2 pi k / lobes``, lobe 0
    along +x) are scaled by ``upper`` and the others (the lower lip) by ``lower``; five lobes
    give two upper and three lower. Fields and sets as for :func:`tube` (``side`` < 0 on the
    lower side)."""
    _check(edge, upper=upper, lower=lower)
    if not (isinstance(lobes, int | np.integer) and 2 <= lobes <= 40):
        raise MorphogenError(f"lobes must be an integer from 2 to 40, got {lobes}")
    theta = 2.0 * np.pi * np.arange(lobes) / lobes
    scales = np.where(np.sin(theta) > 0.1, upper, lower)
    mesh = tube(lobes, length, radius, mouth=mouth, lobe_length=lobe_length,
                lobe_scales=scales.tolist(), edge=edge, flare=flare, bend=bend, notch=notch)
    return mesh.replace(name=f"two-lipped-{lobes}")


def bilabiate(
    lobes: int = 5,
    length: float = 0.9,
    *,
    radius: float = 0.22,
    mouth: float | None = None,
    upper: float = 0.8,
    lower: float = 1.3,
    upper_flare: float = 115.0,
    lower_flare: float = 75.0,
    bend: float = 0.25,
    lobe_length: float = 0.4,
    cleft: float = 0.8,
    notch: float = 0.1,
    edge: float = 0.02,
) -> Mesh:
    """A two-lipped corolla (Mimulus, Ringham §4.5, fig. 1): a :func:`tube` whose limb splits
    into an upper lip of ``lobes // 2`` lobes (scaled by ``upper``), bent back by
    ``upper_flare`` degrees from the tube's axis, and a lower lip of the others (scaled by
    ``lower``) spreading at ``lower_flare``; deep clefts separate the lips.

    The lobes are placed symmetrically about the vertical (``side = sin theta``, +1 up): for
    five lobes, upper lobes at 54° and 126°, lower lobes at 198°, 270° (the middle of the lower
    lip) and 342°. The two clefts between the lips (at 18° and 162° for five lobes) reach down
    ``cleft`` of the way from the rim's sinus level to the throat (Gaussian in angle, a
    quarter-lobe wide). Each vertex's meridian profile is the upper lip's where
    ``sin theta`` is above the clefts' level and the lower lip's below, blended smoothly over
    ``±0.25`` in ``sin theta``; the tube below the limb is common to both. Fields and sets as
    for :func:`tube`, plus ``upper_lip`` (1 on the upper lip's side).
    """
    _check(edge, length=length, radius=radius, upper=upper, lower=lower,
           lobe_length=lobe_length, bend=bend)
    if not (isinstance(lobes, int | np.integer) and 3 <= lobes <= 12):
        raise MorphogenError(f"lobes must be an integer from 3 to 12, got {lobes}")
    for label, value in (("upper_flare", upper_flare), ("lower_flare", lower_flare)):
        if not 0 < value <= 150:
            raise MorphogenError(f"{label} must be in (0, 150] degrees, got {value}")
    if not 0 <= cleft <= 1:
        raise MorphogenError(f"cleft must be in [0, 1], got {cleft}")
    mouth = radius * 1.3 if mouth is None else mouth
    _check(edge, mouth=mouth)
    sector = 2.0 * np.pi / lobes
    n_up = lobes // 2
    offset = np.pi / 2 - (n_up - 1) * sector / 2  # lobe 0: the rightmost upper lobe
    angles = offset + sector * np.arange(lobes)
    scales = np.where(np.arange(lobes) < n_up, upper, lower)
    gaps = [offset - sector / 2, offset + sector * (n_up - 0.5)]  # the clefts
    level = float(np.sin(gaps[0]))
    reach = length + bend + lobe_length * max(upper, lower)
    s_lo, rho_lo, z_lo = _profile(length, radius, mouth, lower_flare, bend, reach - length - bend)
    _, rho_up, z_up = _profile(length, radius, mouth, upper_flare, bend, reach - length - bend)
    rho_mid, z_mid = 0.5 * (rho_lo + rho_up), 0.5 * (z_lo + z_up)
    limb_start = length + 0.25 * bend
    depth = cleft * (limb_start - length)

    def clefts(theta):
        d = [np.angle(np.exp(1j * (theta - g))) for g in gaps]
        return depth * sum(np.exp(-((x / (0.25 * sector)) ** 2)) for x in d)

    def weight(theta):
        t = np.clip((np.sin(theta) - level + 0.25) / 0.5, 0.0, 1.0)
        return t * t * (3 - 2 * t)

    def lip_profile(arc, theta):
        w = weight(theta)
        rho = (1 - w) * np.interp(arc, s_lo, rho_lo) + w * np.interp(arc, s_lo, rho_up)
        return rho, (1 - w) * np.interp(arc, s_lo, z_lo) + w * np.interp(arc, s_lo, z_up)

    mesh = _revolve(s_lo, rho_mid, z_mid, length, limb_start, bend * 0.75 + lobe_length,
                    lobes=lobes, notch=notch, lobe_scales=scales.tolist(), edge=edge,
                    name=f"bilabiate-{lobes}", offset=float(angles[0]), cleft=clefts,
                    lips=lip_profile)
    upper_lip = (weight(mesh.fields["theta"]) > 0.5).astype(float)
    return mesh.with_fields(upper_lip=upper_lip)
