"""Evaluation: genomes in, fitness out, as one batched simulation per population.

A :class:`Problem` is the plain-data description of what a genome means — model, genes, fixed
parameters, grid, time stepping, initial condition and fitness — so it can be saved with a run,
sent to Ray workers and rebuilt anywhere. :class:`Evaluator` turns it into

.. code-block:: python

    evaluate(genomes (P, G), key) -> (fitness (P,), metrics)

by running the whole population as one compiled program over
:func:`morphogen.engine.simulate.integrate`,
in chunks of steps so a progress bar can move between them. Every individual ``i`` gets its own
key ``fold_in(key, i)``, so results do not depend on how a population is split into batches.

Within the program the population is ``lax.map``-ped ``batch_size`` individuals at a time, each
batch vmapped. On a GPU the default is the whole population in one vmapped batch. On a CPU it is
one individual at a time, so a 256x256 state (512 kB) stays in cache for a whole chunk of steps:
for 20 Gray-Scott individuals on the 2-core development machine this ran at 263 million
cell-steps per second against 214 for the vmapped population (best of 4 interleaved runs), with
bit-identical results.

On an x86-64 CPU with Numba (the ``fast`` extra), a population whose members differ only in
scalar parameters, stepped by explicit Euler without noise on a 2D grid, runs on the fused CPU
step instead (:func:`morphogen.solvers.fused.fused_population`: one generated loop, each member
in turn), by default from :data:`~morphogen.solvers.fused.MIN_MEMBER_WORK` cell-steps a member
and unless a ``batch_size`` is asked for; the final states agree with the JAX step's to float32
rounding, and the same problem runs the same program however its population is split.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache, partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.fields import resolve_params
from morphogen.engine.simulate import integrate
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.runs.policy import RunPlan, resolve_run
from morphogen.runs.settings import default
from morphogen.search import fitness as fit
from morphogen.search.genes import Gene, check_genes
from morphogen.search.networks.cluster import cluster_head_fitness
from morphogen.solvers.fused import fused_population
from morphogen.solvers.step import make_step, max_stable_dt

FITNESS_KINDS = ("dirichlet", "target", "cluster", "user")
CHUNK = 250
"""Steps per compiled chunk between progress updates."""
SEARCH_SIZE = (128, 128)
"""A search's default grid (``evolve``, ``fit``, ``mg.optimise``): a population of 20 on the
single run's 256² would cost four times as much per generation."""


