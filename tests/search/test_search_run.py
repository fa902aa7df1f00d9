"""Evolution runs end to end: the evolve and runs commands, run directories, best individuals
that `morphogen simulate --config` reproduces, human selection, and resume after SIGKILL."""

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from types import SimpleNamespace

import jax
import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.runs.config import load_run_file
from morphogen.runs.execute import run_prepared
from morphogen.runs.prepare import prepare
from morphogen.search.archive import Archive
from morphogen.search.evaluate import Problem, individual_keys
from morphogen.search.executors import LocalExecutor
from morphogen.search.fitness import dirichlet_fitness, human_fitness
from morphogen.search.genes import preset_genes
from morphogen.search.run import evolve, start

SMALL = ["--size", "24", "--dt", "0.5", "--steps", "120", "--init", "skaggs",
         "--preset", "skaggs-table-3.1", "--population", "6"]


def evolve_cli(tmp_path, *extra):
    return main(["evolve", "gray-scott", *SMALL, "--archive", str(tmp_path / "index.sqlite"),
                 *extra])


@pytest.mark.slow
def test_evolve_writes_a_complete_run(tmp_path, capsys):
    out = tmp_path / "run"
    assert evolve_cli(tmp_path, "--generations", "2", "--out", str(out), "--elitism", "1") == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split(":")[0] for ln in lines if ln.startswith("generation")] == [
        "generation 1/2", "generation 2/2"]
    for name in ("config.json", "fitness.png", "generations/gen_001.png",
                 "generations/gen_002.png", "generations/gen_002/ind_05.png",
                 "best/best_1.png", "best/best_1.json"):
        assert (out / name).is_file(), name
    archive = Archive(tmp_path / "index.sqlite")
    (run,) = archive.runs()
    assert run["done"] == 2 and run["status"] == "done"
    rows = archive.individuals(run["id"])
    assert len(rows) == 12 and all((out / r["image"]).is_file() for r in rows)
    # elitism: the best of generation 1 is the first individual of generation 2
    gen1 = [r for r in rows if r["gen"] == 1]
    best1 = max(gen1, key=lambda r: r["fitness"])
    assert rows[6]["genome"] == best1["genome"]
    # all fitness values are staged Dirichlet energies
    assert all(r["fitness"] == -1.0 or 0.0 <= r["fitness"] <= 1.0 for r in rows)

    assert main(["runs", "--archive", str(tmp_path / "index.sqlite")]) == 0
    assert run["id"] in capsys.readouterr().out
    assert main(["runs", "show", str(out), "--archive", str(tmp_path / "index.sqlite")]) == 0
    shown = capsys.readouterr().out
    assert "best individuals" in shown and "population 6" in shown and "elitism=1" in shown

    # the best individual's run.json reproduces it with `morphogen simulate --config`
    record = json.loads((out / "best" / "best_1.json").read_text())
    state = run_prepared(prepare(load_run_file(out / "best" / "best_1.json"))).state
    score = float(dirichlet_fitness()(state[None])[0])
    assert score == pytest.approx(record["evolved"]["fitness"], rel=1e-4)
    assert main(["simulate", "--config", str(out / "best" / "best_1.json"),
                 "--out", str(tmp_path / "again"), "--quiet"]) == 0


