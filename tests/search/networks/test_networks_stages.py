"""The network evaluation's stages (Yamamoto §3.3) on hand-built states: grid-scale
checkerboards are invalid, stage two reads the activator, and a non-homogeneous state without
a peak is graded below every state with one, less the more it still drifts."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search.networks.cluster import (
    GRADE_FLOOR,
    cluster_head_fitness,
    pattern_grade,
    stationarity,
)
from morphogen.search.networks.evolve import (
    LEGACY_EV,
    Evaluation,
    evaluate,
    initial_state,
    network_fitness,
)
from morphogen.search.networks.genome import stack, table2_genome, table2_spec

NETWORK = network_fitness(Evaluation())  # stationary grade, checkerboards invalid
LITERAL = cluster_head_fitness(nonnegative=True)  # the earlier network fitness


def _state(a: np.ndarray, seed: int = 0) -> jnp.ndarray:
    """Activator ``a`` (32²), B and C at 1 ± 10 % noise (C does not diffuse: its noise stays)."""
    rng = np.random.default_rng(seed)
    u = 1.0 + 0.1 * rng.uniform(-1.0, 1.0, (3, *a.shape))
    u[0] = a
    return jnp.asarray(u[None], jnp.float32)


def _checkerboard(seed: int = 0) -> np.ndarray:
    """A grid-scale checkerboard of A: 5 ± 10 % on the black cells, 0.01 on the white ones,
    the mark of an explicit step beyond its stability limit."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:32, :32]
    board = np.where((x + y) % 2 == 1, 5.0, 0.01)
    return board * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, board.shape))


def test_a_checkerboard_is_invalid_not_a_pattern():
    u = _state(_checkerboard())
    assert float(LITERAL(u)[0]) > 990  # scored as dense crowded peaks before
    assert float(NETWORK(u)[0]) == -1.0


def test_one_cell_spots_are_not_checkerboards():
    # isolated one-cell spots (the Table-3 bottom network's kind) carry 3/8 of their deviation
    # at grid scale, below the test's 0.6: still peaks; a spot of 20 on 5 ± 10 % noise scores
    # one isolated peak 0.75 + 112 alive + 911 dead = 340.5, on every reading
    rng = np.random.default_rng(1)
    a = 5.0 + 0.5 * rng.uniform(-1.0, 1.0, (32, 32))
    a[5, 5] = 20.0
    a[5, 20] = a[20, 5] = a[20, 20] = 20.0
    u = _state(a)
    assert float(LITERAL(u)[0]) == float(NETWORK(u)[0]) > 340.5


def test_stage_two_reads_the_activator():
    # A flat, C keeps its start noise: homogeneous for the task, "patterned" (256) literally
    u = _state(np.full((32, 32), 2.0))
    assert float(LITERAL(u)[0]) == 256.0
    assert float(cluster_head_fitness(nonnegative=True, stage2="activator")(u)[0]) == 0.0
    assert float(NETWORK(u)[0]) == 0.0


def test_graded_stage_two_orders_the_states():
    rng = np.random.default_rng(2)
    xi = rng.uniform(-1.0, 1.0, (32, 32))
    y, x = np.mgrid[:32, :32]
    bump = np.exp(-((x - 16.0) ** 2 + (y - 16.0) ** 2) / 8.0)
    states = {
        "flat": np.full((32, 32), 1.0),
        "noise on 1": 1.0 + 0.1 * xi,
        "noise on 5": 5.0 + 0.5 * xi,
        "low bump": 1.0 + 1.0 * bump,
        "high bump": 1.0 + 1.9 * bump,
        "spot": np.where(bump > 0.99, 12.0, 1.0),
    }
    f = {k: float(NETWORK(_state(a))[0]) for k, a in states.items()}
    assert f["flat"] == 0.0 < f["noise on 1"] < f["noise on 5"] < 256.0
    assert 0.0 < f["low bump"] < f["high bump"] < 256.0 < f["spot"]
    # the grade by hand: min(1, max/3) · min(1, (max - mean) / (max / 2)), times N/4 = 256
    for name in ("noise on 1", "low bump", "high bump"):
        a = states[name].astype(np.float32)
        top = a.max()
        g = min(1.0, top / 3.0) * min(1.0, (top - a.mean()) / (0.5 * top))
        assert f[name] == pytest.approx(256.0 * g, rel=1e-5)
        assert float(pattern_grade(jnp.asarray(a))) == pytest.approx(g, rel=1e-5)
    # a state with a peak scores the same on every reading
    spot = _state(states["spot"])
    assert f["spot"] == float(LITERAL(spot)[0])
    # normalised (an ordinary parameter search): the same score per cell
    per_cell = cluster_head_fitness(nonnegative=True, stage2="graded", normalise=True)
    assert float(per_cell(_state(states["low bump"]))[0]) == pytest.approx(f["low bump"] / 1024)


