"""Routes of the Evolve page: set up a run, follow it, hand over favourites, stop it.

Genes default to Skaggs's tables 3.1-3.2 where the search package has a preset (Gray-Scott,
Gierer-Meinhardt, GenRD); for the other library models every parameter that is not a diffusion
coefficient (a name starting with ``D``) is a gene on ``[v/2, 3v/2]`` around its default ``v``
(``[-1, 1]`` for a zero default), with a mutation width of a tenth of the range.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from fastapi import APIRouter, Request

from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.search.archive import Archive
from morphogen.search.evaluate import Evaluator, Problem, policy_problem
from morphogen.search.genes import Gene, check_genes, preset_genes
from morphogen.search.run import STRATEGIES, start
from morphogen.web.catalog import check_params, resolve_model
from morphogen.web.evolution import EvolveRun
from morphogen.web.limits import (
    JSONBody,
    Limits,
    check_budget,
    choice,
    integer,
    number,
    run_limited,
)
from morphogen.web.settings import INITIAL_KINDS, read_settings

router = APIRouter(prefix="/api/evolve")

FITNESS = ("user", "dirichlet")
SEARCH_STRATEGIES = tuple(name for name, cls in STRATEGIES.items() if not cls.needs_gradient)
"""The web app's strategies: those that need no fitness gradient (it has no target images)."""
MAX_GENERATIONS = 200
EVOLVE_SETTINGS = ("params", "size", "dx", "boundary", "stencil", "dt", "steps", "seed", "init")
"""The run settings an Evolve request takes from its body."""
MAX_GENES = 128
QUALITY_DIVERSITY = ("map-elites", "cvt-map-elites")
"""Strategies that keep an elite per descriptor cell: they need a fitness that compares any two
individuals, which a person's favourites of one generation are not."""


def default_genes(model: Model) -> list[Gene]:
    """Skaggs's preset genes for the model, or the rule in the module docstring."""
    try:
        return preset_genes(model.name, list(model.params))
    except MorphogenError:
        pass
    genes = []
    for name, value in model.params.items():
        if name.startswith("D"):
            continue
        v = float(value)
        lo, hi = (0.5 * v, 1.5 * v) if v > 0 else (1.5 * v, 0.5 * v) if v < 0 else (-1.0, 1.0)
        genes.append(Gene(name, lo, hi, 0.1 * (hi - lo)))
    return genes


def defaults(model: Model, limits: Limits) -> dict[str, Any]:
    """Suggested settings for an Evolve run of ``model`` that fit the server's budget: ``dt``
    and steps from the run policy (:func:`morphogen.runs.policy.resolve_run`) on the suggested
    grid, the steps cut to the budget (:func:`_budget_steps`)."""
    from morphogen.domains.grid import Grid
    from morphogen.runs.policy import resolve_run

    size, population = 64, 12
    plan = resolve_run(model, Grid((size, size)), model.parameters(), population=True)
    dt = plan.dt
    steps = min(plan.steps, _budget_steps(limits, population, size))
    init = model.init if model.init in INITIAL_KINDS else "square"
    return {
        "genes": [g.to_dict() for g in default_genes(model)],
        "params": [{"name": k, "value": float(v)} for k, v in model.params.items()],
        "size": size, "population": population, "generations": 20, "dt": dt, "steps": steps,
        "init": init, "fitness": "user", "strategy": "ga", "seed": 0,
    }


def parse_genes(raw: Any, model: Model) -> tuple[Gene, ...]:
    if raw is None:
        return tuple(default_genes(model))
    if not isinstance(raw, list) or not raw or len(raw) > MAX_GENES:
        raise MorphogenError(f"genes must be a list of 1 to {MAX_GENES} {{name, low, high}}")
    genes = []
    for g in raw:
        if not isinstance(g, dict):
            raise MorphogenError("each gene must be {name, low, high, sigma}")
        name = g.get("name")
        lo = number(g.get("low"), f"gene {name} low", -1e6, 1e6)
        hi = number(g.get("high"), f"gene {name} high", -1e6, 1e6)
        sigma = g.get("sigma")
        sigma = 0.1 * (hi - lo) if sigma is None else number(sigma, f"gene {name} sigma", 0, 1e6)
        genes.append(Gene(str(name), lo, hi, sigma))
    check_genes(genes, list(model.params))
    return tuple(genes)


def _budget_steps(limits: Limits, population: int, size: int) -> int:
    """The most steps a population on a ``size``² grid may take within the server's budget."""
    return max(1, int(limits.max_cell_steps / (population * size * size)))


