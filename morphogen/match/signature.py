"""A pattern's signature and the distance between two: what ``match`` compares.

The signature of a field is built from the simulator's own descriptors
(:func:`morphogen.patterns.descriptors.describe` and
:func:`~morphogen.patterns.spectrum.radial_spectrum`; families by
:func:`morphogen.patterns.classify.classify`), after a normalisation applied alike
to a picture and to a simulated species, so that what a picture does not fix does not count:

1. **contrast and colour**: values are clipped to their 1st and 99th percentiles and rescaled to
   ``[0, 1]`` (an affine change of the grey levels, or a few saturated pixels, change nothing);
2. **resolution**: the wavelength ``λ`` is the power-weighted mean wavenumber of the radially
   averaged power spectrum over the rings ``[r*/√2, r*√2]`` around its peak ``r*``
   (``λ = N / r̄``, finer than the peak ring alone); every other part of the signature is in
   units of ``λ`` (scale-free), and ``λ`` itself is matched by fitting the grid spacing;
3. **blur, noise, JPEG**: the field is smoothed by a Gaussian of width ``λ / 8`` before it is
   thresholded (Euler characteristic) or its gradients are taken, which removes pixel noise and
   leaves the pattern; the levels are then mapped piecewise linearly so that the descriptors'
   mid-level threshold falls at Otsu's threshold (the level that best splits the values in two),
   which a monotone change of the grey levels (a gamma) barely moves;
4. **borders**: a picture is not periodic, so it is mirrored into a ``2H x 2W`` torus before the
   spectrum and the topology are measured (the descriptors assume a torus);
5. **rotation**: every part is rotation invariant (ring averages, structure-tensor coherence,
   Euler characteristic, histograms); the global ``orientation`` and ``order`` are not used.

6. **mask** (a flattened mesh covers part of its pixels): only the pixels inside count. The
   field is centred on its mean inside and set to 0 outside, and zero-padded to ``2H x 2W``
   (instead of mirrored) before its spectrum is taken; it is smoothed by normalised convolution
   (``G*(m f) / G*m``, ``m`` the mask); the Euler characteristic is counted over the 2x2
   windows that lie wholly inside (its density, so a stripe cut by the outline does not count as
   a component), the coherence over the pixels whose neighbours are inside, the share above
   threshold and the histogram over the pixels inside.

A signature holds the family (``spots``, ``stripes``, ``holes``, ``mixed``, or ``uniform`` /
``blown-up``), the ``spot_index`` (Euler characteristic per wavelength cell), the local
``coherence``, the share ``covered`` above mid-level, the spectrum profile ``log P(x r̄)/P(r̄)``
at 16 ratios ``x`` in ``[0.35, 2.8]`` and a 16-bin intensity histogram. :func:`distance` weighs
them (:data:`WEIGHTS`); a family mismatch alone costs 1, so families come first.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.patterns.classify import classify

RATIOS = np.geomspace(0.35, 2.8, 16)
"""Wavenumber ratios ``k / k̄`` at which the spectrum profile is read."""

HIST_BINS = 16

WEIGHTS = {"family": 1.0, "spot_index": 0.6, "coherence": 1.0, "covered": 1.0,
           "histogram": 2.0, "profile": 0.15}
"""Weights of the distance's terms (each term is in about ``[0, 1]``)."""

SETTLED = ("spots", "stripes", "holes", "mixed")
"""The families a still picture can show (motion is not visible in one picture)."""


@dataclass(frozen=True)
class Signature:
    """What a pattern looks like, scale-free except ``wavelength`` (pixels or cells)."""

    family: str
    wavelength: float
    spot_index: float
    coherence: float
    covered: float
    profile: np.ndarray
    histogram: np.ndarray

    def to_dict(self) -> dict:
        return {"family": self.family, "wavelength": round(self.wavelength, 3),
                "spot_index": round(self.spot_index, 3), "coherence": round(self.coherence, 3),
                "covered": round(self.covered, 3)}


def normalise(f: np.ndarray) -> np.ndarray:
    """Clip ``f`` to its 1st-99th percentiles and rescale to ``[0, 1]`` (float32)."""
    f = np.where(np.isfinite(f), f, 0.0).astype(np.float64)
    lo, hi = np.percentile(f, [1.0, 99.0])
    if hi - lo <= 1e-9 * max(1.0, abs(hi)):
        lo, hi = float(f.min()), float(f.max())
    return np.clip((f - lo) / max(hi - lo, 1e-12), 0.0, 1.0).astype(np.float32)


def spectrum(f: np.ndarray) -> np.ndarray:
    """Radially averaged power spectrum ``P(r)`` of a periodic field (the descriptors' own)."""
    from morphogen.patterns.spectrum import radial_spectrum

    return np.asarray(_jit(radial_spectrum)(np.asarray(f, np.float32)), np.float64)