@pytest.mark.parametrize("args, message", [
    (["--gene", "Q=0:1"], "not a parameter"),
    (["--gene", "F=0.1:0.05"], "low < high"),
    (["--fitness", "target"], "--target"),
    (["--target", "x.png"], "only with --fitness target"),
    (["--address", "127.0.0.1:1"], "--executor ray"),
    (["--dt", "5"], "stability limit"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "run"
    assert evolve_cli(tmp_path, "--out", str(out), *args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("morphogen: error:") and "\n" not in err and message in err
    assert not out.exists()


def test_resume_needs_a_known_run(tmp_path, capsys):
    assert main(["evolve", "--resume", "nothing", "--archive", str(tmp_path / "a.sqlite")]) == 2
    assert main(["evolve", "gray-scott", "--resume", "x"]) == 2
    assert main(["runs", "show", "zzz", "--archive", str(tmp_path / "a.sqlite")]) == 2
    errors = capsys.readouterr().err.strip().splitlines()
    assert len(errors) == 3 and all(e.startswith("morphogen: error:") for e in errors)


def test_human_selection_drives_the_ga(tmp_path, monkeypatch):
    problem = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                      preset="skaggs-table-3.1", size=(16, 16), dt=0.5, steps=40,
                      fitness="user")
    archive = Archive(tmp_path / "index.sqlite")
    run_id, out = start(problem, {"name": "ga", "population": 5}, generations=2,
                        out=tmp_path / "run", archive=archive)
    sheets = []
    # The run's clock moves only while the person chooses: the computer's time reads 0.
    clock = [0.0]
    monkeypatch.setattr("morphogen.search.run.time", SimpleNamespace(perf_counter=lambda: clock[0]))

    def choose(sheet, n):
        sheets.append(sheet)
        clock[0] += 1.5  # a person looking at the sheet
        return [1, 3]

    evolve(run_id, archive, LocalExecutor(problem), select=choose, log=lambda s: None)
    assert sheets == [str(out / "generations" / f"gen_{g:03d}.png") for g in (1, 2)]
    fitness = [r["fitness"] for r in archive.individuals(run_id, 1)]
    np.testing.assert_allclose(fitness, human_fitness([1, 3], 5), rtol=1e-6)
    # a generation's time is the computer's: the 2 x 1.5 s of choosing are not in it
    recorded = [g["seconds"] for g in archive.generations(run_id)]
    assert recorded == [0.0, 0.0]
    assert not (out / "fitness.png").exists()  # selection weights are not plotted as fitness


@pytest.mark.slow
def test_target_fitness_and_cmaes(tmp_path, capsys):
    from PIL import Image

    yy, xx = np.mgrid[0:24, 0:24]
    Image.fromarray((127 + 127 * np.sin(xx / 2.0)).astype(np.uint8)).save(tmp_path / "t.png")
    assert evolve_cli(tmp_path, "--generations", "2", "--strategy", "cmaes", "--fitness",
                      "target", "--target", str(tmp_path / "t.png"), "--out",
                      str(tmp_path / "run")) == 0
    rows = Archive(tmp_path / "index.sqlite").individuals(
        Archive(tmp_path / "index.sqlite").runs()[0]["id"])
    assert len(rows) == 12 and all(r["fitness"] <= 1.0 for r in rows)


def _cli(*args):
    return [sys.executable, "-m", "morphogen.cli.main", *args]


def _recorded(archive_file):
    if not archive_file.exists():
        return 0
    with sqlite3.connect(archive_file, timeout=5) as db:
        try:
            return db.execute("SELECT COUNT(*) FROM generations").fetchone()[0]
        except sqlite3.OperationalError:
            return 0


@pytest.mark.slow
def test_resume_after_sigkill_gives_the_uninterrupted_result(tmp_path):
    common = ["evolve", "gray-scott", "--size", "32", "--dt", "0.5", "--steps", "250",
              "--preset", "skaggs-table-3.1", "--population", "6",
              "--generations", "6", "--seed", "11", "--elitism", "1", "--quiet"]
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    whole, broken = tmp_path / "whole.sqlite", tmp_path / "broken.sqlite"
    victim = subprocess.Popen(_cli(*common, "--archive", str(broken), "--out",
                                   str(tmp_path / "broken")), env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    reference = subprocess.Popen(_cli(*common, "--archive", str(whole), "--out",
                                      str(tmp_path / "whole")), env=env,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while _recorded(broken) < 2 and victim.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    killed_at = _recorded(broken)
    assert 2 <= killed_at < 6, "the run should have been killed part-way"
    assert reference.wait(timeout=180) == 0, reference.stderr.read().decode()

    resumed = subprocess.run(_cli("evolve", "--resume", str(tmp_path / "broken"), "--quiet"),
                             env=env, capture_output=True, text=True, timeout=180)
    assert resumed.returncode == 0, resumed.stderr
    assert f"generation {killed_at + 1}/6" in resumed.stdout
    assert "generation 1/6" not in resumed.stdout

    a, b = Archive(whole), Archive(broken)
    ra, rb = a.runs()[0]["id"], b.runs()[0]["id"]
    strip = [(r["gen"], r["idx"], r["genome"], r["fitness"]) for r in a.individuals(ra)]
    assert strip == [(r["gen"], r["idx"], r["genome"], r["fitness"]) for r in b.individuals(rb)]
    assert len(strip) == 36
    assert a.best(ra)[0]["genome"] == b.best(rb)[0]["genome"]
    assert b.run(rb)["status"] == "done"


@pytest.mark.slow
def test_results_do_not_depend_on_how_a_population_is_split():
    problem = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                      preset="skaggs-table-3.1", size=(16, 16), dt=0.5, steps=30)
    ex = LocalExecutor(problem)
    genomes = np.array([[0.03, 0.05], [0.05, 0.06], [0.04, 0.055]], np.float32)
    f, m = ex.evaluate(genomes, jax.random.PRNGKey(1))
    keys = individual_keys(jax.random.PRNGKey(1), 3)
    f1, m1 = ex.evaluator.evaluate_keys(genomes[1:], keys[1:])
    assert m["fields"].shape == (3, 16, 16) and m["valid"].all()
    np.testing.assert_allclose(f[1:], f1, rtol=1e-5, atol=1e-6)  # batches of 3 vs 2
    np.testing.assert_allclose(m["fields"][1:], m1["fields"], rtol=1e-5, atol=1e-6)
