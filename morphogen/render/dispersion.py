"""The dispersion relation as a picture: growth rate against wavenumber for each fixed point.

One panel per homogeneous fixed point ``u*``: the continuous curve ``σ(q) = max Re eig(J - q² D)``
(Murray, Mathematical Biology II, ch. 2.3) is drawn as a line and the grid's own modes
(``σ`` at the stencil's ``κ²``, plotted at the mode's true wavenumber ``2π / λ``: where the
discrete symbol departs from ``q²`` the dots leave the line) as dots; the unstable band is
shaded, the fastest-growing grid mode marked and labelled with its wavelength. Matplotlib with
the Agg backend (no display needed), written atomically.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from morphogen.util.io import atomic_path

COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")


def dispersion_png(path: str | Path, q: np.ndarray, sigma: np.ndarray, grid_q: np.ndarray,
                   grid_sigma: np.ndarray, labels: Sequence[str],
                   fastest: Sequence[tuple[float, float, float] | None],
                   bands: Sequence[tuple[float, float] | None], *, title: str = "",
                   dpi: int = 110) -> Path:
    """Write the picture.

    Args:
        q: continuous wavenumbers ``(Q,)`` (1/length).
        sigma: ``σ(q)`` per fixed point, ``(F, Q)``.
        grid_q, grid_sigma: the grid modes' wavenumbers ``2π / λ`` ``(K,)`` and ``σ`` per fixed
            point ``(F, K)``.
        labels: one legend entry per fixed point.
        fastest: per fixed point ``(κ, σ, wavelength)`` of the fastest unstable grid mode, or
            ``None``.
        bands: per fixed point the unstable band ``(κ_lo, κ_hi)`` to shade, or ``None``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = len(labels)
    fig, axes = plt.subplots(count, 1, figsize=(7.0, 1.2 + 2.6 * count), dpi=dpi, sharex=True,
                             squeeze=False)
    k = np.asarray(grid_q, np.float64)
    order = np.argsort(k, kind="stable")
    right = 0.0
    for i, (ax, label) in enumerate(zip(axes[:, 0], labels, strict=True)):
        colour = COLOURS[i % len(COLOURS)]
        ax.plot(q, sigma[i], color=colour, lw=1.6, label="continuous q")
        ax.plot(k[order], grid_sigma[i][order], ".", color=colour, ms=3.0, alpha=0.6,
                label="grid modes")
        if bands[i] is not None:
            ax.axvspan(*bands[i], color=colour, alpha=0.10, lw=0, label="unstable band")
        if fastest[i] is not None:
            kf, sf, wl = fastest[i]  # kf: the mode's 2π / λ
            ax.plot([kf], [sf], "o", mfc="none", mec=colour, ms=9, mew=1.5)
            ax.annotate(f"fastest: λ = {wl:.3g}", (kf, sf), textcoords="offset points",
                        xytext=(8, 6), color=colour, fontsize=9)
        ax.axhline(0.0, color="0.3", lw=0.8)
        bottom, top = _limits(sigma[i], grid_sigma[i])
        ax.set_ylim(bottom, top)
        seen = q[sigma[i] >= bottom]
        right = max(right, float(seen.max()) if seen.size else float(q[-1]))
        ax.set_title(label, fontsize=9, loc="left")
        ax.set_ylabel("σ = max Re λ (1/time)", fontsize=9)
        ax.grid(alpha=0.25)
        ax.legend(fontsize=8, loc="lower left")
    axes[-1, 0].set_xlim(0.0, min(float(q[-1]), 1.15 * right) or float(q[-1]))
    axes[-1, 0].set_xlabel("wavenumber q (1 / length)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return Path(path)


def _limits(sigma: np.ndarray, grid_sigma: np.ndarray) -> tuple[float, float]:
    """The interesting part is near ``σ = 0``: all of the growth and decay down to 1.5 times
    it; a curve that only decays is shown from its top down to twice its depth."""
    low = min(float(np.nanmin(sigma)), float(np.nanmin(grid_sigma)))
    high = max(float(np.nanmax(sigma)), float(np.nanmax(grid_sigma)))
    if high > 0:
        bottom, top = max(low, -1.5 * high), high
    else:
        bottom, top = max(low, 2.0 * high), 0.0
    span = (top - bottom) or 1.0
    return bottom - 0.06 * span, top + 0.2 * span
