"""Network runs in the run archive: `morphogen runs` lists them, `runs show` summarises them, the
archived genomes are the run's population and best_1.json replays the best genome's network."""

import json

import jax
import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.runs.config import load_run_file
from morphogen.runs.prepare import load_config_model
from morphogen.search.archive import Archive
from morphogen.search.networks.evolve import load_state
from morphogen.search.networks.genome import Genome, stack, table2_genome, table2_spec
from morphogen.search.networks.reaction import genome_params, padded_reaction
from morphogen.search.networks.record import genome_vectors, spec_from_dict, vector_genome

ARGS = ["--population", "4", "--size", "8", "--dt", "0.5", "--t-start", "5", "--interval",
        "5", "--rounds", "2", "--quiet", "--seed", "1"]


def test_genome_vectors_round_trip():
    spec = table2_spec()
    g = table2_genome(spec)
    other = g._replace(mantissa=g.mantissa.at[6].set(42), active=g.active.at[8].set(False))
    vectors = genome_vectors(stack([g, other]))
    assert vectors.shape == (2, 3 * 9 + 2 * 3 * 9)
    back = vector_genome(vectors[1], spec)
    for a, b in zip(back, other, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert vectors[1][6] == 42 and vectors[1][-1] == 0


@pytest.mark.slow
def test_network_run_is_archived_listed_shown_and_replayable(tmp_path, capsys):
    archive_file = tmp_path / "index.sqlite"
    out = tmp_path / "n"
    args = ["networks", "--mode", "network", "--out", str(out), "--archive", str(archive_file),
            *ARGS]
    assert main(args + ["--generations", "1"]) == 0
    # `morphogen evolve --resume` names the command that resumes a network run ...
    assert main(["evolve", "--resume", str(out), "--archive", str(archive_file)]) == 2
    err = capsys.readouterr().err
    assert f"morphogen networks --out {out} --resume" in err and "damaged" not in err
    # ... which needs only the folder: mode, population, grid, times, seed are the run's
    assert main(["networks", "--out", str(out), "--resume", "--generations", "2",
                 "--quiet"]) == 0
    # and `morphogen networks --resume` on a parameter search names `morphogen evolve`
    (tmp_path / "search").mkdir()
    (tmp_path / "search" / "config.json").write_text('{"id": "ga-x", "problem": {}}')
    assert main(["networks", "--out", str(tmp_path / "search"), "--resume"]) == 2
    assert "morphogen evolve --resume" in capsys.readouterr().err
    capsys.readouterr()

    archive = Archive(archive_file, create=False)
    (row,) = archive.runs()
    assert (row["strategy"], row["fitness"], row["done"], row["generations"]) == (
        "net-network", "cluster", 2, 2)
    assert row["status"] == "done"
    history = np.loadtxt(out / "history.csv", delimiter=",")
    gens = archive.generations(row["id"])
    np.testing.assert_allclose([g["best"] for g in gens], history.max(axis=1), atol=1e-3)
    # the archived genomes of the last generation are the saved population
    pop, _, _, meta = load_state(out / "state.npz")
    spec = spec_from_dict(meta["spec"])
    last = archive.individuals(row["id"], 2)
    np.testing.assert_array_equal(np.array([r["genome"] for r in last]), genome_vectors(pop))
    np.testing.assert_allclose([r["fitness"] for r in last], history[1], atol=1e-4)

    assert main(["runs", "--archive", str(archive_file)]) == 0
    assert row["id"] in capsys.readouterr().out
    assert main(["runs", "show", str(out)]) == 0
    shown = capsys.readouterr().out
    assert "net-network" in shown and "best individual" in shown and "best_1.json" in shown
    assert shown.count("\n     1 ") + shown.count("\n     2 ") == 2  # one row per generation

    # best_1.json: the fittest archived genome as an exported model, replayable
    best = archive.best(row["id"], 1)[0]
    record = json.loads((out / "best" / "best_1.json").read_text())
    assert record["evolved"]["fitness"] == best["fitness"]
    config = load_run_file(out / "best" / "best_1.json")
    assert (config.size, config.dt, config.steps) == ([8, 8], 0.5, 20)
    model = load_config_model(config)
    genome = vector_genome(best["genome"], spec)
    p = genome_params(Genome(*(jax.numpy.asarray(x) for x in genome)), spec)
    u = np.random.default_rng(3).uniform(0.0, 2.0, (3, 4, 4)).astype(np.float32)
    want = np.asarray(padded_reaction(u, p["k"], p["Me"], p["Mp"]))
    got = np.asarray(jax.jit(model.reaction)(u, model.params, {}))
    np.testing.assert_allclose(got, want, rtol=2e-5, atol=1e-5 * max(np.abs(want).max(), 1))
    # random rates of a 2-generation run may blow up over the full replay, and this tiny run's
    # dt = 0.5 may exceed Euler's limit at the genome's fixed point (the replay's start); one
    # step shows the file runs through `morphogen simulate --config`
    assert main(["simulate", "--config", str(out / "best" / "best_1.json"), "--steps", "1",
                 "--out", str(tmp_path / "replay"), "--quiet", "--unsafe"]) == 0
    # the Runs page's fittest networks are valid ones only: an invalid genome (-1) never
    import sqlite3

    from morphogen.search.networks.record import summary

    assert all(b["fitness"] >= 0 for b in summary(archive, row["id"], 3)["best"])
    with sqlite3.connect(archive_file) as db:
        db.execute("UPDATE individuals SET fitness = -1 WHERE run_id = ?", (row["id"],))
    assert summary(archive, row["id"], 3)["best"] == []


@pytest.mark.slow
def test_existing_folder_and_bad_resume_are_refused(tmp_path, capsys):
    archive_file = str(tmp_path / "index.sqlite")
    base = ["networks", "--mode", "rates", "--archive", archive_file, "--generations", "1",
            *ARGS]
    assert main(base + ["--out", str(tmp_path / "a")]) == 0
    assert main(base + ["--out", str(tmp_path / "a")]) == 2
    assert "--resume" in capsys.readouterr().err
    (tmp_path / "b").mkdir()
    assert main(base + ["--out", str(tmp_path / "b"), "--resume"]) == 2
    assert "config.json" in capsys.readouterr().err
    assert main(base + ["--out", str(tmp_path / "c"), "--batches", "2"]) == 2
    assert not (tmp_path / "c" / "config.json").exists()
    assert len(Archive(archive_file).runs()) == 1
