"""PLY input and output for meshes: round trips, fields, bad files."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from plyfile import PlyData

from morphogen.domains.ply import apply_fields, load_mesh, ply_fields, save_ply
from morphogen.errors import MorphogenError
from morphogen.flowers.planar import lattice_mesh
from morphogen.models.library import get_model
from morphogen.render.mesh_outputs import write_mesh_outputs


@pytest.fixture
def mesh():
    base = lattice_mesh(9, 7, spacing=0.5)
    rng = np.random.default_rng(0)
    # a shuffled vertex order must survive the round trip untouched
    perm = rng.permutation(base.n_vertices)
    inverse = np.argsort(perm)
    m = base.replace(vertices=base.vertices[perm], faces=inverse[base.faces])
    return m.with_fields(g=rng.random(m.n_vertices), margin=np.isin(
        np.arange(m.n_vertices), m.boundary_vertices).astype(float))


@pytest.mark.parametrize("binary", [True, False])
def test_round_trip_keeps_order_and_fields(tmp_path, mesh, binary):
    path = save_ply(tmp_path / "m.ply", mesh, fields={"a": np.arange(mesh.n_vertices) * 0.5},
                    binary=binary)
    back = load_mesh(path)
    assert np.array_equal(back.vertices, mesh.vertices)
    assert np.array_equal(back.faces, mesh.faces)
    assert set(back.fields) == {"g", "margin", "a"}
    assert np.allclose(back.fields["g"], mesh.fields["g"], atol=1e-7)
    assert np.array_equal(back.fields["a"], np.arange(mesh.n_vertices) * 0.5)
    assert np.array_equal(back.vertex_set("margin"), mesh.boundary_vertices)
    assert list(tmp_path.iterdir()) == [path]  # nothing temporary left behind


def test_colours_from_other_tools_become_unit_fields(tmp_path):
    box = trimesh.creation.icosphere(subdivisions=1)
    colours = np.zeros((len(box.vertices), 4), np.uint8)
    colours[:, 0] = 255
    colours[::2, 1] = 51
    colours[:, 3] = 255
    box.visual.vertex_colors = colours
    path = tmp_path / "c.ply"
    box.export(path)
    fields = ply_fields(path)
    assert np.allclose(fields["red"], 1.0)
    assert np.allclose(fields["green"][::2], 0.2)
    assert np.allclose(load_mesh(path).vertices, np.asarray(box.vertices), atol=1e-6)


def _write_ascii(path, vertices, faces):
    lines = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}",
             "property float x", "property float y", "property float z",
             f"element face {len(faces)}", "property list uchar int vertex_indices",
             "end_header"]
    lines += [" ".join(map(str, v)) for v in vertices]
    lines += [" ".join(map(str, [len(f), *f])) for f in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_bad_files_give_one_line_errors(tmp_path):
    v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1]]
    cases = {
        "missing": (tmp_path / "none.ply", "does not exist"),
        "garbage": (tmp_path / "g.ply", "cannot read"),
        "truncated": (tmp_path / "t.ply", "cannot read"),
        "nonmanifold": (_write_ascii(tmp_path / "n.ply", v, [[0, 1, 2], [1, 0, 3], [0, 1, 4]]),
                        "non-manifold"),
        "degenerate": (_write_ascii(tmp_path / "d.ply", [[0, 0, 0], [1, 0, 0], [2, 0, 0],
                                                          [0, 1, 0]], [[0, 1, 2], [0, 1, 3]]),
                       "zero area"),
        "points": (tmp_path / "p.ply", "no faces"),
    }
    (tmp_path / "g.ply").write_bytes(b"\x00\x01not a ply at all")
    good = save_ply(tmp_path / "ok.ply", lattice_mesh(5, 5))
    (tmp_path / "t.ply").write_bytes(good.read_bytes()[:-40])
    (tmp_path / "p.ply").write_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                    "property float y\nproperty float z\nend_header\n0 0 0\n")
    for name, (path, message) in cases.items():
        with pytest.raises(MorphogenError, match=message) as info:
            load_mesh(path)
        assert "\n" not in str(info.value), name


def test_quads_are_split_with_a_warning(tmp_path):
    path = _write_ascii(tmp_path / "q.ply", [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
                        [[0, 1, 2, 3]])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_mesh(path)
    assert mesh.n_faces == 2 and any("fans" in str(w.message) for w in caught)


def test_outputs_and_fields_as_initial_values(tmp_path, mesh):
    model = get_model("gray-scott")
    u0 = np.zeros((2, mesh.n_vertices), np.float32)
    m = mesh.with_fields(v=np.full(mesh.n_vertices, 0.25), F=np.linspace(0.01, 0.05,
                                                                         mesh.n_vertices))
    u, params = apply_fields(model, m, u0, model.parameters())
    assert np.allclose(u[1], 0.25) and np.allclose(u[0], 0.0)
    assert params["F"].shape == (mesh.n_vertices,) and params["k"] == model.params["k"]
    state = np.stack([np.ones(mesh.n_vertices), np.linspace(0, 1, mesh.n_vertices)])
    paths = write_mesh_outputs(tmp_path / "out", mesh, model, state, "magma")
    assert [p.name for p in paths] == ["out.ply", "out.png"]
    ply = PlyData.read(str(paths[0]))
    assert np.allclose(ply["vertex"]["v"], state[1], atol=1e-6)
    assert ply["vertex"]["red"].dtype == np.uint8
    assert np.allclose(ply_fields(paths[0])["g"], mesh.fields["g"], atol=1e-7)
    with pytest.raises(MorphogenError, match="state has shape"):
        write_mesh_outputs(tmp_path / "bad", mesh, model, state[:1], "magma")


_TRIANGLE = "0 0 0\n1 0 0\n0 1 0\n"


@pytest.mark.parametrize("header, body, message", [
    ("element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
     "element face 1\nproperty int vertex_indices\n", _TRIANGLE + "1\n", "must be a list"),
    ("element vertex 3\nproperty list uchar float x\nproperty float y\nproperty float z\n"
     "element face 1\nproperty list uchar int vertex_indices\n",
     "1 0 0 0\n1 1 0 0\n1 0 1 0\n3 0 1 2\n", "x is a list"),
    ("element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
     "element face 1\nproperty list uchar float vertex_indices\n", _TRIANGLE + "3 0 1.5 2\n",
     "non-integer indices"),
    ("element vertex 3\nproperty double x\nproperty float y\nproperty float z\n"
     "element face 1\nproperty list uchar int vertex_indices\n",
     "1e308 0 0\n-1e308 0 0\n0 1 0\n3 0 1 2\n", "infinite area"),
])
def test_malformed_properties_are_one_line_errors(tmp_path, header, body, message):
    """Inputs coverage-guided fuzzing reached: wrong property kinds and overflowing geometry
    are refused by the loader instead of escaping as TypeError or ValueError."""
    path = tmp_path / "m.ply"
    path.write_text(f"ply\nformat ascii 1.0\n{header}end_header\n{body}")
    with pytest.raises(MorphogenError, match=message) as info:
        load_mesh(path)
    assert "\n" not in str(info.value)