@dataclass(frozen=True)
class Problem:
    """What to simulate for a genome and how to score it (JSON-serialisable).

    The simulation settings have the names and meanings of
    :class:`morphogen.runs.config.RunConfig`, so an individual can be written out as a ``run.json``
    that ``morphogen simulate --config`` reproduces.

    Attributes:
        model: library name or model file path; ``model_source`` the file's text, so the
            problem is rebuilt without the file (on a Ray worker, or after the file changed).
        genes: the searched parameters (scalars).
        preset, params: fixed parameter values (a preset, then overrides; numbers or
            expressions of ``x, y, z``, resolved with the model's default values).
        size, dx, boundary, stencil: the grid (:class:`morphogen.domains.grid.Grid`); a
            search's own default grid is :data:`SEARCH_SIZE`, smaller than a single run's.
        dt, steps, time, scheme: time stepping (``scheme`` any fixed-step scheme or ``auto``,
            chosen once from the base parameters; ``adaptive`` is refused, since the population
            advances with one ``dt``). ``None`` is the run policy's, as for every front end:
            :func:`resolve_problem` (which the :class:`Evaluator` calls) fills ``dt`` and
            ``steps`` from ``time`` or the model's ``t_end``; ``clamp`` is ``"model"`` (the
            model's own bounds), ``None`` or ``[lo, hi]`` (Skaggs §3.2 clamps to ``[0, 5]``).
        seed, init, init_options: the initial condition
            (:func:`morphogen.engine.initial.make_initial`; ``init=None``: the model's own);
            every individual starts from the same one (up to its own ground state).

    The run settings' defaults and checks are the settings table's
    (:data:`morphogen.runs.settings.SETTINGS`; ``tests/runs/test_settings_table.py``), except
    ``size``.
        fitness: one of :data:`FITNESS_KINDS`; ``target`` the image for ``"target"``;
            ``flat_tol`` the relative spread below which a state counts as uniform.
    """

    model: str
    genes: tuple[Gene, ...]
    model_source: str | None = None
    preset: str | None = None
    params: Mapping[str, Any] = field(default_factory=dict)
    size: tuple[int, ...] = SEARCH_SIZE
    dx: float = default("dx")
    boundary: Any = default("boundary")
    stencil: int | str | None = default("stencil")
    dt: float | None = default("dt")
    steps: int | None = default("steps")
    time: float | None = default("time")
    scheme: str = default("scheme")
    clamp: Any = default("clamp")
    seed: int = default("seed")
    init: str | None = default("init")
    init_options: Mapping[str, Any] = field(default_factory=partial(default, "init_options"))
    fitness: str = "dirichlet"
    target: str | None = None
    flat_tol: float = 1e-3

    def __post_init__(self) -> None:
        if self.fitness not in FITNESS_KINDS:
            raise MorphogenError(
                f"unknown fitness {self.fitness!r}; use one of {', '.join(FITNESS_KINDS)}"
            )
        if self.fitness == "target" and not self.target:
            raise MorphogenError("--fitness target needs --target IMAGE")
        if self.steps is not None and self.steps < 1:
            raise MorphogenError(f"steps must be >= 1, got {self.steps}")
        for name in ("dt", "time"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise MorphogenError(f"{name} must be a positive number, got {value}")

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["genes"] = [g.to_dict() for g in self.genes]
        data["size"] = list(self.size)
        data["params"] = dict(self.params)
        data["init_options"] = dict(self.init_options)
        data["clamp"] = list(self.clamp) if isinstance(self.clamp, list | tuple) else self.clamp
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Problem:
        data = dict(data)
        data["genes"] = tuple(Gene.from_dict(g) for g in data["genes"])
        data["size"] = tuple(int(n) for n in data["size"])
        return cls(**data)

    def clamp_bounds(self, model: Model) -> tuple[float, float] | None:
        """The clamp as ``(lo, hi)`` or ``None``."""
        value = model.clamp if self.clamp == "model" else self.clamp
        return tuple(float(v) for v in value) if value is not None else None


def problem_base(problem: Problem, model: Model | None = None
                 ) -> tuple[Model, Grid, dict[str, Any]]:
    """The problem's model, grid and base parameters (genes at their fixed values)."""
    model = load_problem_model(problem) if model is None else model
    domain = Grid(problem.size, problem.dx, problem.boundary, problem.stencil)
    domain.boundaries(model.species)
    values = model.parameters(dict(problem.params), preset=problem.preset)
    return model, domain, resolve_params(model, domain, values)


def resolve_problem(problem: Problem, model: Model | None = None) -> Problem:
    """``problem`` with every setting concrete: ``init=None`` the model's, and ``dt`` and
    ``steps`` the run policy's for what was given (:func:`morphogen.runs.policy.resolve_run`
    on the base parameters, as a population: the model's ``dt`` within the scheme's limit, a
    given ``dt`` checked against it, ``steps`` from ``time`` or the model's ``t_end``): the
    search's door to the policy every front end uses. A problem already concrete is returned
    as it is."""
    if problem.dt is not None and problem.steps is not None and problem.init is not None:
        return problem
    return _planned(problem, model)[0]


def _planned(problem: Problem, model: Model | None
             ) -> tuple[Problem, RunPlan, Grid, dict[str, Any]]:
    """The problem made concrete by one run of the policy, the plan (its scheme with ``auto``
    resolved), and the problem's grid and base parameters."""
    model, domain, base = problem_base(problem, model)
    plan = resolve_run(model, domain, base, scheme=problem.scheme, dt=problem.dt,
                       steps=problem.steps, t_end=problem.time, population=True)
    concrete = replace(problem, dt=plan.dt, steps=plan.steps, init=problem.init or model.init)
    return concrete, plan, domain, base


def policy_problem(problem: Problem, *, dt: float | None = None, steps: int | None = None,
                   time: float | None = None, model: Model | None = None) -> Problem:
    """``problem`` with ``dt``, ``steps`` and ``time`` as given (``None``: the run policy's),
    resolved (:func:`resolve_problem`)."""
    return resolve_problem(replace(problem, dt=dt, steps=steps, time=time), model)


def load_problem_model(problem: Problem) -> Model:
    """The problem's model: parsed from the saved source when there is one."""
    if problem.model_source is not None:
        from morphogen.models.text.equations import parse_model

        return parse_model(problem.model_source, path=problem.model)
    from morphogen.models.registry import load_model

    return load_model(problem.model)


def individual_keys(key: Any, n: int, start: int = 0) -> np.ndarray:
    """Keys ``fold_in(key, i)`` for ``i = start .. start + n - 1``, shape ``(n, 2)`` uint32."""
    idx = jnp.arange(start, start + n)
    return np.asarray(jax.vmap(lambda i: jax.random.fold_in(key, i))(idx))


class Evaluator:
    """A problem made runnable: ``evaluator(genomes, key) -> (fitness, metrics)``.

    ``metrics`` holds ``valid`` (``(P,)`` bool: finite, bounded and within the stability limit)
    and ``fields``, the final display species, shape ``(P, *spatial)`` (for contact sheets).
    With ``fitness="user"`` the fitness is :data:`~morphogen.search.fitness.FLAT` for valid
    individuals and :data:`~morphogen.search.fitness.INVALID` otherwise, to be replaced by a
    person's choice (:func:`~morphogen.search.fitness.human_fitness`).

    Args:
        batch_size: individuals vmapped together (default: all on a GPU, one on a CPU, or
            the fused CPU step where it applies; a size given keeps the JAX step).
        model: the model itself, for one built in Python that has no text to load from
            (default: :func:`load_problem_model`); it must have the problem's ``model`` name.
    """

    def __init__(self, problem: Problem, *, batch_size: int | None = None,
                 model: Model | None = None):
        self.batch_size = batch_size
        self.model = load_problem_model(problem) if model is None else model
        check_genes(problem.genes, list(self.model.params))
        # the run policy, once: auto resolved for the population, a given dt checked against
        # its limit, dt, steps and init filled in where the problem left them out
        self.problem, plan, self.domain, self.base = _planned(problem, self.model)
        problem = self.problem
        self.scheme = plan.scheme
        self.display = self.model.species_index(self.model.display_species)
        self._step = make_step(self.model, self.domain, scheme=self.scheme,
                               clamp=problem.clamp_bounds(self.model))
        self._score = self._fitness_fn()
        scalar = all(np.ndim(v) == 0 for v in self.base.values())
        self._fused = fused_population(
            self.model, self.domain, tuple(self.base), scheme=self.scheme,
            clamp=problem.clamp_bounds(self.model), steps=int(problem.steps)
        ) if scalar and batch_size is None else None

    def __call__(self, genomes: Any, key: Any, progress: Callable[[int], None] | None = None,
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        genomes = np.asarray(genomes, np.float32)
        return self.evaluate_keys(genomes, individual_keys(key, genomes.shape[0]), progress)

    def evaluate_keys(
        self, genomes: np.ndarray, keys: np.ndarray, progress: Callable[[int], None] | None = None
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Evaluate ``genomes`` ``(P, G)`` with one key per individual, ``keys`` ``(P, 2)``.

        ``progress(n)`` is called after every chunk of ``n`` steps.
        """
        genomes = np.asarray(genomes, np.float32)
        if genomes.ndim != 2 or genomes.shape[1] != len(self.problem.genes):
            raise MorphogenError(
                f"genomes must have shape (P, {len(self.problem.genes)}), got {genomes.shape}"
            )
        params = self.population_params(genomes)
        u = self.initial_states(genomes)
        if self._fused is not None:
            u = self._advance_fused(u, params, progress)
        else:
            u = self._advance_jax(jnp.asarray(u), params, jnp.asarray(keys), progress)
        stable = self.stable(genomes)
        score = np.asarray(self._score(u), np.float32)
        valid = np.asarray(jax.vmap(fit.is_valid)(u)) & stable
        fitness = np.where(valid, score, np.float32(fit.INVALID)).astype(np.float32)
        fields = np.asarray(u[:, self.display], np.float32)
        return fitness, {"valid": valid, "fields": fields}

    def _advance_jax(self, u: Any, params: dict[str, Any], keys: Any,
                     progress: Callable[[int], None] | None) -> Any:
        """The population's run on the JAX step, :data:`CHUNK` steps a compiled program."""
        t = jnp.asarray(0.0, u.dtype)
        done = 0
        while done < self.problem.steps:
            m = min(CHUNK, self.problem.steps - done)
            u, ts, keys = self._advance(m, u.shape[0])(u, params, t, keys)
            t = ts[0]
            done += m
            if progress is not None:
                u.block_until_ready()  # dispatch is asynchronous: wait, so the bar is true
                progress(m)
        return u

    def _advance_fused(self, u: np.ndarray, params: dict[str, Any],
                       progress: Callable[[int], None] | None) -> Any:
        """The population's run on the fused CPU step (:mod:`morphogen.solvers.fused`; no noise,
        so the keys are not used), :data:`CHUNK` steps a call."""
        assert self._fused is not None
        q = np.stack([np.asarray(params[k], np.float32) for k in self.base], axis=1)
        t = np.float32(0.0)
        done = 0
        while done < self.problem.steps:
            m = min(CHUNK, self.problem.steps - done)
            u, t = self._fused(u, q, t, float(self.problem.dt), m)
            done += m
            if progress is not None:
                progress(m)
        return jnp.asarray(u)

    def population_params(self, genomes: np.ndarray) -> dict[str, Any]:
        """Model parameters with a leading population axis ``P`` (genes set per individual)."""
        n = genomes.shape[0]
        out = {k: jnp.broadcast_to(jnp.asarray(v, jnp.float32), (n, *np.shape(v)))
               for k, v in self.base.items()}
        for j, gene in enumerate(self.problem.genes):
            out[gene.name] = jnp.asarray(genomes[:, j])
        return out

    def genome_parameters(self, genome: Sequence[float]) -> dict[str, float]:
        """All parameter values of one individual: the base set with its genes applied."""
        p = dict(self.base)
        for gene, v in zip(self.problem.genes, genome, strict=True):
            p[gene.name] = float(v)
        return p

    def stable(self, genomes: np.ndarray) -> np.ndarray:
        """Whether ``dt`` is within each individual's explicit stability limit, ``(P,)``."""
        dt, scheme = self.problem.dt, self.scheme
        return np.array([
            dt <= max_stable_dt(self.model, self.domain, self.genome_parameters(g), scheme)
            for g in genomes
        ])

    def initial_states(self, genomes: np.ndarray) -> np.ndarray:
        """Initial states ``(P, S, *spatial)``; built once per distinct ground state."""
        from morphogen.engine.initial import make_initial

        p = self.problem
        cache: dict[bytes, np.ndarray] = {}
        out = []
        for g in genomes:
            params = self.genome_parameters(g)
            tag = np.concatenate([self.model.ground_state(params),
                                  self.model.excited_state(params)]).tobytes()
            if tag not in cache:
                cache[tag] = make_initial(p.init, self.model, self.domain, params,
                                          seed=p.seed, **dict(p.init_options))
            out.append(cache[tag])
        return np.stack(out)

    def _advance(self, steps: int, population: int) -> Callable:
        batch = self.batch_size or (1 if jax.default_backend() == "cpu" else population)
        return _advance_fn(self._step, steps, float(self.problem.dt), min(batch, population))

    def _fitness_fn(self) -> Callable:
        p = self.problem
        periodic = all(b.kind == "periodic" for b in self.domain.boundaries(self.model.species))
        if p.fitness == "dirichlet":
            return jax.jit(fit.dirichlet_fitness(periodic, p.flat_tol))
        if p.fitness == "target":
            target = fit.load_target(p.target, p.size)
            return jax.jit(fit.target_fitness(target, self.display, flat_tol=p.flat_tol))
        if p.fitness == "cluster":
            return jax.jit(cluster_head_fitness(species=self.display, normalise=True,
                                                flat_tol=p.flat_tol))
        return jax.jit(lambda u: jnp.full(u.shape[:1], fit.FLAT, jnp.float32))


@lru_cache(maxsize=64)
def _advance_fn(step: Callable, steps: int, dt: float, batch: int) -> Callable:
    """``steps`` steps for a population: ``lax.map`` over it, ``batch`` members at a time
    (vmapped within a batch); one compiled program either way."""

    def one(args):
        u, p, t, key = args
        return integrate(step, u, p, steps=steps, dt=dt, t0=t, key=key)

    def run(u, p, t, keys):
        ts = jnp.broadcast_to(t, u.shape[:1])
        return jax.lax.map(one, (u, p, ts, keys), batch_size=batch)

    return jax.jit(run)


@lru_cache(maxsize=8)
def cached_evaluator(problem_json: str) -> Evaluator:
    """One :class:`Evaluator` per problem per process (Ray workers reuse it between batches)."""
    import json

    return Evaluator(Problem.from_dict(json.loads(problem_json)))
