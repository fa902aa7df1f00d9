"""Routes of the Runs page: browse the archive shared with ``morphogen evolve`` / ``runs``.

A run that is not advancing on this server (stopped, interrupted by a restart, or run by the
command line) can be resumed here: it continues from its last recorded generation with
``search.run.evolve``, exactly as ``morphogen evolve --resume RUN`` would, and the Evolve page
follows it. A run can be deleted: its rows leave the archive and its directory is removed, but
only a directory inside the archive's own folder (where the app and ``morphogen evolve``
without ``--out`` put runs); a run elsewhere, or one still advancing, is refused.

Files of a run (contact sheets, individuals' pictures, the fitness plot, best individuals'
run files, a MAP-Elites run's elite map, coverage plot and elites' run files) are served from
the run's directory only: the requested path is resolved and must stay inside that directory
and end in ``.png`` or ``.json``.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse, Response

from morphogen.errors import MorphogenError
from morphogen.search.archive import Archive, archive_path
from morphogen.search.evaluate import Problem
from morphogen.search.report import individual_run_file

router = APIRouter(prefix="/api/runs")

SERVED = {".png": "image/png", ".json": "application/json"}


def _archive(request: Request) -> Archive | None:
    path = archive_path(request.app.state.archive)
    return Archive(path, create=False) if path.exists() else None


def _run(request: Request, run_id: str) -> tuple[Archive, dict[str, Any]]:
    archive = _archive(request)
    if archive is None:
        raise MorphogenError("the run archive is empty: start a run on the Evolve page")
    return archive, archive.run(run_id)


def _is_network(info: dict[str, Any]) -> bool:
    """Whether a run was written by ``morphogen networks`` (or the Evolve page's network mode),
    whose settings are a network specification rather than a parameter search's problem."""
    from morphogen.search.networks.record import KIND

    return info["config"].get("kind") == KIND


def _search_problem(info: dict[str, Any]) -> Problem:
    """A parameter search's problem; a network run is refused with the command to use."""
    if _is_network(info):
        from morphogen.search.networks.record import resume_hint

        raise MorphogenError(resume_hint(info["id"], info["dir"]))
    return Problem.from_dict(info["config"]["problem"])


def _file_url(run_id: str, rel: str) -> str:
    return f"/api/runs/{run_id}/files/{rel}"


def _individual(run: dict[str, Any], problem: Problem, row: dict[str, Any]) -> dict[str, Any]:
    params = dict(problem.params)
    params.update({g.name: float(v) for g, v in zip(problem.genes, row["genome"], strict=True)})
    return {
        "gen": row["gen"], "idx": row["idx"], "fitness": row["fitness"],
        "valid": bool(row["valid"]), "image": _file_url(run["id"], row["image"]),
        "params": params,
        "config": f"/api/runs/{run['id']}/individuals/{row['gen']}/{row['idx']}/config",
    }


def explore_settings(problem: Problem) -> dict[str, Any]:
    """What the page needs to open an individual of this problem in Explore."""
    model = ({"equations": problem.model_source} if problem.model_source
             else {"library": problem.model})
    return {"model": model, "init": problem.init, "seed": problem.seed,
            "size": max(problem.size)}


@router.get("")
async def runs(request: Request):
    """Every run in the archive, newest first."""
    archive = _archive(request)
    if archive is None:
        return {"archive": str(archive_path(request.app.state.archive)), "runs": []}
    keys = ("id", "model", "strategy", "fitness", "population", "generations", "done", "best",
            "status", "created")
    return {"archive": str(archive.path), "runs": [{k: r[k] for k in keys} for r in archive.runs()]}


@router.get("/{run_id}")
async def run(request: Request, run_id: str):
    """A run: settings, generations (with contact sheets), best individuals."""
    archive, info = _run(request, run_id)
    if _is_network(info):
        from morphogen.search.networks.record import summary

        return summary(archive, run_id)
    problem = Problem.from_dict(info["config"]["problem"])
    gens = [{**g, "sheet": _file_url(run_id, g["sheet"])} for g in archive.generations(run_id)]
    return {
        "id": run_id, "model": info["model"], "status": info["status"],
        "strategy": info["strategy"], "fitness": info["fitness"],
        "population": info["population"], "generations": info["generations"],
        "genes": [g.to_dict() for g in problem.genes],
        "problem": {"size": list(problem.size), "dt": problem.dt, "steps": problem.steps,
                    "init": problem.init},
        "explore": explore_settings(problem),
        "history": gens,
        "fitness_plot": (_file_url(run_id, "fitness.png")
                         if gens and problem.fitness != "user" else None),
        "best": [_individual(info, problem, r) for r in archive.best(run_id, 6)],
        "map_elites": _map_elites(info, problem),
    }


def _map_elites(run: dict[str, Any], problem: Problem) -> dict[str, Any] | None:
    """A MAP-Elites run's archive (``elites/index.json``, :mod:`morphogen.search.qd_report`):
    its picture, coverage plot and every elite as an individual with its cell and family."""
    import json

    root = Path(run["dir"])
    try:
        index = json.loads((root / "elites" / "index.json").read_text())
    except (OSError, ValueError):
        return None
    elites = []
    for e in index.get("elites", []):
        if e.get("generation") is None:
            continue
        row = {"gen": e["generation"], "idx": e["index"], "fitness": e["fitness"],
               "valid": True, "image": e["image"], "genome": e["genome"]}
        elites.append({**_individual(run, problem, row), "cell": e["cell"],
                       "descriptors": e["descriptors"], "family": e.get("family"),
                       "config": _file_url(run["id"], e["run_file"])})
    files = {name: _file_url(run["id"], name) if (root / name).is_file() else None
             for name in ("elites.png", "qd.png")}
    return {"grid": index.get("grid"), "cells": index.get("cells"), "elites": elites,
            "map": files["elites.png"], "qd_plot": files["qd.png"]}


def _active(request: Request, run_id: str) -> bool:
    """Whether this server is advancing the run (or waiting for a choice in it)."""
    try:
        return request.app.state.evolve.get(run_id).state in ("running", "choose")
    except MorphogenError:
        return False


@router.post("/{run_id}/resume")
async def resume(request: Request, run_id: str):
    """Continue a stopped or interrupted run from its last recorded generation."""
    archive, info = _run(request, run_id)
    if _active(request, run_id):
        raise MorphogenError(f"run {run_id} is already running on this server")
    done = len(archive.generations(run_id))
    if done >= info["generations"]:
        raise MorphogenError(f"run {run_id} has finished all {info['generations']} generations")
    problem = _search_problem(info)
    archive.set_status(run_id, "running")
    run = request.app.state.evolve.launch(archive, run_id, problem, info["generations"],
                                          info["population"])
    return run.to_json()


@router.delete("/{run_id}")
async def delete(request: Request, run_id: str):
    """Delete a run from the archive and its directory (inside the archive's folder only)."""
    archive, info = _run(request, run_id)
    if _active(request, run_id):
        raise MorphogenError(f"run {run_id} is still running; stop it before deleting it")
    folder = archive.path.parent.resolve()
    directory = Path(info["dir"]).resolve()
    if folder not in directory.parents:
        raise MorphogenError(
            f"run {run_id} lives in {directory}, outside the archive's folder {folder}; "
            "delete it from the command line"
        )
    archive.delete_run(run_id)
    shutil.rmtree(directory, ignore_errors=True)
    return {"deleted": run_id}


@router.get("/{run_id}/generations/{gen}")
async def generation(request: Request, run_id: str, gen: int):
    """The individuals of one generation."""
    archive, info = _run(request, run_id)
    problem = _search_problem(info)
    rows = archive.individuals(run_id, gen)
    if not rows:
        raise MorphogenError(f"run {run_id} has no generation {gen} yet")
    return {"gen": gen, "individuals": [_individual(info, problem, r) for r in rows],
            "explore": explore_settings(problem)}


@router.get("/{run_id}/individuals/{gen}/{idx}/config")
async def individual_config(request: Request, run_id: str, gen: int, idx: int):
    """A ``run.json`` that ``morphogen simulate --config`` runs to reproduce an individual."""
    import json

    archive, info = _run(request, run_id)
    problem = _search_problem(info)
    rows = [r for r in archive.individuals(run_id, gen) if r["idx"] == idx]
    if not rows:
        raise MorphogenError(f"run {run_id} has no individual {idx} in generation {gen}")
    data = json.dumps(individual_run_file(problem, rows[0]["genome"]), indent=2) + "\n"
    name = f"{run_id}-g{gen}-i{idx}.json"
    return Response(data, media_type="application/json",
                    headers={"Content-Disposition": f'attachment; filename="{name}"'})


@router.get("/{run_id}/files/{rel:path}")
async def file(request: Request, run_id: str, rel: str):
    """A picture or JSON file of a run, from inside its directory only."""
    _, info = _run(request, run_id)
    root = Path(info["dir"]).resolve()
    path = (root / rel).resolve()
    if root not in path.parents or path.suffix.lower() not in SERVED or not path.is_file():
        raise MorphogenError(f"run {run_id} has no file {rel!r}")
    return FileResponse(path, media_type=SERVED[path.suffix.lower()])
