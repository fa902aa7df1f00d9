"""Padded network genomes against the fixed-structure mass-action model (Yamamoto eqs. 2-3)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.models.network import mass_action
from morphogen.search.networks.genome import (
    NetworkSpec,
    encode_rates,
    make_genome,
    rates,
    satisfied,
    stack,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.reaction import genome_params, integer_power, padded_reaction


def _fixed_model_of(genome, spec):
    """The same network through models/network.py (active slots only)."""
    active = np.asarray(genome.active)
    me = np.asarray(genome.educts)[:, active]
    mp = np.asarray(genome.products)[:, active]
    k = np.asarray(rates(genome))[active]
    return mass_action("ref", spec.species, me, mp, list(k), list(spec.diffusion))


def test_rates_encode_two_digits():
    mant, ex = encode_rates([0.0, 0.094, 0.3, 1.0, 6.2, 990.0])
    assert mant.tolist() == [0, 94, 30, 10, 62, 99]
    assert ex.tolist() == [-6, -2, -1, 0, 0, 2]


def test_table2_genome_rates_and_structure():
    spec = table2_spec()
    g = table2_genome(spec)
    np.testing.assert_allclose(np.asarray(rates(g)),
                               [0, 0, 0.1, 0.01, 0.02, 0, 0.01, 0.1, 0.02], rtol=1e-6)
    assert bool(satisfied(g, spec))
    # slot 6 is 2A + C -> 3A + C
    assert np.asarray(g.educts)[:, 6].tolist() == [2, 0, 1]
    assert np.asarray(g.products)[:, 6].tolist() == [3, 0, 1]


@pytest.mark.slow
def test_padded_equals_fixed_structure_model():
    spec = table2_spec()
    g = table2_genome(spec)
    model = _fixed_model_of(g, spec)
    u = jnp.asarray(np.random.default_rng(0).uniform(0.1, 3.0, (3, 8, 8)), jnp.float32)
    ref = model.reaction(u, model.parameters(), {})
    p = genome_params(g, spec)
    got = padded_reaction(u, p["k"], p["Me"], p["Mp"])
    np.testing.assert_allclose(np.asarray(got), np.asarray(ref), rtol=1e-5, atol=1e-7)
    # hand-computed at a = 2, b = 1, c = 1: da = 0.01*4 - 0.01*2, db = 0.02*4 - 0.02,
    # dc = 0.1 - 0.1*1*1
    one = jnp.asarray([2.0, 1.0, 1.0]).reshape(3, 1, 1)
    np.testing.assert_allclose(np.asarray(padded_reaction(one, p["k"], p["Me"], p["Mp"]))[:, 0, 0],
                               [0.02, 0.06, 0.0], atol=1e-7)


def test_two_topologies_in_one_batch_no_retrace():
    spec = NetworkSpec(("A", "B"), 6, (0.1, 0.1))
    # topology 1: A + B -> 2B (k=0.5); topology 2: 2A -> B (k=2), plus static inflow/decay
    g1 = make_genome(spec, [1.0, 0.0, 0.1, 0.2, 0.5, 0.0], [[1], [1]], [[0], [2]])
    g2 = make_genome(spec, [0.0, 1.0, 0.3, 0.0, 2.0, 7.0], [[2], [0]], [[0], [1]])
    pop = stack([g1, g2])
    traces = []

    @jax.jit
    def batch(u, p):
        traces.append(1)
        return jax.vmap(padded_reaction)(u, p["k"], p["Me"], p["Mp"])

    u = jnp.asarray([[[1.0]], [[2.0]]])  # a = 1, b = 2
    u = jnp.stack([u, u])
    out = np.asarray(batch(u, genome_params(pop, spec)))[:, :, 0, 0]
    # g1: da = 1 - 0.1 - 0.5*1*2 = -0.1; db = 0 - 0.2*2 + 0.5*2 = 0.6
    # g2: da = 0 - 0.3*1 - 2*2*1 = -4.3; db = 1 - 0 + 2*1 = 3 (slot 5 inactive: k=7 ignored)
    np.testing.assert_allclose(out, [[-0.1, 0.6], [-4.3, 3.0]], rtol=1e-6)
    g3 = make_genome(spec, [0.0, 0.0, 0.0, 0.0, 1.0, 1.0], [[0, 1], [1, 0]], [[3, 0], [0, 0]])
    batch(u, genome_params(stack([g3, g1]), spec))
    assert len(traces) == 1


def test_integer_power_exact():
    s = jnp.asarray([-2.0, 0.0, 1.5])
    for e in range(4):
        np.testing.assert_allclose(np.asarray(integer_power(s, jnp.int32(e))),
                                   np.asarray(s) ** e)


def test_bad_genomes_refused():
    spec = NetworkSpec(("A", "B"), 6, (0.1, 0.1))
    with pytest.raises(MorphogenError, match="coefficient above 3"):
        make_genome(spec, [0.0] * 6, [[4], [0]], [[0], [0]])
    with pytest.raises(MorphogenError, match="more than 4"):
        make_genome(spec, [0.0] * 6, [[3], [2]], [[0], [0]])
    with pytest.raises(MorphogenError, match="m_max"):
        NetworkSpec(("A", "B"), 3, (0.1, 0.1))
    with pytest.raises(MorphogenError, match="do not fit"):
        make_genome(spec, [0.0] * 6, [[1, 1, 1], [0, 0, 0]], [[0, 0, 0], [0, 0, 0]])
