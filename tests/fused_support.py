"""What the tests of the fused CPU step share (:mod:`morphogen.solvers.fused`)."""

from __future__ import annotations

import importlib.util

import pytest


def _numba_here() -> bool:
    if importlib.util.find_spec("numba") is None:
        return False
    from morphogen.solvers.fused_jit import SUPPORTED

    return SUPPORTED


needs_numba = pytest.mark.skipif(not _numba_here(),
                                 reason="the fused step needs Numba on an x86-64 CPU")
"""Skips a test where the fused step cannot run (no Numba, or not an x86-64 CPU)."""