def test_stage_two_options_and_legacy_runs():
    assert Evaluation().stage2 == "stationary" and Evaluation().reject_checkerboards
    assert LEGACY_EV["stage2"] == "literal" and LEGACY_EV["reject_checkerboards"] is False
    literal = network_fitness(Evaluation(stage2="literal", reject_checkerboards=False))
    u = _state(_checkerboard(3))
    assert float(literal(u)[0]) == float(LITERAL(u)[0]) > 990
    with pytest.raises(MorphogenError, match="stage-2"):
        Evaluation(stage2="smooth")
    with pytest.raises(MorphogenError, match="stage-2"):
        cluster_head_fitness(stage2="smooth")


@pytest.mark.slow
def test_cli_stage_two_and_draw_options_are_saved_and_resumed(tmp_path):
    import json

    from morphogen.cli.main import main
    from morphogen.search.networks import record

    out = tmp_path / "r"
    args = ["networks", "--out", str(out), "--population", "4", "--size", "8", "--dt", "0.5",
            "--t-start", "5", "--interval", "5", "--rounds", "1", "--quiet", "--init", "uniform",
            "--archive", str(tmp_path / "index.sqlite")]
    assert main(args + ["--generations", "1", "--stage2", "literal", "--checkerboards",
                        "scored", "--draw", "decade"]) == 0
    saved = record.saved_settings(out)
    assert (saved["stage2"], saved["checkerboards"], saved["draw"]) == ("literal", "scored",
                                                                        "decade")
    assert main(["networks", "--out", str(out), "--resume", "--generations", "2", "--quiet"]) == 0
    assert record.saved_settings(out)["draw"] == "decade"
    # a run recorded before the options existed resumes with its earlier behaviour
    config = json.loads((out / "config.json").read_text())
    del config["problem"]["ev"]["stage2"], config["problem"]["ev"]["reject_checkerboards"]
    del config["strategy"]["draw"]
    (out / "config.json").write_text(json.dumps(config))
    saved = record.saved_settings(out)
    assert (saved["stage2"], saved["checkerboards"], saved["draw"]) == ("literal", "scored",
                                                                        "log-uniform")


def test_the_stationary_grade_scales_by_the_drift_since_the_previous_round():
    y, x = np.mgrid[:32, :32]
    bump = 1.0 + 1.9 * np.exp(-((x - 16.0) ** 2 + (y - 16.0) ** 2) / 8.0)
    u = _state(bump)
    top = float(bump.max())
    graded = cluster_head_fitness(nonnegative=True, stage2="graded")
    g = float(graded(u)[0]) / 256.0
    assert 0.1 < g < 1.0
    assert float(NETWORK(u)[0]) == pytest.approx(256.0 * g, rel=1e-6)  # no previous: settled
    assert float(NETWORK(u, u)[0]) == pytest.approx(256.0 * g, rel=1e-6)
    # A 5 % of its range lower one round before: drift 0.05 against the tolerance 0.1 -> half
    before = np.asarray(u).copy()
    before[0, 0] -= 0.05 * top
    assert float(stationarity(u[0], jnp.asarray(before[0]))) == pytest.approx(0.5, rel=1e-4)
    assert float(NETWORK(u, before)[0]) == pytest.approx(128.0 * g, rel=1e-4)
    # the same drift over half a round is twice as fast: no grade left but the floor
    assert float(NETWORK(u, before, 2.0)[0]) == pytest.approx(256.0 * GRADE_FLOOR, rel=1e-4)
    # the non-diffusing C running away (20 % of its range) while A stands still: the floor
    runaway = np.asarray(u).copy()
    runaway[0, 2] *= 0.8
    assert float(NETWORK(u, runaway)[0]) == pytest.approx(256.0 * GRADE_FLOOR, rel=1e-4)
    assert float(graded(u, runaway)[0]) == pytest.approx(256.0 * g, rel=1e-6)
    # a state with a peak, and a flat one, score the same however they drift
    spot = _state(np.where(np.exp(-((x - 16.0) ** 2 + (y - 16.0) ** 2) / 8.0) > 0.99, 12.0, 1.0))
    assert float(NETWORK(spot, 0.5 * spot)[0]) == float(graded(spot)[0]) > 256.0
    flat = _state(np.full((32, 32), 2.0))
    assert float(NETWORK(flat, 0.5 * flat)[0]) == 0.0


def test_the_evaluation_hands_each_round_the_state_before_it():
    # Table 2 from the shared uniform field, scored early (t = 5, 10) while still moving: a
    # graded individual scores less under the stationary reading, the others the same
    spec = table2_spec()
    g = table2_genome(spec)
    pop = stack([g._replace(mantissa=g.mantissa.at[j].set(m))
                 for j, m in ((3, 10), (3, 30), (6, 50), (7, 20), (8, 99), (0, 0))])
    ev = Evaluation(size=8, dt=0.5, t_start=5.0, interval=5.0, rounds=2, init="uniform")
    u0 = initial_state(jax.random.key(4), spec, ev)
    drifting, _ = evaluate(pop, u0, spec, ev)
    settled, _ = evaluate(pop, u0, spec, replace(ev, stage2="graded"))
    graded = (settled > 0) & (settled <= 16.0)  # 8² cells: N/4 = 16
    assert graded.any()
    assert np.all(drifting[graded] < settled[graded])
    np.testing.assert_array_equal(drifting[~graded], settled[~graded])
