"""The cluster-head fitness rewards spots, not noise, and the evaluation starts near each
network's homogeneous state (Yamamoto §3.1, §3.3, §4; hand-built states)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search.networks.cluster import cell_fitness, cluster_head_fitness, peaks
from morphogen.search.networks.evolve import (
    Evaluation,
    evaluate,
    fixed_states,
    homogeneous_states,
    initial_state,
    starts,
)
from morphogen.search.networks.genome import make_genome, stack, table2_genome, table2_spec
from morphogen.search.networks.reaction import genome_params


def _noise(size=32, seed=0):
    """A nearly flat activator: 5 ± 0.5, every noise maximum above a_peak = 3."""
    rng = np.random.default_rng(seed)
    u = np.ones((3, size, size), np.float32)
    u[0] = 5.0 + 0.5 * rng.uniform(-1.0, 1.0, (size, size))
    return u


def test_flat_field_with_noise_scores_as_dead():
    u = _noise()
    literal = np.asarray(peaks(jnp.asarray(u[0]))).sum()
    assert literal > 50  # the seed's words alone: a local maximum above 3 is a peak
    assert not np.asarray(peaks(jnp.asarray(u[0]), prominence=0.5)).any()
    f = cluster_head_fitness()(jnp.asarray(u[None]))
    assert float(f[0]) == 1024 * 0.25  # every cell dead
    assert float(cluster_head_fitness(prominence=0.0)(jnp.asarray(u[None]))[0]) > 900


def test_a_real_spot_on_noise_is_one_peak():
    # a spot of 20 on the noise: its radius-6 disc (113 cells) averages about 5.1 < 20 / 2;
    # one isolated peak 0.75, 112 alive cells, 911 dead: 340.5 (as on a zero background)
    u = _noise()
    u[0, 5, 5] = 20.0
    assert float(cluster_head_fitness()(jnp.asarray(u[None]))[0]) == 340.5


def test_prominence_is_half_the_peak_over_its_disc_mean():
    # on 8x8 with d_max = 1.5 the disc is the 3x3 block: a peak p over a background b has
    # mean (p + 8b) / 9, and p - mean >= p / 2 exactly when p >= 16 b / 7
    u = np.zeros((3, 8, 8), np.float32)
    u[0] = 2.0
    for p, is_peak in ((4.6, True), (4.5, False)):  # 16 * 2 / 7 = 4.571...
        u[0, 3, 3] = p
        got = np.asarray(peaks(jnp.asarray(u[0]), 3.0, prominence=0.5, d_max=1.5))
        assert bool(got[3, 3]) is is_peak and got.sum() == int(is_peak)


def test_negative_concentrations_are_invalid_for_a_network():
    u = np.zeros((3, 32, 32), np.float32)
    u[0, 5, 5] = 5.0
    u[2, 9, 9] = -1e-3
    network = cluster_head_fitness(nonnegative=True)(jnp.asarray(u[None]))
    assert float(network[0]) == -1.0
    # per cell: the alive cell (9, 9) (distance √32 < 6 from the peak) is now invalid: 1 -> 0
    assert float(jnp.sum(cell_fitness(jnp.asarray(u), nonnegative=True))) == 340.5 - 1.0
    assert float(cluster_head_fitness()(jnp.asarray(u[None]))[0]) == 340.5  # not a network


@pytest.mark.slow
def test_hand_made_spots_keep_their_score():
    """The Table-2 network's spots (t = 2000 on 32², Δt = 0.1) score the same with and without
    the prominence test: every one of its peaks is a real peak."""
    spec = table2_spec()
    ev = Evaluation(t_start=2000.0, rounds=1)
    u0 = initial_state(jax.random.key(0), spec, ev)
    fitness, states = evaluate(stack([table2_genome(spec)]), u0, spec, ev)
    literal = cluster_head_fitness(prominence=0.0)(jnp.asarray(states))
    assert fitness[0] > 990 and fitness[0] == float(literal[0])
    assert np.asarray(peaks(jnp.asarray(states[0, 0]), prominence=0.5)).sum() >= 10


def test_steady_start_is_the_homogeneous_state_times_noise():
    spec = table2_spec()
    # Table 2 by hand: A* = k1 rho_c mu_b / (k2 k3 mu_a) = 1, B* = k3 A*^2 / mu_b = 1,
    # C* = rho_c / (k2 B*) = 1; Fig. 4's rates: A* = 6.816, B* = 4.414, C* = 0.02341
    me = np.array([[2, 0, 2], [0, 1, 0], [1, 1, 0]])
    mp = np.array([[3, 0, 2], [0, 1, 1], [1, 0, 0]])
    fig4 = make_genome(spec, [0, 0, 0.031, 0.015, 0.02, 0, 0.094, 0.3, 0.0019], me, mp)
    params = genome_params(stack([table2_genome(spec), fig4]), spec)
    ev = Evaluation(size=8, init="steady", init_noise=0.1)
    s = np.asarray(homogeneous_states(params, spec, ev))
    a = 0.094 * 0.031 * 0.02 / (0.3 * 0.0019 * 0.015)
    np.testing.assert_allclose(s, [[1, 1, 1], [a, 0.0019 * a * a / 0.02,
                                               0.031 / (0.3 * 0.0019 * a * a / 0.02)]],
                               rtol=2e-4)
    u0 = initial_state(jax.random.key(1), spec, ev)
    assert u0.shape == (3, 8, 8) and 0.9 <= float(u0.min()) and float(u0.max()) < 1.1
    u = np.asarray(starts(u0, params, spec, ev))
    np.testing.assert_allclose(u, s[:, :, None, None] * np.asarray(u0)[None], rtol=1e-6)
    with pytest.raises(MorphogenError, match="initial condition"):
        Evaluation(init="ramp")


def test_a_network_whose_well_mixed_state_blows_up_starts_invalid():
    spec = table2_spec()
    g = table2_genome(spec)
    bad = g._replace(mantissa=g.mantissa.at[6].set(99), exponent=g.exponent.at[6].set(2))
    ev = Evaluation(size=8, dt=0.5, t_start=10.0, interval=5.0, rounds=2, init="steady",
                    init_relax=50.0)
    fitness, states = evaluate(stack([g, bad]), initial_state(jax.random.key(2), spec, ev),
                               spec, ev)
    assert fitness[1] == -1.0 and (states[1] == 0).all()
    # valid, the ±10 % noise not yet spots: every cell dead (64 / 4), graded below that
    assert 0.0 < fitness[0] < 64 * 0.25


@pytest.mark.slow
def test_a_run_saved_before_init_existed_resumes_with_uniform_starts(tmp_path):
    from morphogen.search.networks.evolve import load_state, run, save_state
    from morphogen.search.networks.operators import Operators

    spec = table2_spec()
    ev = Evaluation(size=8, dt=0.5, t_start=5.0, interval=5.0, rounds=2, init="uniform")
    kw = dict(ops=Operators(mode="rates"), ev=ev, population=4, seed=1, log=lambda s: None)
    _, _, full = run(spec, table2_genome(spec), tmp_path / "a", generations=2, **kw)
    run(spec, table2_genome(spec), tmp_path / "b", generations=1, **kw)
    path = tmp_path / "b" / "state.npz"
    pop, history, done, meta = load_state(path)
    for key in ("init", "init_noise", "init_relax"):
        del meta["ev"][key]  # as written before the option existed
    save_state(path, pop, history, done, meta)
    assert "init" not in load_state(path)[3]["ev"]
    _, _, resumed = run(spec, table2_genome(spec), tmp_path / "b", generations=2, resume=True,
                        **kw)
    np.testing.assert_array_equal(full, resumed)


@pytest.mark.slow
def test_cli_init_option_is_saved_and_resumed(tmp_path):
    from morphogen.cli.main import main
    from morphogen.search.networks import record

    out = tmp_path / "u"
    args = ["networks", "--out", str(out), "--population", "4", "--size", "8", "--dt", "0.5",
            "--t-start", "5", "--interval", "5", "--rounds", "1", "--quiet",
            "--archive", str(tmp_path / "index.sqlite")]
    assert main(args + ["--generations", "1", "--init", "uniform", "--init-noise", "0.2"]) == 0
    saved = record.saved_settings(out)
    assert saved["init"] == "uniform" and saved["init_noise"] == 0.2
    assert main(["networks", "--out", str(out), "--resume", "--generations", "2", "--quiet"]) == 0
    assert record.saved_settings(out)["init"] == "uniform"


def test_fixed_start_is_each_genomes_fixed_point_times_the_shared_noise():
    spec = table2_spec()
    me = np.array([[2, 0, 2], [0, 1, 0], [1, 1, 0]])
    mp = np.array([[3, 0, 2], [0, 1, 1], [1, 0, 0]])
    fig4 = make_genome(spec, [0, 0, 0.031, 0.015, 0.02, 0, 0.094, 0.3, 0.0019], me, mp)
    # without B + C -> B nothing consumes C, fed at 0.1: dC/dt > 0 everywhere, no fixed point
    k = [0.0, 0.0, 0.1, 0.01, 0.02, 0.0, 0.01, 0.0, 0.02]
    unfixed = make_genome(spec, k, me, mp)
    params = genome_params(stack([table2_genome(spec), fig4, unfixed]), spec)
    u_star, ok = fixed_states(params, spec)
    a = 0.094 * 0.031 * 0.02 / (0.3 * 0.0019 * 0.015)  # exact, as in the steady test above
    b = 0.0019 * a * a / 0.02
    np.testing.assert_allclose(np.asarray(u_star)[:2], [[1, 1, 1], [a, b, 0.031 / (0.3 * b)]],
                               rtol=1e-4)
    assert np.asarray(ok).tolist() == [True, True, False]
    ev = Evaluation(size=8, init="fixed", init_noise=0.1)
    u0 = np.asarray(initial_state(jax.random.key(3), spec, ev))
    assert 0.0 <= u0.min() and u0.max() < 2.0  # the shared uniform field
    u = np.asarray(starts(jnp.asarray(u0), params, spec, ev))
    noise = 1.0 + 0.1 * (u0 - 1.0)  # ξ = 2 u0 / init_high - 1
    np.testing.assert_allclose(u[:2], np.asarray(u_star)[:2, :, None, None] * noise[None],
                               rtol=1e-6)
    np.testing.assert_array_equal(u[2], u0)


def test_replay_file_of_a_fixed_start_run_starts_at_the_fixed_point(tmp_path):
    from dataclasses import asdict

    from morphogen.search.networks.record import best_run_file, genome_vectors

    spec = table2_spec()
    vector = genome_vectors(stack([table2_genome(spec)]))[0]
    best = {"genome": vector.tolist(), "fitness": 1000.0, "gen": 0, "idx": 0}
    ev = asdict(Evaluation(size=8, init="fixed"))
    config = best_run_file(best, spec, ev, "r1", tmp_path)["config"]
    assert config["init"] == "noise" and config["init_options"] == {"amplitude": 0.1}
    assert "[initial]\nA = 1.0\nB = 1.0\nC = 1.0" in config["model_source"]
