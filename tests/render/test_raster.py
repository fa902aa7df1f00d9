"""The depth-buffer rasteriser and the mesh renderer built on it, on hand-built scenes: which
pixels a triangle covers, which of two triangles is seen, depth interpolated across a
triangle, supersampled edges, and a brute-force reference for random triangles."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.render import raster
from morphogen.render.mesh import render_mesh
from morphogen.render.raster import rasterise

WHITE = np.ones(3)
RED, BLUE = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def cross(u: np.ndarray, v: np.ndarray) -> float:
    return u[0] * v[1] - u[1] * v[0]


def square(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """Two triangles covering the rectangle, ``(2, 3, 2)``."""
    return np.array([[[x0, y0], [x1, y0], [x1, y1]], [[x0, y0], [x1, y1], [x0, y1]]])


def test_a_rectangle_covers_exactly_the_pixels_whose_centres_it_contains():
    image = rasterise(square(2, 1, 6, 4), np.zeros((2, 3)), np.stack([RED, RED]), (8, 6),
                      WHITE, ss=1)
    red = np.all(image == [255, 0, 0], axis=-1)
    expected = np.zeros((6, 8), bool)
    expected[1:4, 2:6] = True  # rows are y, columns x
    np.testing.assert_array_equal(red, expected)
    assert np.all(image[~red] == 255)


@pytest.mark.parametrize("red_depth, seen", [(1.0, [255, 0, 0]), (-1.0, [0, 0, 255])])
def test_the_nearer_of_two_triangles_is_seen_whatever_their_order(red_depth, seen):
    tris = np.concatenate([square(0, 0, 4, 4), square(0, 0, 4, 4)])
    depth = np.array([[red_depth] * 3] * 2 + [[0.0] * 3] * 2)
    for order in ([0, 1, 2, 3], [2, 3, 0, 1]):
        colours = np.stack([RED, RED, BLUE, BLUE])[order]
        image = rasterise(tris[order], depth[order], colours, (4, 4), WHITE, ss=1)
        assert np.all(image == seen)


def test_depth_is_interpolated_across_each_triangle():
    # two planes crossing at x = 4: red nearer on the left, blue nearer on the right
    tris = np.concatenate([square(0, 0, 8, 2), square(0, 0, 8, 2)])
    x = tris[..., 0]
    depth = np.concatenate([1 - x[:2] / 4, x[2:] / 4 - 1])
    image = rasterise(tris, depth, np.stack([RED, RED, BLUE, BLUE]), (8, 2), WHITE, ss=1)
    assert np.all(image[:, :4] == [255, 0, 0]) and np.all(image[:, 4:] == [0, 0, 255])


def test_supersampling_averages_a_half_covered_pixel():
    image = rasterise(square(0, 0, 2.5, 2), np.zeros((2, 3)), np.stack([RED, RED]), (4, 2),
                      WHITE, ss=2)
    # column 2 has its left half covered: half red, half white
    np.testing.assert_array_equal(image[:, 2], [[255, 128, 128]] * 2)
    assert np.all(image[:, :2] == [255, 0, 0]) and np.all(image[:, 3] == 255)


def test_random_triangles_match_a_pixel_by_pixel_reference(monkeypatch):
    # small groups force the chunking; sizes from sub-pixel to the whole picture
    monkeypatch.setattr(raster, "CHUNK", 50)
    rng = np.random.default_rng(3)
    width, height, n = 40, 30, 60
    centre = rng.uniform([0, 0], [width, height], (n, 1, 2))
    tris = centre + rng.normal(size=(n, 3, 2)) * rng.choice([0.7, 3.0, 25.0], (n, 1, 1))
    depth = rng.normal(size=(n, 3))
    colours = rng.uniform(size=(n, 3))
    image = rasterise(tris, depth, colours, (width, height), WHITE, ss=1)

    reference = np.ones((height, width, 3))
    for iy in range(height):
        for ix in range(width):
            p, best = np.array([ix + 0.5, iy + 0.5]), -np.inf
            for t in range(n):
                a, b, c = tris[t]
                area = cross(b - a, c - a)
                lam = np.array([cross(c - b, p - b), cross(a - c, p - c),
                                cross(b - a, p - a)]) / area
                if np.all(lam >= 0) and lam @ depth[t] > best:
                    best, reference[iy, ix] = lam @ depth[t], colours[t]
    np.testing.assert_array_equal(image, np.rint(reference * 255).astype(np.uint8))


def test_a_mesh_seen_from_the_top_has_x_to_the_right_and_y_up():
    # a flat unit square in z = 0 with its corner (1, 0) red: only the triangle below the
    # diagonal y = x has that corner, so the picture's bottom right is redder than its top left
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    colours = np.array([[0, 0, 255], [255, 0, 0], [0, 0, 255], [0, 0, 255]], np.uint8)
    image = render_mesh(vertices, faces, colours, view="top", size=(64, 64), shade=0.0)
    h, w, _ = image.shape  # the square less the 8-pixel margin kept around it
    assert list(image[h - 12, w - 12]) == [85, 0, 170]  # the mean of its corners' colours
    assert list(image[12, 12]) == [0, 0, 255]
    # the light at the camera: seen from 30° above, the face gets cos 60° = 0.5 of the Lambert
    # term, 0.4 + 0.6 * 0.5 = 0.7 of its colour (grey on a white background)
    grey = np.full((4, 3), 128, np.uint8)
    flat = render_mesh(vertices, faces, grey, view="top", size=(32, 32))
    tilted = render_mesh(vertices, faces, grey, view=(30.0, -90.0), size=(32, 32))
    assert np.median(flat[flat < 255]) == 128
    assert np.median(tilted[tilted < 255]) == round(0.7 * 128)
