"""``morphogen match``: descriptor invariances, a planted Gray-Scott target, resuming."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from morphogen.match.signature import distance, signature


def _hexagons(n: int = 192, period: float = 12.0) -> np.ndarray:
    """Three cosines 120 degrees apart: a hexagonal spot lattice of wavelength ``period``."""
    y, x = np.mgrid[0:n, 0:n].astype(float)
    k = 2 * np.pi / (period * np.sqrt(3) / 2)
    f = sum(np.cos(k * (x * np.cos(a) + y * np.sin(a))) for a in (0, 2 * np.pi / 3, 4 * np.pi / 3))
    return f.astype(np.float32)


def _labyrinth(n: int = 192, period: float = 14.0, seed: int = 0) -> np.ndarray:
    """Band-pass noise at ``period``, sharpened: a labyrinth of stripes."""
    rng = np.random.default_rng(seed)
    q = np.hypot(*np.meshgrid(np.fft.fftfreq(n), np.fft.fftfreq(n)))
    ring = np.exp(-((q - 1 / period) ** 2) / (2 * (0.05 / period) ** 2))
    f = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((n, n))) * ring))
    return np.tanh(3 * f / f.std()).astype(np.float32)


FIXTURES = {"spots": _hexagons, "stripes": _labyrinth, "holes": lambda: -_hexagons()}


def _rotate(f: np.ndarray, degrees: float) -> np.ndarray:
    r = ndimage.rotate(f, degrees, reshape=False, order=1, mode="wrap")
    c = f.shape[0] // 4
    return r[c:-c, c:-c]


@pytest.mark.parametrize("family", list(FIXTURES))
def test_signature_is_blind_to_rotation_contrast_and_resolution(family):
    f = FIXTURES[family]()
    base = signature(f[:128, :128], periodic=False)
    assert base.family == family
    cases = {
        "rotated 30": (_rotate(f, 30.0), 1.0),
        "contrast": (3.0 * f - 7.0, 1.0),
        "gamma 0.7": (((f - f.min()) / np.ptp(f)) ** 0.7, 1.0),
        "half size": (ndimage.zoom(f, 0.5, order=1), 0.5),
        "double size": (ndimage.zoom(f[:128, :128], 2.0, order=1), 2.0),
        "blur and noise": (ndimage.gaussian_filter(f, 1.0)
                           + np.random.default_rng(1).normal(0, 0.2 * f.std(), f.shape), 1.0),
    }
    for name, (g, scale) in cases.items():
        s = signature(g, periodic=False)
        assert s.family == family, name
        assert s.wavelength / scale == pytest.approx(base.wavelength, rel=0.05), name
        assert distance(s, base) < 0.35, name


def test_polarity_flips_spots_to_holes():
    f = _hexagons()
    assert signature(f, periodic=False, invert=True).family == "holes"


def test_a_planted_gray_scott_target_is_found_and_resumed(tmp_path, monkeypatch):
    """Spots grown by Gray-Scott at (F, k) = (0.035, 0.064) (not a preset), from another
    initial condition, tiled, turned by 30 degrees and recoloured, are matched by Gray-Scott
    spots at the picture's wavelength within a 12-simulation budget; interrupted after its
    search, the match resumes from its journal without simulating a population again."""
    import jax
    from matplotlib import colormaps

    from morphogen.match import boxes, match
    from morphogen.match import search as search_mod
    from morphogen.search.evaluate import Evaluator, Problem

    box = boxes.Box("gray-scott", boxes.BOXES["gray-scott"].genes, time=3000.0)
    monkeypatch.setitem(boxes.BOXES, "gray-scott", box)
    problem = Problem(model="gray-scott", genes=box.genes, size=(64, 64), dt=1.0, steps=3000,
                      init="blobs", seed=7)
    _, metrics = Evaluator(problem)(np.array([[0.035, 0.064]], np.float32),
                                    jax.random.PRNGKey(0))
    truth = signature(metrics["fields"][0], periodic=True)
    assert truth.family == "spots"
    picture = _rotate(np.tile(metrics["fields"][0], (3, 3)), 30.0)
    rgb = colormaps["viridis"]((picture - picture.min()) / np.ptp(picture))[..., :3]

    from morphogen.match import api

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:  # interrupted after the search: no answer yet
        patch.setattr(api, "answer", stop)
        with pytest.raises(KeyboardInterrupt):
            match(rgb, models=["gray-scott"], budget=12, out=tmp_path / "answer", top=2)
    assert not (tmp_path / "answer").exists()
    assert (tmp_path / ".answer.match-work").is_dir()

    def refuse(*args, **kwargs):
        raise AssertionError("a journaled population was simulated again")

    monkeypatch.setattr(search_mod.Scorer, "__call__", refuse)
    result = match(rgb, models=["gray-scott"], budget=12, out=tmp_path / "answer", top=2)
    best = result.best
    assert best.model == "gray-scott" and best.family == "spots"
    assert best.wavelength_px == pytest.approx(truth.wavelength, rel=0.1)
    files = {p.name for p in (tmp_path / "answer").iterdir()}
    assert {"run.json", "candidate_1.json", "sheet.png", "report.txt", "match.json"} <= files
    assert not (tmp_path / ".answer.match-work").exists()
