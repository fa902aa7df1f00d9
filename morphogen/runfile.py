"""A run as data: :class:`RunConfig` -> outputs, and ``run.json`` to reproduce it exactly.

``run.json`` holds the whole configuration (model name or the model file's text, parameter
overrides, domain, dt, steps, scheme, seed, initial condition, noise, clamp, rendering) plus
provenance (package versions, device, wall time). ``morphogen simulate --config run.json``
rebuilds the same :class:`RunConfig` and so the same state, bit for bit on the same machine.
"""

from __future__ import annotations

import json
import math
import platform
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from morphogen import guard
from morphogen.autoscheme import choose_scheme
from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.fields import resolve_params
from morphogen.initial import make_initial
from morphogen.io import check_run_dir, staged_dir, write_json
from morphogen.models.model import Model, Tensor
from morphogen.runschema import validate_config
from morphogen.simulate import Solution, simulate
from morphogen.steppers import Noise, max_stable_dt

FORMAT = "morphogen-run/1"
SNAPSHOTS = 241
"""Snapshots a run with ``every`` keeps at most (``simulate``'s ``max_snapshots`` + 1)."""


@dataclass
class RunConfig:
    """Everything that determines a simulation and its pictures.

    ``steps`` or ``time`` may be ``None``: the model's suggested ``t_end`` and ``dt`` fill in
    (the suggested ``dt`` is reduced to 90 % of the stability limit when the domain needs it).
    ``clamp`` is ``"model"`` (the model's own bounds), ``None`` or ``[lo, hi]``.
    """

    model: str
    model_source: str | None = None
    preset: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    size: list[int] = field(default_factory=lambda: [256, 256])
    mesh: str | None = None
    dx: float = 1.0
    boundary: Any = "periodic"
    stencil: int | str | None = None
    dt: float | None = None
    steps: int | None = None
    time: float | None = None
    scheme: str = "euler"
    rtol: float | None = None
    atol: float | None = None
    seed: int = 0
    init: str | None = None
    init_options: dict[str, Any] = field(default_factory=dict)
    noise: dict[str, Any] | None = None
    clamp: Any = "model"
    every: int | None = None
    species: str | None = None
    cmap: str | None = None
    vmin: float | None = None
    vmax: float | None = None
    threshold: float | None = None
    fps: float = 12.0
    animation: str = "gif"
    unsafe: bool = False
    precision: str = "float32"

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunConfig:
        """Rebuild a config from ``run.json``'s ``config`` object (unknown keys are an error)."""
        if not isinstance(data, dict):
            raise MorphogenError("run file: 'config' must be an object")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise MorphogenError(f"run file has unknown settings {unknown}")
        if "model" not in data:
            raise MorphogenError("run file lacks the 'model' setting")
        validate_config(data, "run file")
        return cls(**data)


