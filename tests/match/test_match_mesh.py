"""``morphogen match MESH.ply``: a vertex field flattened onto the mesh's plane, described only
where the mesh is, its wavelength in mesh units; bad meshes refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.mesh import Mesh
from morphogen.domains.ply import save_ply
from morphogen.flowers.meshing import triangulate
from morphogen.flowers.planar import grid_mesh
from morphogen.match.api import describe_picture
from morphogen.match.mesh_picture import load_mesh_picture
from morphogen.match.signature import signature
from tests.match_support import assert_refused

RADIUS, EDGE, PERIOD = 10.0, 0.3, 2.0
"""The test disc's radius and edge length, and the wavelength of its patterns (mesh units)."""


def _disc() -> tuple[np.ndarray, np.ndarray]:
    """A triangulated flat disc: points ``(V, 2)`` and triangles ``(F, 3)``."""
    theta = np.linspace(0.0, 2.0 * np.pi, 200, endpoint=False)
    outline = RADIUS * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    points, triangles, _ = triangulate([outline], lambda p: np.full(len(p), EDGE))
    return points, triangles


def _stripes(p: np.ndarray, angle: float = 0.0) -> np.ndarray:
    """Stripes of wavelength :data:`PERIOD` whose wave vector makes ``angle`` degrees with x."""
    a = np.radians(angle)
    return np.cos(2.0 * np.pi * (p[:, 0] * np.cos(a) + p[:, 1] * np.sin(a)) / PERIOD)


def _hexagons(p: np.ndarray) -> np.ndarray:
    """Three cosines 120 degrees apart of wavelength :data:`PERIOD`: hexagonal spots (their
    spacing is ``2 PERIOD / sqrt 3``)."""
    k = 2.0 * np.pi / PERIOD
    return sum(np.cos(k * (p[:, 0] * np.cos(a) + p[:, 1] * np.sin(a)))
               for a in (0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0))


def _turn(points: np.ndarray) -> np.ndarray:
    """The flat points ``(V, 2)`` placed in space: turned about every axis, tilted, moved."""
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    flat = np.column_stack([points, np.zeros(len(points))])
    return flat @ q.T + np.array([4.0, -7.0, 2.5])


def _write(path, points, triangles, **fields) -> str:
    vertices = points if points.shape[1] == 3 else np.column_stack([points, np.zeros(len(points))])
    save_ply(path, Mesh(vertices, triangles, fields=fields))
    return str(path)


@pytest.mark.parametrize("angle", [0.0, 35.0])
def test_stripes_keep_their_wavelength_in_mesh_units_however_the_mesh_is_turned(tmp_path, angle):
    points, triangles = _disc()
    field = _stripes(points, angle)
    seen = {}
    for pose, where in {"flat": points, "turned": _turn(points)}.items():
        ply = _write(tmp_path / f"{pose}.ply", where, triangles, u=field)
        picture = load_mesh_picture(ply)
        sig = describe_picture(picture)
        assert sig.family == "stripes", pose
        seen[pose] = sig.wavelength * picture.pixel_size
        assert seen[pose] == pytest.approx(PERIOD, rel=0.1), pose
        # the disc fills its square: a diameter across the longer side, pi/4 of the pixels
        assert picture.pixel_size * max(picture.field.shape) == pytest.approx(2 * RADIUS, rel=0.03)
        assert picture.mask.mean() == pytest.approx(np.pi / 4, rel=0.05)
    assert seen["turned"] == pytest.approx(seen["flat"], rel=0.01)


