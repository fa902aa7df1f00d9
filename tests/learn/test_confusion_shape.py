"""The resemblance by shape (learn/confusion.py ``shape=True``) on hand-made textures: a maze
painted in a checkerboard's colours is farther from the checkerboard than a checkerboard in
other colours, which the colour loss of the training gets the other way round."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.learn.confusion import confusion_table, shape_only

N = 64
BROWN, BEIGE = np.array([0.55, 0.27, 0.07]), np.array([0.96, 0.87, 0.70])
BLUE, YELLOW = np.array([0.10, 0.20, 0.80]), np.array([0.95, 0.90, 0.20])


def paint(mask: np.ndarray, ink: np.ndarray, ground: np.ndarray) -> np.ndarray:
    return np.where(mask[..., None], ink, ground).astype(np.float32)


def checker(shift: tuple[int, int] = (0, 0)) -> np.ndarray:
    y, x = np.mgrid[0:N, 0:N]
    return ((((y + shift[0]) // 8) + ((x + shift[1]) // 8)) % 2).astype(bool)


def maze(seed: int = 0) -> np.ndarray:
    """A labyrinth: band-pass noise (wavelength about 16 cells) split at its median."""
    rng = np.random.default_rng(seed)
    q = np.hypot(*np.meshgrid(np.fft.fftfreq(N), np.fft.fftfreq(N)))
    field = np.real(np.fft.ifft2(np.fft.fft2(rng.normal(size=(N, N)))
                                 * np.exp(-((q - 1 / 16) / 0.01) ** 2)))
    return field > np.median(field)


def test_shape_only_keeps_where_light_and_dark_fall_and_drops_the_palette():
    a = shape_only(paint(checker(), BROWN, BEIGE))
    b = shape_only(paint(checker(), 0.2 * BEIGE, 0.5 * BEIGE + 0.5))  # other colours, same order
    np.testing.assert_allclose(a, b)
    assert np.unique(a).tolist() == pytest.approx([0.25, 0.75], abs=1e-3)  # two equal halves
    assert a.shape == (N, N, 3) and np.all(a[..., 0] == a[..., 2])


@pytest.mark.slow
def test_a_recoloured_maze_is_farther_from_the_checker_than_a_checker_in_other_colours():
    target = {"checker": paint(checker(), BROWN, BEIGE)}
    images = {"maze in checker colours": paint(maze(), BROWN, BEIGE)[None],
              "checker in other colours": paint(checker((3, 5)), BLUE, YELLOW)[None]}
    by_colour = confusion_table(images, target, n_rot=8).mean[:, 0]
    by_shape = confusion_table(images, target, n_rot=8, shape=True).mean[:, 0]
    assert by_shape[0] > by_shape[1]  # the shape measure: the real checkerboard is nearer
    assert by_colour[0] < by_colour[1]  # the colour loss: the maze in the right colours wins
