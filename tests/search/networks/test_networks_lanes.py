"""The population kernel with the member axis innermost equals the padded runtime-structure step
to float32 rounding (Yamamoto eqs. 2-3, explicit Euler, periodic 5-point Laplacian)."""

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import integrate
from morphogen.search.networks.genome import NetworkSpec, make_genome, stack
from morphogen.search.networks.lanes import advance_population, compact
from morphogen.search.networks.operators import Operators, next_generation, random_population
from morphogen.search.networks.reaction import genome_params, padded_model
from morphogen.solvers.step import make_step

SPEC = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1), fixed_rates=(0.0, 0.0))


def _reference(u, params, steps, dt):
    step = make_step(padded_model(SPEC), Grid(u.shape[2:]))
    run = jax.vmap(lambda x, p: integrate(step, x, p, steps=steps, dt=dt,
                                          key=jax.random.key(0))[0])
    return np.asarray(run(u, params))


def test_compact_puts_used_slots_first_in_order():
    # evolvable slots 6..11: member 0 uses slots 7 and 10 (rate 0 in slot 9 counts as unused)
    k = [0, 0, 0.1, 0.01, 0.02, 0.03, 0, 0, 0, 0, 0, 0]
    me = np.zeros((3, 5), int)
    mp = np.zeros((3, 5), int)
    me[:, 1], mp[:, 1] = [2, 0, 1], [3, 0, 1]   # slot 7: 2A + C -> 3A + C
    me[:, 3], mp[:, 3] = [0, 3, 0], [1, 0, 0]   # slot 9, rate 0
    me[:, 4], mp[:, 4] = [0, 1, 1], [0, 1, 0]   # slot 10: B + C -> B
    k[7], k[10] = 0.5, 0.25
    g = make_genome(SPEC, k, me, mp)
    arrays, e_max = compact(genome_params(stack([g]), SPEC), SPEC)
    assert e_max == 2
    np.testing.assert_allclose(arrays["k"][:, 0], [0.5, 0.25])
    np.testing.assert_array_equal(arrays["e"][:, :, 0], [[2, 0, 1], [0, 1, 1]])
    np.testing.assert_array_equal(arrays["nu"][:, :, 0], [[1, 0, 0], [0, 0, -1]])
    np.testing.assert_allclose(arrays["rho"][:, 0], [0, 0, 0.1], rtol=1e-6)
    np.testing.assert_allclose(arrays["mu"][:, 0], [0.01, 0.02, 0.03], rtol=1e-6)


def test_kernel_matches_the_padded_step_on_random_networks():
    key = jax.random.key(4)
    ops = Operators(mode="network", p_duplicate=0.5)
    pop = random_population(key, make_genome(SPEC, [0.0] * 12), SPEC, 13, ops)
    breed = jax.jit(lambda k, p, f: next_generation(k, p, f, SPEC, ops))
    for gen in range(4):  # a few generations grow more evolvable reactions
        pop = breed(jax.random.fold_in(key, gen), pop, jnp.arange(13.0))
    # moderate rates so that 30 steps stay finite: k < 0.1
    pop = pop._replace(exponent=jnp.clip(pop.exponent, -4, -2))
    params = genome_params(pop, SPEC)
    assert compact(params, SPEC)[1] >= 2
    u = jnp.asarray(np.random.default_rng(0).uniform(0.2, 1.8, (13, 3, 10, 12)), jnp.float32)
    got = np.asarray(advance_population(u, params, SPEC, 30, 0.1))
    want = _reference(u, params, 30, 0.1)
    assert got.shape == (13, 3, 10, 12) and np.isfinite(want).all()
    np.testing.assert_allclose(got, want, rtol=2e-5, atol=1e-6)


def test_cubes_and_every_exponent_are_exact():
    # 3A -> 3A + B (k = 0.5), A + C -> A + C (0.25, no net change), 2A -> 2A + C (0.25) on a
    # flat field (no diffusion) at A = B = C = 2, one step of dt = 1
    me = np.array([[3, 1, 2], [0, 0, 0], [0, 1, 0]])
    mp = np.array([[3, 1, 2], [1, 0, 0], [0, 1, 1]])
    g = make_genome(SPEC, [0, 0, 0, 0, 0, 0, 0.5, 0.25, 0.25, 0, 0, 0], me, mp)
    u = jnp.full((1, 3, 4, 4), 2.0, jnp.float32)
    got = np.asarray(advance_population(u, genome_params(stack([g]), SPEC), SPEC, 1, 1.0))
    # dB = 0.5 · 2³ = 4, dC = 0.25 · 2² = 1; A and C as catalysts unchanged by slot 7
    np.testing.assert_allclose(got[0], np.broadcast_to(np.array([2.0, 6.0, 3.0])[:, None, None],
                                                       (3, 4, 4)), rtol=1e-6)