def load_run_file(path: str | Path) -> RunConfig:
    """Read ``run.json`` (as written by :func:`execute`) into a :class:`RunConfig`."""
    try:
        data = json.loads(Path(path).read_bytes().decode("utf-8-sig"))
    except OSError as exc:
        raise MorphogenError(f"cannot read run file {path}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise MorphogenError(f"run file {path} is not UTF-8 text (is it a run.json?)") from None
    except RecursionError:
        raise MorphogenError(f"run file {path} is nested too deeply") from None
    except json.JSONDecodeError as exc:
        raise MorphogenError(
            f"run file {path} is not valid JSON: {exc.msg} (line {exc.lineno})"
        ) from None
    if not isinstance(data, dict) or not isinstance(data.get("config"), dict):
        raise MorphogenError(f"{path} is not a morphogen run file (no 'config' object)")
    return RunConfig.from_dict(data["config"])


@dataclass
class Prepared:
    """A config resolved into objects, ready to run."""

    config: RunConfig
    model: Model
    domain: Any
    params: dict[str, np.ndarray]
    u0: np.ndarray
    dt: float
    steps: int


def load_config_model(config: RunConfig) -> Model:
    """The model of a config: from the embedded file text when present, else by name/path."""
    from morphogen.models.equations import load_model, parse_model

    if config.model_source is not None:
        return parse_model(config.model_source, path=config.model)
    return load_model(config.model)


def build_domain(config: RunConfig, model: Model) -> Any:
    """A :class:`Grid` from ``size``/``dx``/``boundary``/``stencil``, or a mesh from ``mesh``."""
    if config.mesh:
        from morphogen.domains.mesh import load_mesh

        mesh_args = {} if config.boundary == "periodic" else {"boundary": config.boundary}
        return load_mesh(config.mesh, **mesh_args)
    grid = Grid(tuple(config.size), dx=config.dx, boundary=config.boundary,
                stencil=config.stencil)
    grid.boundaries(model.species)
    return grid


def prepare(config: RunConfig) -> Prepared:
    """Validate and resolve everything before any output is written: the settings against
    :class:`~morphogen.runschema.RunSchema`, then the run's cost against :mod:`morphogen.guard`
    (memory before the domain is built, steps once ``dt`` is known)."""
    validate_config(asdict(config), "run settings")
    set_precision(config.precision)
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
    dt = float(config.dt) if config.dt is not None else _default_dt(model, domain, params, config)
    if config.steps is not None:
        steps = config.steps
    else:
        total = config.time if config.time is not None else model.t_end
        steps = round(total / dt) if math.isfinite(total / dt) else total / dt
    steps = guard.check_steps(steps, cells, len(model.species))
    if config.species is not None:
        model.species_index(config.species)
    return Prepared(config, model, domain, params, u0, dt, steps)


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
    """PLY vertex properties named like a species give its initial value (unless ``--init`` is
    given); those named like a parameter give a per-vertex field (unless ``-p`` sets it)."""
    from morphogen.mesh_io import apply_fields

    mesh_u0, mesh_values = apply_fields(model, mesh, u0, values)
    mesh_values.update({k: values[k] for k in config.params})
    return (u0 if config.init is not None else mesh_u0), mesh_values


def set_precision(precision: str) -> None:
    """``float32`` (the default) or ``float64`` (JAX's x64 mode) for the whole process."""
    import jax

    if precision not in ("float32", "float64"):
        raise MorphogenError(f"precision must be float32 or float64, not {precision!r}")
    jax.config.update("jax_enable_x64", precision == "float64")


def _default_dt(model: Model, domain: Any, params: dict, config: RunConfig) -> float:
    """The model's suggested dt, reduced to 90 % of the stability limit where the domain
    (a 3D grid, a fine mesh, a larger diffusion) needs it; with ``auto`` choosing a stiff
    scheme, that scheme's (reaction-limited) limit."""
    if config.scheme == "auto":
        scheme = choose_scheme(model, domain, params)
        if scheme != "euler":
            return max_stable_dt(model, domain, params, scheme)
    limit = max_stable_dt(model, domain, params, config.scheme)
    return float(min(model.dt, 0.9 * limit))


def run_prepared(prep: Prepared, *, progress: bool = False) -> Solution:
    """Simulate a prepared run."""
    c = prep.config
    noise = Noise(**c.noise) if c.noise else None
    clamp = tuple(c.clamp) if isinstance(c.clamp, list | tuple) else c.clamp
    solution = simulate(
        prep.model, prep.domain, prep.u0, prep.params, steps=prep.steps, dt=prep.dt,
        scheme=c.scheme, noise=noise, clamp=clamp, seed=c.seed, every=c.every,
        progress=progress, unsafe=c.unsafe, rtol=c.rtol, atol=c.atol,
    )
    if c.clamp == "model" and prep.model.clamp is not None:
        check_ceiling(prep.model, np.asarray(solution.state), prep.model.clamp[1])
    return solution


def check_ceiling(model: Model, state: np.ndarray, ceiling: float) -> None:
    """A model's declared upper bound is a guard against overflow, not physics: a species
    that reaches it has blown up, and the run says so instead of keeping the pinned values."""
    for i, s in enumerate(model.species):
        pinned = float(np.mean(state[i] >= ceiling))
        if pinned > 0:
            raise MorphogenError(
                f"numerical blow-up: {pinned:.0%} of species {s} reached the model's ceiling "
                f"{ceiling:g}; reduce --dt or check the parameters, or use --clamp LO:HI to "
                "bound values explicitly"
            )


def execute(config: RunConfig, out: str | Path, *, progress: bool = False) -> Solution:
    """Prepare, simulate and write ``state.npz``, ``final.png``, ``run.json`` (and an
    animation when snapshots were taken) into ``out``, replacing an earlier run there whole;
    nothing is created unless the run succeeds."""
    from morphogen.outputs import write_outputs

    prep = prepare(config)
    check_run_dir(out)
    started = time.perf_counter()
    solution = run_prepared(prep, progress=progress)
    wall = time.perf_counter() - started
    with staged_dir(out) as stage:
        write_outputs(stage, prep, solution)
        write_json(stage / "run.json", run_record(prep, solution, wall))
    return solution


def run_record(prep: Prepared, solution: Solution, wall: float) -> dict[str, Any]:
    """The JSON written to ``run.json``."""
    import jax

    config = asdict(prep.config)
    if prep.model.source is not None:
        config["model_source"] = prep.model.source
    return {
        "format": FORMAT,
        "config": config,
        "resolved": {
            "model": prep.model.name,
            "species": list(prep.model.species),
            "params": {k: _describe(v) for k, v in prep.params.items()},
            "dt": prep.dt,
            "steps": prep.steps,
            "t_end": solution.t,
            "clamp": prep.model.clamp if prep.config.clamp == "model" else prep.config.clamp,
            "scheme": solution.scheme,
            **_adaptive_record(solution),
            **({"warnings": solution.warnings} if solution.warnings else {}),
        },
        "provenance": {
            "morphogen": _version("morphogen"),
            "jax": jax.__version__,
            "numpy": np.__version__,
            "python": platform.python_version(),
            "device": str(jax.devices()[0]),
            "wall_time_s": round(wall, 3),
        },
    }


def _adaptive_record(solution: Solution) -> dict[str, Any]:
    """Accepted and rejected steps of an ``adaptive`` run (nothing for fixed steps)."""
    if solution.rejected_steps is None:
        return {}
    return {"accepted_steps": solution.steps, "rejected_steps": solution.rejected_steps}


def _describe(value: np.ndarray) -> Any:
    arr = np.asarray(value)
    if arr.ndim == 0:
        return float(arr)
    return {"field": list(arr.shape), "min": float(arr.min()), "max": float(arr.max())}


def _version(package: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"
