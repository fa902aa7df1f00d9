"""The one power spectrum, radial average and earth mover's distance (patterns/spectrum.py),
on fields whose answer is known by hand."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.patterns.spectrum import (
    power_spectrum,
    radial_spectrum,
    spectrum_distribution,
    wasserstein_1d,
)


def wave(h, w, ky, kx):
    """``cos 2π (ky y / h + kx x / w)``: all its power at ``±(ky, kx)``."""
    y, x = np.mgrid[0:h, 0:w]
    return np.cos(2 * np.pi * (ky * y / h + kx * x / w)).astype(np.float32)


def test_a_single_mode_has_its_power_at_its_wavevector_only():
    p = np.array(power_spectrum(jnp.asarray(wave(32, 32, 3, 5) + 7.0)))
    assert p[3, 5] == pytest.approx((32 * 32 / 2) ** 2, rel=1e-5)  # |N²/2|², the offset removed
    assert p[-3, -5] == pytest.approx(p[3, 5], rel=1e-6)
    p[3, 5] = p[-3, -5] = 0.0
    assert p.max() < 1e-6 * (32 * 32 / 2) ** 2


def test_the_ring_holds_the_wavelength_in_pixels_on_any_aspect_ratio():
    # 8 periods along 64 pixels (λ = 8 px) on a 64 x 128 field: ring N / λ = 8, N = 64
    s = np.asarray(radial_spectrum(jnp.asarray(wave(64, 128, 0, 16))))
    assert s.shape == (33,) and int(np.argmax(s)) == 8
    s = np.asarray(radial_spectrum(jnp.asarray(wave(64, 128, 8, 0))))
    assert int(np.argmax(s)) == 8


def test_the_distribution_peaks_at_the_wavenumber_and_sums_to_one():
    s = np.asarray(spectrum_distribution(jnp.asarray(wave(64, 64, 6, 8))))
    assert s.shape == (32,) and s.argmax() + 1 == 10  # |k| = sqrt(6² + 8²)
    assert s.sum() == pytest.approx(1.0, rel=1e-5)
    assert s[9] == pytest.approx(1.0, abs=1e-5)
    # offset and scale do not count
    t = np.asarray(spectrum_distribution(jnp.asarray(3.0 * wave(64, 64, 6, 8) - 2.0)))
    np.testing.assert_allclose(t, s, atol=1e-6)
    with pytest.raises(ValueError, match="bins"):
        spectrum_distribution(jnp.asarray(wave(64, 64, 6, 8)), bins=33)


def test_the_earth_movers_distance_by_hand_in_numpy_and_jax():
    p = np.array([1.0, 0.0, 0.0, 0.0])
    q = np.array([0.0, 0.0, 0.0, 1.0])
    assert wasserstein_1d(p, q) == 0.75  # all the mass moved 3 of 4 bins
    assert isinstance(wasserstein_1d(p, q), np.floating)
    r = np.array([0.5, 0.0, 0.0, 0.5])
    assert wasserstein_1d(p, r) == pytest.approx(0.375)
    assert float(wasserstein_1d(jnp.asarray(p), jnp.asarray(r))) == pytest.approx(0.375)
    assert wasserstein_1d(q, q) == 0.0
