"""Pattern descriptors on synthetic fields with known answers, and the classifier's rules."""

import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.patterns.classify import classify
from morphogen.patterns.descriptors import (
    describe,
    describe_batch,
    describe_dynamics,
    euler_characteristic,
)

N = 128
Y, X = np.mgrid[0:N, 0:N].astype(np.float32)
# Three wave vectors (8, 0), (-4, 7), (-4, -7) cycles per box: a (nearly) hexagonal lattice
# whose maxima form the lattice spanned by them, det = 8 * 7 = 56 spots on the torus.
HEX = sum(np.cos(2 * np.pi * (a * X + b * Y) / N) for a, b in ((8, 0), (-4, 7), (-4, -7)))


def _describe(f):
    return {k: float(v) for k, v in describe(jnp.asarray(f, jnp.float32)).items()}


@pytest.mark.slow
def test_sine_grating_wavelength_and_orientation():
    d = _describe(np.sin(2 * np.pi * X / 16))
    assert d["wavelength"] == 16.0
    assert d["peak_share"] == pytest.approx(1.0, abs=1e-5)
    assert d["orientation"] == pytest.approx(0.0, abs=1e-5)
    assert d["order"] == pytest.approx(1.0, abs=1e-5)
    assert d["coherence"] == pytest.approx(1.0, abs=1e-4)
    assert d["euler"] == 0.0 and d["covered"] == pytest.approx(0.5, abs=0.01)
    assert d["range"] == pytest.approx(2.0, abs=1e-5)
    assert d["contrast"] == pytest.approx(1 / np.sqrt(2), abs=1e-5)


def test_oblique_grating():
    # wave vector (8, 4) cycles: |q| N = sqrt(80) = 8.94 -> ring 9, angle atan(1/2)
    d = _describe(np.sin(2 * np.pi * (8 * X + 4 * Y) / N))
    assert d["wavelength"] == pytest.approx(N / 9, rel=1e-5)
    assert d["orientation"] == pytest.approx(np.arctan2(4, 8), abs=0.01)
    assert d["order"] == pytest.approx(1.0, abs=1e-4)


def test_hexagonal_spots_and_their_inverse():
    spots = _describe(HEX)
    assert spots["euler"] == 56.0
    assert spots["wavelength"] == 16.0
    assert spots["spot_index"] == pytest.approx(56 * 16**2 / N**2)
    assert spots["coherence"] < 0.05 and spots["order"] < 0.05
    holes = _describe(-HEX)
    assert holes["euler"] == -56.0
    assert holes["covered"] == pytest.approx(1 - spots["covered"])


def test_euler_characteristic_of_small_shapes():
    mask = np.zeros((12, 12), bool)
    mask[2:5, 2:5] = True  # a square: 1
    mask[7:11, 6:11] = True
    mask[8:10, 8] = False  # a ring: 1 - 1 = 0
    mask[1, 9] = True  # a pixel: 1
    assert float(euler_characteristic(jnp.asarray(mask))) == 2.0
    diagonal = np.zeros((6, 6), bool)
    diagonal[1, 1] = diagonal[2, 2] = True  # 4-connectivity: two components
    assert float(euler_characteristic(jnp.asarray(diagonal))) == 2.0


def test_uniform_and_checkerboard():
    flat = _describe(np.full((N, N), 0.3))
    assert flat["range"] == 0.0 and flat["contrast"] == 0.0 and flat["grid_energy"] == 0.0
    board = _describe((-1.0) ** (X + Y))
    assert board["grid_energy"] == pytest.approx(1.0)
    smooth = _describe(np.sin(2 * np.pi * X / 16))
    assert smooth["grid_energy"] < 1e-6


def test_dynamics_static_travelling_and_pulsing():
    still = np.stack([np.sin(2 * np.pi * X / 16)] * 5)
    d = {k: float(v) for k, v in describe_dynamics(jnp.asarray(still)).items()}
    assert d["activity"] == 0.0 and d["pulse"] == 0.0
    # a grating moving 4 pixels per snapshot: each step changes it; after 16 px it returns
    moving = np.stack([np.sin(2 * np.pi * (X - 4 * t) / 16) for t in range(5)])
    d = {k: float(v) for k, v in describe_dynamics(jnp.asarray(moving)).items()}
    mean_step = np.mean(np.abs(np.diff(moving, axis=0)))
    assert d["activity"] == pytest.approx(mean_step / 2.0, rel=1e-4)
    assert d["recurrence"] == pytest.approx(0.0, abs=1e-5)
    assert d["persistence"] == pytest.approx(1.0, abs=1e-4)
    # the whole field swinging: mean 0, ±1 around a fixed pattern
    base = 0.1 * np.sin(2 * np.pi * X / 16)
    pulsing = np.stack([base + (-1.0) ** t for t in range(5)])
    d = {k: float(v) for k, v in describe_dynamics(jnp.asarray(pulsing)).items()}
    assert d["pulse"] > 5.0


@pytest.mark.slow
def test_batch_matches_single_and_classifies_synthetic_fields():
    still = lambda f: np.stack([f] * 3)  # noqa: E731
    fields = [HEX, -HEX, np.sin(2 * np.pi * X / 16), np.full((N, N), 0.3), (-1.0) ** (X + Y),
              np.where(X < 32, (HEX + 1.5) / 2.25 - 1, np.sin(2 * np.pi * X / 16))]
    batch = np.stack([still(f) for f in fields]).astype(np.float32)
    d = describe_batch(batch)
    single = describe(jnp.asarray(batch[1, -1]))
    for k, v in single.items():
        np.testing.assert_allclose(d[k][1], v, rtol=1e-5, atol=1e-6)
    assert 0.2 < d["spot_index"][5] < 0.4  # a quarter of spots beside stripes
    labels = classify(d)
    assert list(labels) == ["spots", "holes", "stripes", "uniform", "blown-up", "mixed"]
    assert list(classify(d, valid=np.array([True, False, True, True, True, True])))[1] \
        == "blown-up"


@pytest.mark.slow
def test_classifier_moving_patterns():
    moving = np.stack([np.sin(2 * np.pi * (X - 4 * t) / 16) for t in range(5)])
    noise = np.random.default_rng(0).random((5, N, N))
    labels = classify(describe_batch(np.stack([moving, noise]).astype(np.float32)))
    assert list(labels) == ["oscillating", "chaotic"]
