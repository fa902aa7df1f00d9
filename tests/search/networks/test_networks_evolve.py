"""Network evolution loop: evaluation against the fixed-structure model, resume (Yamamoto §3-4)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import integrate
from morphogen.models.network import yamamoto_activator_inhibitor
from morphogen.search.networks.evolve import (
    Evaluation,
    evaluate,
    initial_state,
    network_fitness,
    run,
)
from morphogen.search.networks.genome import stack, table2_genome, table2_spec
from morphogen.search.networks.operators import Operators
from morphogen.solvers.step import make_step

EV = Evaluation(size=12, dt=0.5, t_start=20.0, interval=10.0, rounds=2, init="uniform")


@pytest.mark.slow
def test_evaluation_matches_fixed_structure_model():
    spec = table2_spec()
    g = table2_genome(spec)
    bad = g._replace(mantissa=g.mantissa.at[6].set(99), exponent=g.exponent.at[6].set(2))
    u0 = initial_state(jax.random.key(0), spec, EV)
    fitness, states = evaluate(stack([g, bad]), u0, spec, EV)
    # the same network written by hand (models/network.py), species order a, h, c = A, B, C
    model = yamamoto_activator_inhibitor()
    step = make_step(model, Grid((12, 12)))
    p = {k: jnp.asarray(v, jnp.float32) for k, v in model.parameters().items()}
    score = network_fitness(EV)
    u, total = u0, 0.0
    for scored in (False, True, True):  # a check at t = 10, rounds at t = 20 and 30
        before = u
        u, _, _ = integrate(step, u, p, steps=20, dt=0.5, key=jax.random.key(0))
        if scored:  # each round graded by its drift since the check or round before it
            total += float(score(u[None], before[None])[0])
    np.testing.assert_allclose(states[0], np.asarray(u), rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(fitness[0], total / 2, rtol=1e-6)
    assert fitness[1] == -1.0  # 990 * a^2 c autocatalysis blows up: invalid, zeroed state
    assert (states[1] == 0).all()


@pytest.mark.slow
def test_invalid_individuals_leave_the_integration_early(monkeypatch):
    """Stage one of §3.3 on the way to t_start: the 990 a^2 c blow-ups are found invalid at the
    check after 20 steps and only the valid genomes (padded to 8) are integrated further;
    fitness and final states equal the evaluation without checks."""
    from morphogen.search.networks import evolve

    spec = table2_spec()
    g = table2_genome(spec)
    bad = g._replace(mantissa=g.mantissa.at[6].set(99), exponent=g.exponent.at[6].set(2))
    varied = [g._replace(mantissa=g.mantissa.at[7].set(m)) for m in range(1, 7)]
    pop = stack([x for pair in zip(varied, [bad] * 6, strict=True) for x in pair])
    u0 = initial_state(jax.random.key(1), spec, EV)
    batches = []
    advance = evolve._advance

    def counted(*key):
        fn = advance(*key)
        return lambda u, p: batches.append(u.shape[0]) or fn(u, p)

    monkeypatch.setattr(evolve, "_advance", counted)
    fitness, states = evaluate(pop, u0, spec, EV)
    assert batches == [12, 8, 8]  # 40 steps to t_start, cut at 20 for a check; one round
    full, full_states = evaluate(pop, u0, spec, EV, checks=0)
    assert (fitness[1::2] == -1.0).all() and (full[1::2] == -1.0).all()
    assert (fitness[2::2] > 0).all()  # (k8 mantissa 1 in genome 0 also blows up)
    np.testing.assert_allclose(fitness, full, rtol=1e-6)
    np.testing.assert_allclose(states[::2], full_states[::2], rtol=1e-5, atol=1e-6)


@pytest.mark.slow
def test_rates_run_resumes_bit_identically(tmp_path):
    spec = table2_spec()
    ops = Operators(mode="rates")
    ev = Evaluation(size=8, dt=0.5, t_start=5.0, interval=5.0, rounds=2)
    kw = dict(ops=ops, ev=ev, population=6, seed=3, log=lambda s: None)
    _, _, full = run(spec, table2_genome(spec), tmp_path / "a", generations=3, **kw)
    run(spec, table2_genome(spec), tmp_path / "b", generations=2, **kw)
    pop, _, resumed = run(spec, table2_genome(spec), tmp_path / "b", generations=3,
                          resume=True, **kw)
    np.testing.assert_array_equal(full, resumed)
    assert full.shape == (3, 6)
    assert (np.asarray(pop.educts) == np.asarray(table2_genome(spec).educts)).all()


@pytest.mark.slow
def test_cli_network_mode_runs_and_resumes(tmp_path, capsys):
    import json

    from morphogen.cli.main import main

    args = ["networks", "--mode", "network", "--out", str(tmp_path / "n"), "--population", "4",
            "--size", "8", "--dt", "0.5", "--t-start", "5", "--interval", "5", "--rounds", "2",
            "--quiet", "--archive", str(tmp_path / "index.sqlite")]
    assert main(args + ["--generations", "1"]) == 0
    assert main(args + ["--generations", "2"]) == 2  # the folder already holds a run
    assert "--resume" in capsys.readouterr().err
    assert main(args + ["--generations", "2", "--resume"]) == 0
    history = np.loadtxt(tmp_path / "n" / "history.csv", delimiter=",")
    assert history.shape == (2, 4)
    best = json.loads((tmp_path / "n" / "best.json").read_text())
    assert abs(best["fitness"] - history[-1].max()) < 1e-3
    assert sum(not r["static"] for r in best["reactions"]) >= 1
