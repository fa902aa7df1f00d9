"""Resolve a :class:`~morphogen.runs.config.RunConfig` into a model, a domain, parameters, an
initial state, a scheme, ``dt`` and a step count (the one run policy,
:func:`morphogen.runs.policy.resolve_run`), checking every setting and the run's cost before
anything is written."""

from __future__ import annotations

import math
from contextlib import AbstractContextManager
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.fields import resolve_params
from morphogen.engine.initial import make_initial
from morphogen.errors import MorphogenError
from morphogen.models.model import Model, Tensor
from morphogen.runs.config import SNAPSHOTS, RunConfig
from morphogen.runs.policy import resolve_run
from morphogen.runs.schema import validate_config
from morphogen.util import guard


@dataclass
class Prepared:
    """A config resolved into objects, ready to run; ``scheme`` is the config's with ``auto``
    resolved, ``reason`` the policy's word on ``dt``."""

    config: RunConfig
    model: Model
    domain: Any
    params: dict[str, np.ndarray]
    u0: np.ndarray
    dt: float
    steps: int
    scheme: str = "euler"
    reason: str = "given"


def load_config_model(config: RunConfig) -> Model:
    """The model of a config: from the embedded file text when present, else by name/path."""
    from morphogen.models.registry import load_model
    from morphogen.models.text.equations import parse_model

    if config.model_source is not None:
        return parse_model(config.model_source, path=config.model)
    return load_model(config.model)


def build_domain(config: RunConfig, model: Model) -> Any:
    """A :class:`Grid` from ``size``/``dx``/``boundary``/``stencil``, or a mesh from ``mesh``."""
    if config.mesh:
        from morphogen.domains.ply import load_mesh

        mesh_args = {} if config.boundary == "periodic" else {"boundary": config.boundary}
        return load_mesh(config.mesh, **mesh_args)
    grid = Grid(tuple(config.size), dx=config.dx, boundary=config.boundary,
                stencil=config.stencil)
    grid.boundaries(model.species)
    return grid


def prepare(config: RunConfig) -> Prepared:
    """Validate and resolve everything before any output is written: the settings against
    :class:`~morphogen.runs.schema.RunSchema`, then the run's cost against
    :mod:`morphogen.util.guard` (memory before the domain is built, steps once ``dt`` is known).
    Call it, and run what it prepares, inside ``with precision(config.precision)``."""
    validate_config(asdict(config), "run settings")
    model = load_config_model(config)
    itemsize = 8 if config.precision == "float64" else 4
    if not config.mesh:
        guard.check_memory(math.prod(config.size), len(model.species), itemsize=itemsize)
    domain = build_domain(config, model)
    cells = math.prod(domain.spatial_shape)
    snapshots = SNAPSHOTS if config.every else 1
    guard.check_memory(cells, len(model.species), snapshots=snapshots, itemsize=itemsize)
    values = model.parameters(config.params, preset=config.preset)
    params = resolve_params(model, domain, values)
    check_diffusion(model, domain, params)
    u0 = make_initial(config.init or model.init, model, domain, params, seed=config.seed,
                      **config.init_options)
    if config.mesh:
        u0, params = _mesh_fields(config, model, domain, u0, params)
    plan = resolve_run(model, domain, params, scheme=config.scheme, dt=config.dt,
                       steps=config.steps, t_end=config.time, unsafe=config.unsafe,
                       rtol=config.rtol, atol=config.atol)
    steps = guard.check_steps(plan.steps, cells, len(model.species))
    if config.species is not None:
        model.species_index(config.species)
    return Prepared(config, model, domain, params, u0, plan.dt, steps, plan.scheme, plan.reason)


def check_diffusion(model: Model, domain: Any, params: dict[str, np.ndarray]) -> None:
    """Refuse a negative diffusion coefficient (or a tensor that is not positive
    semi-definite, ``xx, yy >= 0`` and ``xx·yy >= xy²``) at ``t = 0``: ``u_t = -|D| Δu`` is
    backward diffusion, ill-posed, and grows the finest grid modes without bound."""
    import jax.numpy as jnp

    coords = {**{k: jnp.asarray(v) for k, v in domain.coords.items()}, "t": jnp.asarray(0.0)}
    coefficients = model.diffusion({k: jnp.asarray(v) for k, v in params.items()}, coords)
    for s, d in zip(model.species, coefficients, strict=True):
        if isinstance(d, Tensor):
            xx, xy, yy = (np.asarray(c, np.float64) for c in d)
            det = xx * yy - xy**2 + 1e-6 * (xx + yy) ** 2
            worst = float(np.min(np.minimum(np.minimum(xx, yy), det)))
        else:
            worst = float(np.min(np.asarray(d, np.float64)))
        if not worst >= 0:
            raise MorphogenError(
                f"species {s} has a negative or undefined diffusion coefficient ({worst:g}): "
                "backward diffusion is ill-posed; use coefficients >= 0"
            )


def _mesh_fields(config: RunConfig, model: Model, mesh: Any, u0: np.ndarray,
                 values: dict[str, Any]) -> tuple[np.ndarray, dict[str, Any]]:
    """PLY vertex properties named like a species give its initial value, those named like a
    parameter its per-vertex values, only when asked for (``--mesh-field NAME``, or ``all``):
    a mesh's radius field ``r`` must not silently become a model's rate ``r``. A field named
    like one that is neither asked for, nor overridden (``-p NAME=...``, ``--init``), nor
    ignored (``--mesh-field none``) is a one-line error naming both and the options."""
    from morphogen.domains.ply import apply_fields, field_clashes

    chosen = set(config.mesh_fields)
    clashes = field_clashes(model, mesh)
    unknown = sorted(chosen - {"all", "none"} - set(clashes))
    if unknown:
        named = ", ".join(clashes) or "none"
        raise MorphogenError(
            f"--mesh-field {unknown[0]}: mesh {config.mesh} has no field {unknown[0]!r} named "
            f"like a species or parameter of model {model.name} (such fields: {named})"
        )
    if {"all", "none"} <= chosen:
        raise MorphogenError("--mesh-field all and --mesh-field none contradict each other")
    use = set(clashes) if "all" in chosen else chosen & set(clashes)
    overridden = set(config.params) | (set(model.species) if config.init is not None else set())
    pending = [n for n in clashes if n not in use | overridden]
    if pending and "none" not in chosen:
        name = pending[0]
        species = name in model.species
        role, other = (("species", "--init KIND") if species
                       else ("parameter", f"-p {name}=VALUE"))
        raise MorphogenError(
            f"mesh {config.mesh} has a field {name!r} and model {model.name} a {role} "
            f"{name!r}: add --mesh-field {name} to use the field as the {role}'s "
            f"{'start' if species else 'values'}, or --mesh-field none (or {other}) to ignore it"
        )
    mesh_u0, mesh_values = apply_fields(model, mesh, u0, values, names=use)
    mesh_values.update({k: values[k] for k in config.params})
    return (u0 if config.init is not None else mesh_u0), mesh_values


def precision(name: str) -> AbstractContextManager:
    """The scope of a run's precision: ``float32`` (the default) or ``float64`` (JAX's x64
    mode) inside the ``with`` block only, so a float64 run leaves later runs of the same
    process in float32 (the process-wide switch it replaces did not)."""
    import jax

    if name not in ("float32", "float64"):
        raise MorphogenError(f"precision must be float32 or float64, not {name!r}")
    return jax.enable_x64(name == "float64")
