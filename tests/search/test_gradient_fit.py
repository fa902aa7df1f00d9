"""Gradient fitting of classic models through the simulator (morphogen.search.gradient)."""

from __future__ import annotations

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.engine.simulate import integrate
from morphogen.errors import MorphogenError
from morphogen.render import write_png
from morphogen.runs.config import RunConfig
from morphogen.runs.execute import run_prepared
from morphogen.runs.prepare import prepare
from morphogen.search.archive import Archive
from morphogen.search.evaluate import Problem
from morphogen.search.executors import make_executor
from morphogen.search.genes import Gene
from morphogen.search.gradient import GradientAscent, GradientEvaluator, field_image, fit
from morphogen.search.run import evolve, start
from morphogen.search.strategy import Strategy
from morphogen.solvers.step import make_step

F_TRUE, K_TRUE = 0.037, 0.06
SIZE, STEPS = 64, 400


@pytest.fixture(scope="module")
def gray_scott_target(tmp_path_factory) -> str:
    """Gray-Scott's own pattern at (F, k) = (0.037, 0.06): 400 steps from seeded blobs."""
    cfg = RunConfig(model="gray-scott", size=[SIZE, SIZE], steps=STEPS, dt=1.0, init="blobs",
                    seed=0, params={"F": F_TRUE, "k": K_TRUE})
    v = run_prepared(prepare(cfg)).state[1]
    grey = ((v - v.min()) / (v.max() - v.min()) * 255).astype(np.uint8)
    return str(write_png(tmp_path_factory.mktemp("gs") / "target.png", grey))


def problem(target: str, f_range=(0.032, 0.056), k_range=(0.056, 0.068)) -> Problem:
    genes = (Gene("F", *f_range, 0.1 * (f_range[1] - f_range[0])),
             Gene("k", *k_range, 0.1 * (k_range[1] - k_range[0])))
    return Problem(model="gray-scott", genes=genes, size=(SIZE, SIZE), dt=1.0, steps=STEPS,
                   init="blobs", seed=0, fitness="target", target=target)


@pytest.mark.slow
def test_gradient_fitting_recovers_gray_scott_f_and_k(gray_scott_target):
    """Start at the centre of the gene box, F 19 % and k 3 % too high; Adam on the fitness
    gradient finds both within 10 % (the loss valley runs along the F-k ridge of similar
    patterns, so F is the harder one)."""
    prob = problem(gray_scott_target)
    evaluate = GradientEvaluator(prob)
    strategy = GradientAscent(population_size=2, learning_rate=0.03, start="centre")
    assert isinstance(strategy, Strategy)
    result = fit(evaluate, strategy, prob.genes, iterations=40)
    start = result.genomes[0, 0]
    assert abs(start[0] / F_TRUE - 1) > 0.15
    assert result.best_fitness > 5 * result.fitness[0].max()  # loss down at least 5x
    f, k = result.best_genome
    assert abs(f / F_TRUE - 1) < 0.1, f
    assert abs(k / K_TRUE - 1) < 0.1, k


@pytest.mark.slow
def test_evaluator_gradient_equals_a_plain_scan(gray_scott_target):
    """The chunk-rematerialised, vmapped evaluator gives the gradient that jax.grad gives
    through a plain lax.scan of the same steps (morphogen.engine.simulate.integrate).

    (A finite difference is no reference here: the texture loss of a pattern is piecewise
    smooth with kinks finer than any usable step, so central differences of it depend on the
    step size.)
    """
    prob = problem(gray_scott_target)
    evaluate = GradientEvaluator(prob)
    genomes = np.array([[0.040, 0.061]], np.float32)
    _, metrics = evaluate(genomes, jax.random.PRNGKey(0))

    base = evaluate.base
    step = make_step(base.model, base.domain)
    u0 = jnp.asarray(base.initial_states(genomes)[0])
    fixed = {k: jnp.asarray(v[0]) for k, v in base.population_params(genomes).items()}

    def loss(genome):
        p = {**fixed, "F": genome[0], "k": genome[1]}
        u, _, _ = integrate(step, u0, p, steps=STEPS, dt=1.0, key=jax.random.PRNGKey(0))
        return evaluate.loss(field_image(u[base.display])[None])[0]

    for genome, gradient in zip(genomes, metrics["gradient"], strict=True):
        reference = -np.asarray(jax.jit(jax.grad(loss))(jnp.asarray(genome)))
        assert np.abs(reference).max() > 0.1
        np.testing.assert_allclose(gradient, reference, rtol=1e-3, atol=1e-3)


def test_field_image_is_standardised_and_scale_free():
    rng = np.random.default_rng(0)
    f = rng.normal(3.0, 2.0, (16, 16)).astype(np.float32)
    a = np.asarray(field_image(f))
    b = np.asarray(field_image(10 * f - 4))
    assert a.shape == (16, 16, 3)
    np.testing.assert_allclose(a[..., 0].mean(), 0.5, atol=1e-5)
    np.testing.assert_allclose(a[..., 0].std(), 0.2, rtol=1e-4)
    np.testing.assert_allclose(a, b, atol=1e-5)


def test_gradient_strategy_needs_a_gradient_and_keeps_bounds():
    genes = [Gene("F", 0.0, 1.0, 0.1), Gene("k", 0.0, 2.0, 0.1)]
    strategy = GradientAscent(population_size=3, learning_rate=0.5)
    state = strategy.init(jax.random.PRNGKey(0), genes)
    genomes, state = strategy.ask(jax.random.PRNGKey(1), state)
    fitness = np.zeros(3, np.float32)
    with pytest.raises(MorphogenError, match="gradient"):
        strategy.tell(genomes, fitness, state)
    push = np.array([[1.0, -1.0]] * 3, np.float32)
    for _ in range(10):
        genomes, state = strategy.ask(jax.random.PRNGKey(1), state)
        state, _ = strategy.tell(genomes, fitness, state, gradient=push)
    genomes, _ = strategy.ask(jax.random.PRNGKey(1), state)
    np.testing.assert_allclose(np.asarray(genomes), [[1.0, 0.0]] * 3)
    with pytest.raises(MorphogenError, match="start"):
        GradientAscent(population_size=2, start="nowhere")


def test_evolve_runs_the_gradient_strategy_and_records_it(gray_scott_target, tmp_path):
    """``evolve --strategy gradient``: the generation loop passes the executor's fitness
    gradient to the strategy, the archive records each generation, and the loss falls."""
    prob = problem(gray_scott_target)
    archive = Archive(tmp_path / "index.sqlite")
    spec = {"name": "gradient", "population": 2, "learning_rate": 0.03, "start": "centre"}
    run_id, out = start(prob, spec, generations=6, archive=archive)
    executor = make_executor("local", prob, gradient=True)
    result = evolve(run_id, archive, executor, log=lambda s: None)
    loss = -np.array([g["best"] for g in archive.generations(run_id)])
    assert loss.shape == (6,)
    assert loss[-1] < loss[0] / 1.5
    assert result.best_fitness == pytest.approx(-loss.min())
    assert (out / "best").is_dir()


def test_gradient_strategy_refuses_runs_it_cannot_do(gray_scott_target, tmp_path):
    prob = problem(gray_scott_target)
    archive = Archive(tmp_path / "index.sqlite")
    with pytest.raises(MorphogenError, match="fitness target"):
        start(replace(prob, fitness="dirichlet", target=None),
              {"name": "gradient", "population": 2}, generations=1, archive=archive)
    with pytest.raises(MorphogenError, match="executor local"):
        make_executor("ray", prob, gradient=True)
    assert archive.runs() == []
