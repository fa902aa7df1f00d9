"""morphogen: reaction-diffusion pattern formation, simulated, searched and shown on one JAX engine.

The names below are the public API::

    import morphogen as mg

    model = mg.load_model("gray-scott")            # a library name, or a .toml/.ant/.npz file
    grid = mg.Grid((256, 256))
    params = model.parameters(preset="mazes")
    u0 = mg.make_initial("blobs", model, grid, params, seed=1)
    sol = mg.simulate(model, grid, u0, params, steps=8000, dt=1.0)

Each name is imported from its module on first use (PEP 562), so ``import morphogen`` loads
neither JAX nor anything else heavy; the modules themselves never import from this one.
"""

from __future__ import annotations

import importlib
from typing import Any

_HOMES: dict[str, str] = {
    # models and domains
    "Model": "morphogen.models.model",
    "load_model": "morphogen.models.registry",
    "parse_model": "morphogen.models.text.equations",
    "Grid": "morphogen.domains.grid",
    "Mesh": "morphogen.domains.mesh",
    "load_mesh": "morphogen.domains.ply",
    "save_ply": "morphogen.domains.ply",
    # time stepping and the time loop
    "make_step": "morphogen.solvers.step",
    "max_stable_dt": "morphogen.solvers.step",
    "Noise": "morphogen.solvers.step",
    "Stepper": "morphogen.solvers.base",
    "Advance": "morphogen.solvers.base",
    "make_rhs": "morphogen.solvers.base",
    "make_initial": "morphogen.engine.initial",
    "simulate": "morphogen.engine.simulate",
    "simulate_batch": "morphogen.engine.simulate",
    "integrate": "morphogen.engine.simulate",
    "Solution": "morphogen.engine.simulate",
    "stack_params": "morphogen.engine.batch",
    "stack_states": "morphogen.engine.batch",
    # search
    "optimise": "morphogen.search.api",
    "Gene": "morphogen.search.genes",
    # a run as data (run.json)
    "RunConfig": "morphogen.runs.config",
    "load_run_file": "morphogen.runs.config",
    "execute": "morphogen.runs.execute",
    # linear stability (morphogen analyse)
    "analyse": "morphogen.runs.analysis",
    "Analysis": "morphogen.runs.analysis",
    # errors
    "MorphogenError": "morphogen.errors",
    "BlowUpError": "morphogen.errors",
}
"""Each public name and the module that defines it."""

__all__ = list(_HOMES)

def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use, and keep it here."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'morphogen' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names."""
    return sorted(__all__)