def build(body: dict[str, Any], limits: Limits) -> tuple[Problem, dict[str, Any], int, int]:
    """A validated ``(problem, strategy spec, generations, seed)`` from a request."""
    spec = body.get("model", {"library": "gray-scott"})
    model, _ = resolve_model(spec, limits)
    d = defaults(model, limits)
    run = read_settings(body, EVOLVE_SETTINGS, labels={"size": "grid size"},
                        bounds={"size": (16, limits.max_tile_size)},
                        defaults={k: d[k] for k in ("size", "init")})
    population = integer(body.get("population", d["population"]), "population", 2,
                         limits.max_population)
    generations = integer(body.get("generations", d["generations"]), "generations", 1,
                          MAX_GENERATIONS)
    size, seed = run["size"], run["seed"]
    fitness = choice(body.get("fitness", "user"), "fitness", FITNESS)
    strategy = choice(body.get("strategy", "ga"), "strategy", SEARCH_STRATEGIES)
    if fitness == "user" and strategy in QUALITY_DIVERSITY:
        raise MorphogenError("MAP-Elites keeps the fittest individual of each kind of pattern "
                             "across generations, which favourites chosen one generation at a "
                             "time cannot rank; choose the automatic fitness for MAP-Elites")
    problem = Problem(
        model=model.name if "library" in spec else f"{model.name}.toml",
        genes=parse_genes(body.get("genes"), model), model_source=model.source,
        params=check_params(run["params"], model), size=(size, size), dx=run["dx"],
        boundary=run["boundary"], stencil=run["stencil"], seed=seed, init=run["init"],
        fitness=fitness,
    )
    # dt and steps from the run policy, as the command line's; steps cut to the budget
    problem = policy_problem(problem, dt=run["dt"], steps=run["steps"], model=model)
    if run["steps"] is None:
        problem = replace(problem, steps=min(problem.steps,
                                             _budget_steps(limits, population, size)))
    check_budget(size * size, problem.steps, population, limits)
    strat: dict[str, Any] = {"name": strategy, "population": population}
    if strategy == "ga":
        strat.update(elitism=0, tournament=0)
    return problem, strat, generations, seed


def _archive(request: Request) -> Archive:
    return Archive(request.app.state.archive)


@router.get("/setup/{name}")
async def setup(request: Request, name: str):
    """Default settings (genes, grid, steps) for a library model."""
    model, _ = resolve_model({"library": name}, request.app.state.limits)
    return defaults(model, request.app.state.limits)


@router.post("")
async def create(request: Request, body: JSONBody):
    """Validate, create the run in the archive, and start it; returns its status."""
    lim: Limits = request.app.state.limits
    problem, strat, generations, seed = build(body, lim)
    cmap = read_settings(body, ("cmap",), defaults={"cmap": "viridis"})["cmap"]
    # building an evaluator checks the model, genes and stability before anything is written
    await run_limited(lambda: Evaluator(problem), lim.request_timeout_s, "checking the run")
    archive = _archive(request)
    run_id, _ = start(problem, strat, generations=generations, seed=seed, archive=archive,
                      cmap=cmap)
    run = request.app.state.evolve.launch(archive, run_id, problem, generations,
                                          strat["population"])
    return run.to_json()


@router.get("/networks/defaults")
async def network_defaults():
    """Suggested settings of a reaction-network run (:mod:`morphogen.web.network_runs`)."""
    from morphogen.web.network_runs import DEFAULTS, MAX_GENERATIONS

    return {**DEFAULTS, "max_generations": MAX_GENERATIONS}


@router.post("/networks")
async def create_network(request: Request, body: JSONBody):
    """Validate and start a reaction-network evolution (rates or network mode, cluster-head
    fitness); it is polled like any run at ``/api/evolve/{run_id}``."""
    from morphogen.web.network_runs import start_network_run

    runs = request.app.state.evolve
    runs.check_capacity()
    run = start_network_run(body, request.app.state.limits, _archive(request))
    return runs.add(run).to_json()


def _current(request: Request, run_id: str) -> Any:
    """The run this server drives; a favourites run that was waiting for a choice when the
    server stopped (recorded ``running``, driven by no one) is taken up again from its last
    recorded generation: the generation it was waiting on is evaluated again, with the same
    individuals, and waits for the choice, so its page gets its tiles back. Any other run not
    driven here is an error (the Runs page resumes it)."""
    runs = request.app.state.evolve
    archive = _archive(request)

    def waiting() -> EvolveRun | None:
        try:
            info = archive.run(run_id)
            problem = Problem.from_dict(info["config"]["problem"])
        except (MorphogenError, KeyError, TypeError, ValueError):
            return None  # unknown, a network run, or a damaged record: not taken up
        if (info["status"] != "running" or problem.fitness != "user"
                or len(archive.generations(run_id)) >= info["generations"]):
            return None
        strategy = info["config"]["strategy"]["name"]
        return EvolveRun(run_id, archive, problem, info["generations"], info["population"],
                         runs.idle_s, strategy)

    run = runs.take_up(run_id, waiting)
    return run if run is not None else runs.get(run_id)


@router.get("/{run_id}")
async def status(request: Request, run_id: str):
    return _current(request, run_id).to_json()


@router.post("/{run_id}/select")
async def select(request: Request, run_id: str, body: JSONBody):
    """The favourites of the generation on show: ``{"indices": [..]}``."""
    run = _current(request, run_id)
    run.choose(body.get("indices"))
    return run.to_json()


@router.post("/{run_id}/stop")
async def stop(request: Request, run_id: str):
    run = _current(request, run_id)
    run.stop()
    return run.to_json()
