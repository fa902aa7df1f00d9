"""Small models built directly from the core API, shared by the core tests."""

from __future__ import annotations

import jax.numpy as jnp

from morphogen.models.model import Model


def pure_diffusion(n_species: int = 1, d: float = 1.0) -> Model:
    """``du/dt = D lap(u)`` for ``n_species`` independent species."""
    names = tuple(f"s{i}" for i in range(n_species))
    return Model(
        name="diffusion",
        species=names,
        params={"D": d},
        reaction=lambda u, p, c: jnp.zeros_like(u),
        diffusion=lambda p, c: tuple(p["D"] for _ in names),
        ground=lambda p: tuple(0.0 for _ in names),
    )