def wavelength(power: np.ndarray, n: int, min_ring: int = 2) -> float:
    """``N / r̄``: ``r̄`` the power-weighted mean ring over ``[r*/√2, r*√2]`` (module doc)."""
    p = np.array(power, np.float64)
    p[:min_ring] = 0.0
    if not np.any(p > 0):
        return float(n)
    peak = int(np.argmax(p))
    r = np.arange(len(p))
    band = (r >= peak / np.sqrt(2.0)) & (r <= peak * np.sqrt(2.0)) & (r >= min_ring)
    mean = float(np.sum(r[band] * p[band]) / max(np.sum(p[band]), 1e-30))
    return float(n / max(mean, 1e-9))


def otsu(f: np.ndarray, bins: int = 64) -> float:
    """Otsu's threshold of values in ``[0, 1]``: the level that best splits them in two."""
    hist, edges = np.histogram(f, bins=bins, range=(0.0, 1.0))
    p = hist / max(hist.sum(), 1)
    centres = 0.5 * (edges[1:] + edges[:-1])
    w0 = np.cumsum(p)
    m0 = np.cumsum(p * centres)
    between = (m0[-1] * w0 - m0) ** 2 / np.maximum(w0 * (1.0 - w0), 1e-12)
    return float(edges[1:][int(np.argmax(between[:-1]))])


def split_at(f: np.ndarray, t: float) -> np.ndarray:
    """Map ``[0, t]`` to ``[0, 1/2]`` and ``[t, 1]`` to ``[1/2, 1]`` (piecewise linear), so that
    the descriptors' mid-level threshold falls at ``t``."""
    t = float(np.clip(t, 0.05, 0.95))
    return np.where(f < t, 0.5 * f / t, 0.5 + 0.5 * (f - t) / (1.0 - t)).astype(np.float32)


def mirror(f: np.ndarray) -> np.ndarray:
    """A non-periodic ``(H, W)`` field mirrored into a seamless ``(2H, 2W)`` torus."""
    top = np.concatenate([f, f[:, ::-1]], axis=1)
    return np.concatenate([top, top[::-1]], axis=0)


def signature(f: np.ndarray, *, periodic: bool, invert: bool = False,
              mask: np.ndarray | None = None) -> Signature:
    """The signature of one field ``(H, W)`` (a simulated species: ``periodic=True``; a
    picture: ``False``); ``invert`` reads ``1 - f`` (the other polarity); ``mask`` ``(H, W)``
    bool limits it to the pixels inside (a picture only; module docstring, item 6)."""
    from scipy.ndimage import gaussian_filter

    if mask is not None:
        return _masked_signature(f, np.asarray(mask, bool), invert)

    g = normalise(f)
    if invert:
        g = 1.0 - g
    torus = g if periodic else mirror(g)
    n = min(torus.shape)
    lam = wavelength(spectrum(torus), n, min_ring=2 if periodic else 3)
    smooth = normalise(gaussian_filter(torus, lam / 8.0, mode="wrap"))
    smooth = split_at(smooth, otsu(smooth))
    d = {k: float(v) for k, v in _describe(smooth).items()}
    cells = smooth.size / lam**2
    return Signature(family=_family(d), wavelength=lam,
                     spot_index=float(np.clip(d["euler"] / max(cells, 1e-9), -1.5, 1.5)),
                     coherence=d["coherence"], covered=d["covered"],
                     profile=_profile(spectrum(smooth), n, lam), histogram=_histogram(smooth))


def _family(d: dict[str, float]) -> str:
    """The family of one still field from its descriptors ``d`` (nothing moves in it)."""
    d = {**d, "activity": 0.0, "pulse": 0.0, "recurrence": 1.0, "persistence": 0.0}
    return str(classify({k: np.array([v]) for k, v in d.items()})[0])


def _profile(power: np.ndarray, n: int, lam: float) -> np.ndarray:
    """``log10 P(x r̄) / P(r̄)`` at :data:`RATIOS` ``x`` of the mean ring ``r̄ = n / λ``."""
    rings = np.arange(len(power))
    r_mean = n / lam
    prof = np.interp(RATIOS * r_mean, rings, power, right=0.0)
    top = max(float(np.interp(r_mean, rings, power)), 1e-30)
    return np.log10(np.maximum(prof / top, 1e-4))


def _histogram(values: np.ndarray) -> np.ndarray:
    """The share of ``values`` in each of :data:`HIST_BINS` bins of ``[0, 1]``."""
    hist = np.histogram(values, bins=HIST_BINS, range=(0.0, 1.0))[0].astype(np.float64)
    return hist / max(hist.sum(), 1.0)