def test_spots_on_a_disc_are_spots_and_the_outside_is_never_described(tmp_path):
    points, triangles = _disc()
    picture = load_mesh_picture(_write(tmp_path / "spots.ply", points, triangles,
                                       u=_hexagons(points)))
    sig = describe_picture(picture)
    assert sig.family == "spots"
    assert sig.wavelength * picture.pixel_size == pytest.approx(PERIOD, rel=0.1)
    assert np.all(picture.rgb[~picture.mask] == 1.0)  # white around the mesh on the sheet
    noise = np.random.default_rng(0).random(picture.field.shape).astype(np.float32)
    other = signature(np.where(picture.mask, picture.field, noise), periodic=False,
                      mask=picture.mask)
    assert other.to_dict() == sig.to_dict()
    assert np.allclose(other.histogram, sig.histogram) and np.allclose(other.profile, sig.profile)
    inner = picture.inner
    assert inner.size > 0.5 * picture.mask.sum()  # the largest square in a disc: 2/pi of it


def test_where_organs_overlap_the_one_in_front_is_seen(tmp_path):
    """Two flat squares, one 1 unit above the other and shifted by half: seen from the side
    their faces face, the upper square's field hides the lower one's where they overlap."""
    lower, upper = grid_mesh(41, 41, 0.25), grid_mesh(41, 41, 0.25)
    vertices = np.concatenate([lower.vertices, upper.vertices + [5.0, 0.0, 1.0]])
    faces = np.concatenate([lower.faces, upper.faces + lower.n_vertices])
    u = np.concatenate([np.zeros(lower.n_vertices), np.ones(upper.n_vertices)])
    path = tmp_path / "organs.ply"
    save_ply(path, Mesh(vertices, faces, fields={"u": u}))
    picture = load_mesh_picture(path)
    rows = picture.mask.any(axis=1)
    middle = picture.field[rows][:, picture.field.shape[1] // 2]  # x = 7.5: both squares
    assert np.all(middle > 0.99)
    left = picture.field[rows][:, 10]  # x < 5: the lower square alone
    assert np.all(left < 0.01)


def test_a_wall_seen_edge_on_is_left_out(tmp_path):
    """A flat 11 x 10 rectangle whose last unit rises 6 units (80 degrees): the wall's pattern
    would come out squeezed by the projection, so only the flat part is described."""
    mesh = grid_mesh(49, 41, 0.25)
    x = mesh.vertices[:, 0]
    vertices = mesh.vertices + np.column_stack([0 * x, 0 * x, 6.0 * np.maximum(x - 11.0, 0.0)])
    u = np.cos(2.0 * np.pi * mesh.vertices[:, 1] / PERIOD)
    save_ply(tmp_path / "wall.ply", Mesh(vertices, mesh.faces, fields={"u": u}))
    picture = load_mesh_picture(tmp_path / "wall.ply")
    assert "36% of the surface, tilted over 60 degrees from the plane, left out" in picture.note
    width = picture.mask.any(axis=0).sum() * picture.pixel_size
    assert width == pytest.approx(11.0, rel=0.05)
    assert describe_picture(picture).wavelength * picture.pixel_size == pytest.approx(
        PERIOD, rel=0.1)


def test_the_default_field_is_the_first_species_else_the_colours(tmp_path):
    points, triangles = _disc()
    mesh = Mesh(np.column_stack([points, np.zeros(len(points))]), triangles,
                fields={"s": points[:, 0], "a": _stripes(points), "h": _hexagons(points)})
    colours = (255 * (0.5 + 0.5 * _stripes(points, 90.0)[:, None]) * [1, 0.3, 0.1]).astype(np.uint8)
    save_ply(tmp_path / "final.ply", mesh, colours=colours)
    picture = load_mesh_picture(tmp_path / "final.ply")
    assert picture.note.startswith("field colours")  # no species known: what the file shows
    (tmp_path / "pipeline.json").write_text(json.dumps({"stages": [
        {"kind": "positional", "fields": ["s"]},
        {"kind": "simulate", "fields": ["a", "h"]}]}))
    assert load_mesh_picture(tmp_path / "final.ply").note.startswith("field a ")
    assert load_mesh_picture(tmp_path / "final.ply", channel="red").note.startswith(
        "field colours")


def test_the_match_reports_the_mesh_and_its_wavelength_in_mesh_units(tmp_path, monkeypatch):
    """The command's path up to the search (which the other match tests cover): the target's
    line quotes mesh units, and the report quotes them for the answer's cells."""
    from morphogen.match import api
    from morphogen.match.answer import Candidate, report_text
    from morphogen.match.search import Samples

    points, triangles = _disc()
    ply = _write(tmp_path / "final.ply", points, triangles, u=_stripes(points))
    lines = []

    class Stop(Exception):
        pass

    def stop(*args, **kwargs):
        raise Stop

    monkeypatch.setattr(api, "run_search", stop)
    with pytest.raises(Stop):
        api.match(ply, models=["gray-scott"], budget=8, out=tmp_path / "answer",
                  log=lines.append)
    assert lines[0].startswith("final.ply: field u flattened onto its best-fit plane")
    units = float(lines[1].split("px (")[1].split(" mesh units")[0])
    assert units == pytest.approx(PERIOD, rel=0.1)
    assert not (tmp_path / "answer").exists()
    cand = Candidate(model="gray-scott", params={"F": 0.03}, dx=1.0, size=(64, 64), dt=1.0,
                     steps=10, seed=0, init="blobs", invert=False, family="stripes",
                     distance=0.1, texture=0.1, pixels_per_cell=2.0, wavelength_px=38.0)
    sig = describe_picture(load_mesh_picture(ply))
    text = report_text("final.ply", sig, 1.0, [cand], Samples(), 1.0, pixel_size=0.05)
    assert "(1.9 mesh units)" in text and "a cell is 0.1 mesh units" in text


def test_help_names_the_field_option(capsys):
    with pytest.raises(SystemExit):
        main(["match", "--help"])
    out = capsys.readouterr().out
    assert "--field" in out and ".ply" in out


def _bad_cases(tmp_path):
    points, triangles = _disc()
    good = _write(tmp_path / "good.ply", points, triangles, u=_stripes(points))
    flat = _write(tmp_path / "flat.ply", points, triangles, u=np.ones(len(points)))
    from plyfile import PlyData, PlyElement

    cloud = np.zeros(3, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("u", "f4")])
    cloud["x"], cloud["y"], cloud["u"] = [0, 1, 0], [0, 0, 1], [0, 1, 2]
    PlyData([PlyElement.describe(cloud, "vertex")], text=True).write(str(tmp_path / "cloud.ply"))
    (tmp_path / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\n"
                                          b"property float x\nend_header\n1 2\n")
    (tmp_path / "text.ply").write_text("not a mesh at all")
    return {
        "missing field": ([good, "--field", "pigment"], "no vertex field 'pigment'; it has u"),
        "no faces": ([str(tmp_path / "cloud.ply")], "no faces"),
        "malformed": ([str(tmp_path / "broken.ply")], "PLY"),
        "not PLY": ([str(tmp_path / "text.ply")], "PLY"),
        "constant field": ([flat], "constant"),
        "crop": ([good, "--crop", "0,0,30,30"], "--crop applies to a picture"),
        "channel of a field": ([good, "--field", "u", "--channel", "red"], "--channel"),
    }


@pytest.mark.parametrize("case", ["missing field", "no faces", "malformed", "not PLY",
                                  "constant field", "crop", "channel of a field"])
def test_a_bad_mesh_is_one_line_and_writes_nothing(case, tmp_path, capsys):
    assert_refused(*_bad_cases(tmp_path)[case], tmp_path, capsys)


def test_field_is_refused_for_a_picture(tmp_path, capsys):
    from PIL import Image

    y, x = np.mgrid[0:64, 0:64]
    Image.fromarray((127.5 * (1 + np.cos(2 * np.pi * x / 12))).astype(np.uint8)).save(
        tmp_path / "p.png")
    assert main(["match", str(tmp_path / "p.png"), "--field", "u", "--out",
                 str(tmp_path / "answer")]) == 2
    assert "--field applies to a mesh target" in capsys.readouterr().err
