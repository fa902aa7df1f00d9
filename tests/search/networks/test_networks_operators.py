"""Invariants of the network genetic operators (Yamamoto §3.2, §4.2)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search.networks.genome import (
    Genome,
    NetworkSpec,
    make_genome,
    rates,
    satisfied,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.operators import (
    Operators,
    crossover,
    duplicate,
    mutate,
    next_generation,
    random_population,
    tournament,
)

SPEC = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1), fixed_rates=(0.0, 0.0))
NET = Operators(mode="network")


def _template():
    return random_population(jax.random.key(0), make_genome(SPEC, [0.0] * 12), SPEC, 1, NET)


def _one(pop, i):
    return Genome(*(x[i] for x in pop))


@pytest.mark.slow
def test_many_generations_keep_constraints_and_statics():
    pop = random_population(jax.random.key(1), _one(_template(), 0), SPEC, 64, NET)
    ops = Operators(mode="network", p_mutate=1.0, p_mutate_reaction=0.5, p_duplicate=0.5)
    step = jax.jit(lambda k, p, f: next_generation(k, p, f, SPEC, ops))
    me, mp = SPEC.static_structure()
    grew = False
    for gen in range(30):
        fit = jnp.asarray(np.random.default_rng(gen).uniform(size=64))
        pop = step(jax.random.key(gen), pop, fit)
        assert bool(jnp.all(satisfied(pop, SPEC)))
        assert bool(jnp.all(pop.mantissa[:, :2] == 0))  # imposed inflow of A, B stays 0
        grew |= bool(jnp.any(pop.active.sum(1) > 7))
    assert grew  # duplication added reactions
    assert np.array_equal(np.asarray(pop.educts[:, :, :6]), np.broadcast_to(me[:, :6], (64, 3, 6)))


@pytest.mark.slow
def test_mutation_moves_fields_by_one():
    g = table2_genome(table2_spec())
    spec = table2_spec()
    ops = Operators(mode="rates", p_mutate_reaction=1.0)
    out = jax.jit(jax.vmap(lambda k: mutate(k, g, spec, ops)))(
        jax.random.split(jax.random.key(3), 200))
    dm = np.abs(np.asarray(out.mantissa) - np.asarray(g.mantissa))
    de = np.abs(np.asarray(out.exponent) - np.asarray(g.exponent))
    assert (dm <= 1).all() and (de <= 1).all()
    # exactly one field of each non-fixed reaction changed (unless clipped at a bound)
    assert ((dm + de) <= 1).all()
    assert (dm[:, [0, 1, 5]] == 0).all() and (de[:, [0, 1, 5]] == 0).all()
    assert np.array_equal(np.asarray(out.educts), np.broadcast_to(g.educts, out.educts.shape))


@pytest.mark.slow
def test_crossover_preserves_genes_per_slot():
    pop = random_population(jax.random.key(5), _one(_template(), 0), SPEC, 2, NET)
    a, b = _one(pop, 0), _one(pop, 1)
    cross = jax.jit(lambda k: crossover(k, a, b, SPEC, NET))
    for s in range(20):
        c, d = cross(jax.random.key(s))
        for x, y, cx, dx in zip(a, b, c, d, strict=True):
            x, y, cx, dx = map(np.asarray, (x, y, cx, dx))
            swapped = np.all(cx == y, axis=tuple(range(cx.ndim - 1)))
            kept = np.all(cx == x, axis=tuple(range(cx.ndim - 1)))
            assert (swapped | kept).all()
            np.testing.assert_array_equal(np.sort(np.stack([cx, dx]), 0),
                                          np.sort(np.stack([x, y]), 0))


def test_rates_crossover_keeps_structure():
    spec = table2_spec()
    g = table2_genome(spec)
    h = g._replace(mantissa=g.mantissa + 1)
    c, d = crossover(jax.random.key(0), g, h, spec, Operators(mode="rates"))
    assert np.array_equal(np.asarray(c.educts), np.asarray(g.educts))
    changed = int(jnp.sum(c.mantissa != g.mantissa))
    assert 1 <= changed < spec.m_max


def test_duplication_copies_a_reaction():
    g = _one(_template(), 0)
    d = duplicate(jax.random.key(0), g, SPEC)
    assert int(d.active.sum()) == int(g.active.sum()) + 1
    new = int(jnp.argmax(d.active & ~g.active))
    np.testing.assert_array_equal(np.asarray(d.educts[:, new]), np.asarray(g.educts[:, 6]))
    np.testing.assert_array_equal(np.asarray(d.products[:, new]), np.asarray(g.products[:, 6]))
    assert int(d.mantissa[new]) == int(g.mantissa[6])


@pytest.mark.slow
def test_tournament_size_two_probabilities():
    # with fitness ranks 0 < 1 < 2, P(winner = i) = ((i+1)^2 - i^2) / 9 for size 2
    w = np.asarray(tournament(jax.random.key(0), jnp.asarray([0.0, 1.0, 2.0]), 90000, 2))
    freq = np.bincount(w, minlength=3) / w.size
    np.testing.assert_allclose(freq, [1 / 9, 3 / 9, 5 / 9], atol=0.01)
    # NaN loses every tournament it is in: it wins only when drawn twice, P = 1/4
    w = np.asarray(tournament(jax.random.key(1), jnp.asarray([jnp.nan, 0.0]), 40000, 2))
    assert abs(np.mean(w == 0) - 0.25) < 0.01


@pytest.mark.slow
def test_initial_network_population_has_one_evolvable_reaction():
    pop = random_population(jax.random.key(2), _one(_template(), 0), SPEC, 50, NET)
    assert (np.asarray(pop.active).sum(1) == 7).all()
    assert bool(jnp.all(satisfied(pop, SPEC)))


def test_bad_operator_settings():
    with pytest.raises(MorphogenError, match="mode"):
        Operators(mode="nets")
    with pytest.raises(MorphogenError, match="p_crossover"):
        Operators(p_crossover=1.5)


def test_rates_drawn_within_a_decade_of_table_2():
    spec = table2_spec()
    template = table2_genome(spec)
    key = jax.random.key(4)
    near = random_population(key, template, spec, 2000, Operators(mode="rates", draw="decade"))
    wide = random_population(key, template, spec, 2000, Operators(mode="rates"))
    k_t = np.asarray(rates(template), np.float64)
    k = np.asarray(rates(near), np.float64)
    free = ~np.asarray(spec.fixed_mask)
    fixed = ~free
    np.testing.assert_array_equal(k[:, fixed], np.broadcast_to(k_t[fixed], k[:, fixed].shape))
    ratio = np.log10(k[:, free] / k_t[free])
    # k_t · 10^U(-1, 1), rounded down to two significant digits: within [-1, 1), about half
    # below the hand-made rate, about a quarter in each outer half-decade
    assert ratio.min() >= -1.0 - 1e-6 and ratio.max() < 1.0
    assert abs(float(np.mean(ratio < 0)) - 0.5) < 0.03
    assert abs(float(np.mean(ratio > 0.5)) - 0.25) < 0.03
    # the default draw spans nine decades, from 1e-6 to 99 * 10
    w = np.asarray(rates(wide), np.float64)[:, free]
    assert w.min() < 1e-5 and w.max() > 100.0
    assert float(np.mean(np.abs(np.log10(w / k_t[free])) < 1.0)) < 0.3
    with pytest.raises(MorphogenError, match="rate draw"):
        Operators(draw="normal")
