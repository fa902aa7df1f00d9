"""Name a pattern's family from its descriptors (Richard et al. §5.2.2, fig. 9; Pearson).

The families are those of Richard et al.'s map and Pearson's classification, grouped:

``uniform``, ``spots``, ``stripes`` (stripes and labyrinths), ``holes`` (inverted spots),
``mixed`` (spots and stripes together), ``chaotic`` (moving, never settling), ``oscillating``
(the field comes back, or swings as a whole), ``blown-up``.

The rules, applied in order to the descriptors of :mod:`morphogen.patterns.descriptors` (the
thresholds are the module constants below; docs/patterns.md shows them at work on the
Gray-Scott presets):

1. ``blown-up``: the run was marked invalid, a value is not finite, or more than
   ``GRID_ENERGY`` of the power is at grid scale (a checkerboard is a numerical instability,
   not a pattern).
2. ``uniform``: ``range <= UNIFORM_RANGE * max(1, |max f|)``: nothing to see.
3. ``oscillating``: ``activity > ACTIVE`` and ``pulse > PULSE`` (the whole field swings
   together), ``recurrence < RECURRENT`` (the state comes back to an earlier one) or
   ``persistence > PERSISTENT`` (it changes in place: pulsating spots).
4. ``chaotic``: ``activity > ACTIVE`` otherwise (it keeps moving and does not come back).
5. Settled patterns by ``spot_index`` ``s`` (Euler characteristic per wavelength cell):
   ``spots`` if ``s >= SPOTS``, ``holes`` if ``s <= -SPOTS``, ``stripes`` if
   ``|s| <= STRIPES``, else ``mixed``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

FAMILIES = ("uniform", "spots", "stripes", "holes", "mixed", "chaotic", "oscillating",
            "blown-up")

# The colour of each family's frame on atlas tiles and elite maps.
COLOURS = {"uniform": "#9e9e9e", "spots": "#e6194b", "stripes": "#3cb44b", "holes": "#4363d8",
           "mixed": "#f58231", "chaotic": "#911eb4", "oscillating": "#42d4f4",
           "blown-up": "#000000"}

GRID_ENERGY = 0.5
UNIFORM_RANGE = 1e-3
ACTIVE = 0.01
PULSE = 0.5
RECURRENT = 0.1
PERSISTENT = 0.9
SPOTS = 0.4
STRIPES = 0.2


def classify(descriptors: Mapping[str, np.ndarray], valid: np.ndarray | None = None) -> np.ndarray:
    """Family names for a batch of descriptors (a dict of ``(B,)`` arrays) -> ``(B,)`` str.

    Args:
        valid: optional ``(B,)`` flags from the simulation (``False``: it blew up).
    """
    d = {k: np.asarray(v, np.float64) for k, v in descriptors.items()}
    size = d["range"].shape
    blown = (d["finite"] < 0.5) | (d["grid_energy"] > GRID_ENERGY)
    if valid is not None:
        blown |= ~np.asarray(valid, bool).reshape(size)
    uniform = d["range"] <= UNIFORM_RANGE * np.maximum(1.0, d["level"])
    active = d["activity"] > ACTIVE
    periodic = ((d["pulse"] > PULSE) | (d["recurrence"] < RECURRENT)
                | (d["persistence"] > PERSISTENT))
    s = d["spot_index"]
    settled = np.where(s >= SPOTS, "spots",
                       np.where(s <= -SPOTS, "holes",
                                np.where(np.abs(s) <= STRIPES, "stripes", "mixed")))
    moving = np.where(periodic, "oscillating", "chaotic")
    out = np.where(active, moving, settled)
    out = np.where(uniform, "uniform", out)
    return np.where(blown, "blown-up", out).astype(object)
