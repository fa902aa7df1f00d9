"""Search strategies: GA operators against their defining probabilities, CMA-ES convergence,
the shared ask/tell contract (bounds, NaN -> worst, best so far, pure/scannable state)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search.cmaes import CMAES
from morphogen.search.ga import GeneticAlgorithm, proportions
from morphogen.search.genes import Gene, preset_genes, skaggs_gene
from morphogen.search.strategy import state_from_arrays, state_to_arrays

KEY = jax.random.PRNGKey(0)
N = 3000
"""One large population per ask gives the statistics; every GA test below shares its shape
(N individuals, 2 genes), so the GA compiles once; bounds and sigma are state, not shape."""
GA = GeneticAlgorithm(N)


def two_genes(low=-100.0, high=100.0, sigma=(0.0, 0.0)):
    return [Gene("a", low, high, sigma[0]), Gene("b", low, high, sigma[1])]


def children(strategy, genes, parents, fitness):
    """One generation bred from ``parents`` ``(N, 2)`` with the given fitness ``(N,)``."""
    state = strategy.init(KEY, genes)
    _, state = strategy.ask(KEY, state)
    state, _ = strategy.tell(jnp.asarray(parents, jnp.float32),
                             jnp.asarray(fitness, jnp.float32), state)
    kids, _ = strategy.ask(jax.random.PRNGKey(7), state)
    return np.asarray(kids)


def sampling_tolerance(n):
    """Four standard errors of a frequency near 1/2 estimated from ``n`` draws."""
    return 4 * np.sqrt(0.25 / n)


def test_first_generation_is_uniform_in_the_ranges():
    genes = [Gene("a", 0.02, 0.08, 0.01), Gene("b", -3.0, 5.0, 0.1)]
    pop, _ = GA.ask(KEY, GA.init(KEY, genes))
    pop = np.asarray(pop)
    for j, g in enumerate(genes):
        assert pop[:, j].min() >= g.low and pop[:, j].max() <= g.high
        # mean and variance of U(low, high), within 4 standard errors
        assert abs(pop[:, j].mean() - (g.low + g.high) / 2) < 4 * g.width / np.sqrt(12 * N)
        assert pop[:, j].var() == pytest.approx(g.width**2 / 12, rel=0.08)


def test_proportionate_selection_follows_eq_3_10():
    # no mutation: each child's gene is one of its two parents' values, and each parent is
    # drawn with p_i = f_i / sum f (NaN, -inf and negative fitness count as 0)
    group = np.arange(N) % 6
    fitness = np.array([1.0, 3.0, 0.0, 6.0, np.nan, -2.0])[group]
    kids = children(GA, two_genes(), np.stack([group, group], 1), fitness)
    freq = np.bincount(kids[:, 0].astype(int), minlength=6) / N
    p = np.array([0.1, 0.3, 0.0, 0.6, 0.0, 0.0])
    np.testing.assert_allclose(freq, p, atol=sampling_tolerance(N))
    np.testing.assert_allclose(proportions(jnp.asarray(fitness[:6])), p, rtol=1e-6)


def test_zero_total_fitness_selects_uniformly():
    np.testing.assert_allclose(proportions(jnp.array([0.0, -1.0, jnp.nan, 0.0])), 0.25)


def test_tournament_selection_probabilities():
    # the fittest of k uniform draws lands in the r-th best of 5 equal groups with
    # probability ((6 - r)/5)^k - ((5 - r)/5)^k
    k = 3
    group = np.arange(N) % 5
    rank = np.array([3, 5, 1, 4, 2])
    fitness = (6 - rank)[group].astype(float)
    kids = children(GeneticAlgorithm(N, tournament=k), two_genes(), np.stack([group] * 2, 1),
                    fitness)
    freq = np.bincount(kids[:, 0].astype(int), minlength=5) / N
    p = ((6.0 - rank) / 5) ** k - ((5.0 - rank) / 5) ** k
    np.testing.assert_allclose(freq, p, atol=sampling_tolerance(N))


def test_uniform_crossover_takes_each_gene_from_either_parent():
    # half the population is (-1, -1), half (1, 1), all equally fit: two parents differ with
    # probability 1/2, and then the two genes come from different parents with probability 1/2
    side = np.where(np.arange(N) % 2 == 0, -1.0, 1.0)
    kids = children(GA, two_genes(), np.stack([side, side], 1), np.ones(N))
    assert set(np.unique(kids)) <= {-1.0, 1.0}
    mixed = kids[:, 0] != kids[:, 1]
    assert mixed.mean() == pytest.approx(0.25, abs=sampling_tolerance(N))
    assert (kids == 1.0).mean() == pytest.approx(0.5, abs=sampling_tolerance(N))


def test_gaussian_mutation_eq_3_5_once_per_gene():
    centre = np.array([1.0, 50.0])
    kids = children(GA, two_genes(sigma=(0.3, 2.0)), np.tile(centre, (N, 1)), np.ones(N))
    delta = kids - centre
    assert np.all(delta != 0)  # every gene of every child is mutated
    np.testing.assert_allclose(delta.std(axis=0), [0.3, 2.0], rtol=0.05)
    assert np.all(np.abs(delta.mean(axis=0)) < 4 * np.array([0.3, 2.0]) / np.sqrt(N))


def test_children_are_clipped_to_the_bounds():
    # mutation far wider than the range [0.02, 0.08]: almost every child lands on a bound
    kids = children(GA, two_genes(0.02, 0.08, (1.0, 1.0)), np.full((N, 2), 0.05), np.ones(N))
    assert kids.min() == np.float32(0.02) and kids.max() == np.float32(0.08)
    assert ((kids == np.float32(0.02)) | (kids == np.float32(0.08))).mean() > 0.9


def test_elitism_keeps_the_best_unchanged():
    rng = np.random.default_rng(1)
    pop = rng.uniform(0, 1, (N, 2)).astype(np.float32)
    fitness = rng.uniform(0, 0.5, N)
    fitness[[17, 5]] = [0.95, 0.9]
    kids = children(GeneticAlgorithm(N, elitism=2), two_genes(sigma=(0.2, 0.2)), pop, fitness)
    np.testing.assert_array_equal(kids[:2], pop[[17, 5]])
    assert not np.any(np.all(kids[2:, None] == pop[None, [17, 5]], axis=-1))


def test_nan_fitness_is_worst_and_best_so_far_is_kept():
    genes = [Gene("a", 0.0, 1.0, 0.1)]
    ga = GeneticAlgorithm(3)
    state = ga.init(KEY, genes)
    g1 = jnp.array([[0.1], [0.2], [0.3]])
    state, m = ga.tell(g1, jnp.array([jnp.nan, 0.5, 0.2]), state)
    assert float(m["best_fitness"]) == 0.5 and float(m["best_genome"][0]) == pytest.approx(0.2)
    state, m = ga.tell(g1 + 0.5, jnp.array([0.1, jnp.nan, 0.3]), state)
    assert float(m["best_fitness"]) == 0.5 and float(m["generation_best"]) == pytest.approx(0.3)
    assert int(m["generation"]) == 2
    state, m = ga.tell(g1, jnp.array([jnp.nan] * 3), state)
    assert float(m["generation_best"]) == -np.inf and float(m["best_fitness"]) == 0.5


def test_whole_loop_runs_in_lax_scan_and_matches_the_python_loop():
    genes = two_genes(-2.0, 2.0, (0.2, 0.2))
    ga = GA

    def fitness(x):
        return jnp.exp(-jnp.sum((x - jnp.array([0.5, -1.0])) ** 2, axis=1))

    def body(state, key):
        x, state = ga.ask(key, state)
        state, m = ga.tell(x, fitness(x), state)
        return state, m["best_fitness"]

    keys = jax.random.split(KEY, 8)
    final, curve = jax.lax.scan(body, ga.init(KEY, genes), keys)
    state = ga.init(KEY, genes)
    for k in keys:
        state, _ = body(state, k)
    np.testing.assert_allclose(np.asarray(final.best_genome), np.asarray(state.best_genome),
                               rtol=1e-6)  # scanned vs step-by-step: two programs
    assert np.all(np.diff(np.asarray(curve)) >= 0)  # best so far never decreases
    assert float(curve[-1]) > 0.97


ES = CMAES(12)
"""CMA-ES tests share 12 samples of 3 genes, so it compiles once."""
ES_GENES = [Gene("F", 0.0, 0.1, 0.0), Gene("k", 0.0, 100.0, 0.0), Gene("c", -1.0, 1.0, 0.0)]


def test_cmaes_finds_the_optimum_without_per_gene_rates():
    # ranges differing by 4 orders of magnitude; sigma values are ignored by CMA-ES
    target = jnp.array([0.03, 71.0, -0.4])
    scale = jnp.array([0.1, 100.0, 2.0])
    es = ES
    state = es.init(KEY, ES_GENES)
    for g in range(50):
        x, state = es.ask(jax.random.fold_in(KEY, g), state)
        assert np.all(np.asarray(x) >= np.asarray([0, 0, -1]) - 1e-7)
        assert np.all(np.asarray(x) <= np.asarray([0.1, 100, 1]) + 1e-7)
        state, m = es.tell(x, -jnp.sum(((x - target) / scale) ** 2, axis=1), state)
    np.testing.assert_allclose(np.asarray(m["best_genome"]), target, rtol=1e-3, atol=1e-4)


def test_cmaes_treats_nan_as_worst():
    genes = [Gene(g, 0.0, 1.0, 0.0) for g in "abc"]
    state = ES.init(KEY, genes)
    for g in range(40):
        x, state = ES.ask(jax.random.fold_in(KEY, g), state)
        f = -jnp.sum((x - 0.8) ** 2, axis=1)
        f = jnp.where(x[:, 0] < 0.5, jnp.nan, f)  # failed evaluations in half the space
        state, m = ES.tell(x, f, state)
    np.testing.assert_allclose(np.asarray(m["best_genome"]), [0.8, 0.8, 0.8], atol=0.03)


@pytest.mark.parametrize(("strategy", "genes"), [(GA, two_genes(sigma=(0.3, 0.3))), (ES, ES_GENES)])
def test_saved_state_resumes_identically(strategy, genes):
    state = strategy.init(KEY, genes)
    for g in range(3):
        x, state = strategy.ask(jax.random.fold_in(KEY, g), state)
        state, _ = strategy.tell(x, jnp.sum(x, axis=1), state)
    restored = state_from_arrays(strategy.init(KEY, genes), state_to_arrays(state))
    a, _ = strategy.ask(jax.random.fold_in(KEY, 9), state)
    b, _ = strategy.ask(jax.random.fold_in(KEY, 9), restored)
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_skaggs_rates_are_read_in_units_of_the_range():
    g = skaggs_gene("k", 0.04, 0.06, 0.05)
    assert g.sigma == pytest.approx(np.sqrt(0.05) * 0.02)
    assert [x.name for x in preset_genes("gierer-meinhardt")] == ["rho", "mu", "nu", "kappa"]
    assert len(preset_genes("genrd", ["alpha_u1_00", "beta_v3_22", "Du"])) == 2


@pytest.mark.parametrize("spec", ["F", "F=0.1", "F=a:b", "F=0.2:0.1", "F=0:1:-1", "=0:1"])
def test_bad_gene_specs_are_one_line_errors(spec):
    with pytest.raises(MorphogenError) as err:
        Gene.parse(spec)
    assert "\n" not in str(err.value)


def test_gene_parse_default_sigma():
    assert Gene.parse("F=0.02:0.08") == Gene("F", 0.02, 0.08, 0.1 * (0.08 - 0.02))
    assert Gene.parse("k=0:1:0.3").sigma == 0.3


def test_bad_strategy_settings():
    with pytest.raises(MorphogenError):
        GeneticAlgorithm(1)
    with pytest.raises(MorphogenError):
        GeneticAlgorithm(5, elitism=5)
    with pytest.raises(MorphogenError):
        GeneticAlgorithm(5, tournament=1)
    with pytest.raises(MorphogenError):
        CMAES(5, sigma_init=0.0)
