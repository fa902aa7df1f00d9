"""The dispersion relation as a picture: growth rate against wavenumber for each fixed point.

For each homogeneous fixed point ``u*`` the continuous curve ``σ(q) = max Re eig(J - q² D)``
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

    fig, ax = plt.subplots(figsize=(7.0, 4.4), dpi=dpi)
    k = np.asarray(grid_q, np.float64)
    order = np.argsort(k, kind="stable")
    for i, label in enumerate(labels):
        colour = COLOURS[i % len(COLOURS)]
        ax.plot(q, sigma[i], color=colour, lw=1.6, label=label)
        ax.plot(k[order], grid_sigma[i][order], ".", color=colour, ms=3.0, alpha=0.6)
        if bands[i] is not None:
            ax.axvspan(*bands[i], color=colour, alpha=0.10, lw=0)
        if fastest[i] is not None:
            kf, sf, wl = fastest[i]  # kf: the mode's 2π / λ
            ax.plot([kf], [sf], "o", mfc="none", mec=colour, ms=9, mew=1.5)
            ax.annotate(f"λ = {wl:.3g}", (kf, sf), textcoords="offset points", xytext=(8, 6),
                        color=colour, fontsize=9)
    ax.axhline(0.0, color="0.3", lw=0.8)
    low = min(float(np.nanmin(sigma)), float(np.nanmin(grid_sigma)))
    high = max(float(np.nanmax(sigma)), float(np.nanmax(grid_sigma)))
    # the interesting part is near σ = 0: all of the growth, and decay down to 1.5 times it
    bottom = max(low, -1.5 * abs(high)) if high > 0 else low
    pad = 0.08 * (max(high, 0.0) - bottom or 1.0)
    ax.set_ylim(bottom - pad, max(high, 0.0) + pad)
    ax.set_xlim(0.0, float(q[-1]))
    ax.set_xlabel("wavenumber q (1 / length)")
    ax.set_ylabel("growth rate σ = max Re λ (1 / time)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="lower left", title="line: continuous q, dots: grid modes",
              title_fontsize=8)
    ax.grid(alpha=0.25)
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return Path(path)