def _masked_signature(f: np.ndarray, m: np.ndarray, invert: bool) -> Signature:
    """:func:`signature` of the pixels of ``f`` inside ``m`` (module docstring, item 6)."""
    from scipy.ndimage import binary_erosion, gaussian_filter

    if f.shape != m.shape or m.sum() < 16:
        raise MorphogenError(f"a mask {m.shape} with at least 16 pixels inside must cover the "
                         f"field {f.shape}")
    g = np.where(m, f, np.median(f[m]))
    lo, hi = np.percentile(g[m], [1.0, 99.0])
    if hi - lo <= 1e-9 * max(1.0, abs(hi)):
        lo, hi = float(g[m].min()), float(g[m].max())
    g = np.clip((g - lo) / max(hi - lo, 1e-12), 0.0, 1.0)
    g = 1.0 - g if invert else g
    h, w = g.shape

    def padded(a: np.ndarray) -> np.ndarray:
        centred = np.where(m, a - a[m].mean(), 0.0)
        return np.pad(centred, ((0, h), (0, w))).astype(np.float32)

    n = min(2 * h, 2 * w)
    lam = wavelength(spectrum(padded(g)), n, min_ring=3)
    weight = gaussian_filter(m.astype(np.float64), lam / 8.0, mode="constant")
    smooth = gaussian_filter(np.where(m, g, 0.0), lam / 8.0, mode="constant")
    smooth = np.where(m, smooth / np.maximum(weight, 1e-12), 0.0)
    inside = smooth[m]
    lo, hi = np.percentile(inside, [1.0, 99.0])
    smooth = np.clip((smooth - lo) / max(hi - lo, 1e-12), 0.0, 1.0)
    smooth = np.where(m, split_at(smooth, otsu(smooth[m])), 0.0)
    fg = smooth > 0.5
    corner, right, below, across = fg[:-1, :-1], fg[:-1, 1:], fg[1:, :-1], fg[1:, 1:]
    whole = m[:-1, :-1] & m[:-1, 1:] & m[1:, :-1] & m[1:, 1:]
    ones = corner.astype(int) + right + below + across
    chi = (np.sum((ones == 1) & whole) - np.sum((ones == 3) & whole)
           + 2 * np.sum((ones == 2) & (corner == across) & whole)) / 4.0
    spot_index = chi / max(whole.sum() / lam**2, 1e-9)
    coherence = _masked_coherence(smooth, binary_erosion(m), lam / 2.0)
    centred = padded(smooth)
    power = spectrum(centred)
    freq = np.maximum(*np.meshgrid(np.abs(np.fft.fftfreq(2 * w)), np.abs(np.fft.fftfreq(2 * h))))
    full = np.abs(np.fft.fft2(centred)) ** 2
    d = {"level": float(np.max(np.abs(smooth[m]))), "range": float(np.ptp(smooth[m])),
         "finite": 1.0, "spot_index": float(spot_index),
         "grid_energy": float(full[freq >= 0.375].sum() / max(full.sum(), 1e-30))}
    return Signature(family=_family(d), wavelength=lam,
                     spot_index=float(np.clip(spot_index, -1.5, 1.5)),
                     coherence=coherence, covered=float(np.mean(fg[m])),
                     profile=_profile(power, n, lam), histogram=_histogram(smooth[m]))


def _masked_coherence(f: np.ndarray, m: np.ndarray, sigma: float) -> float:
    """The descriptors' local coherence (structure tensor smoothed over ``sigma``, weighted by
    its trace) from the central differences at the pixels ``m`` (whose neighbours are inside)."""
    from scipy.ndimage import gaussian_filter

    gy, gx = np.gradient(f)
    parts = [gaussian_filter(np.where(m, p, 0.0), sigma, mode="constant")
             for p in (gx * gx, gy * gy, gx * gy)]
    sxx, syy, sxy = (p[m] for p in parts)
    trace = sxx + syy
    coh = np.sqrt((sxx - syy) ** 2 + 4.0 * sxy**2) / np.maximum(trace, 1e-12)
    return float(np.sum(coh * trace) / max(trace.sum(), 1e-12))


def distance(a: Signature, b: Signature) -> float:
    """Weighted distance of two signatures (wavelength excluded: the grid spacing fits it).

    ``family`` is 1 when the families differ, ``histogram`` the earth mover's distance of the
    intensity histograms (:func:`morphogen.patterns.spectrum.wasserstein_1d`),
    ``profile`` the mean absolute difference of the log spectrum profiles (in decades).
    """
    from morphogen.patterns.spectrum import wasserstein_1d
    terms = {
        "family": float(a.family != b.family),
        "spot_index": abs(a.spot_index - b.spot_index),
        "coherence": abs(a.coherence - b.coherence),
        "covered": abs(a.covered - b.covered),
        "histogram": float(wasserstein_1d(a.histogram, b.histogram)),
        "profile": float(np.mean(np.abs(a.profile - b.profile))),
    }
    return float(sum(WEIGHTS[k] * v for k, v in terms.items()))


@lru_cache(maxsize=8)
def _jit(fn):  # noqa: ANN001, ANN202 (a jitted descriptor function, one per function)
    import jax

    return jax.jit(fn)


def _describe(f: np.ndarray) -> dict:
    from morphogen.patterns.descriptors import describe

    return _jit(describe)(np.asarray(f, np.float32))
