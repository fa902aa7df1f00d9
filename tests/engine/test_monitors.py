"""The jobs between compiled chunks (engine/monitors.py), checked on hand-built states, and the
same monitors serving the fixed-step and the adaptive time loops."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.adaptive_loop import simulate_adaptive
from morphogen.engine.monitors import (
    OVERFLOW,
    BlowUp,
    Cancel,
    Chunk,
    Divergence,
    Monitors,
    Snapshots,
    first_failure,
)
from morphogen.engine.simulate import simulate
from morphogen.errors import BlowUpError, MorphogenError
from morphogen.models.model import Model

SPECIES = ("a", "b")
FLAT = np.ones((2, 4, 4), np.float32)


def _chunk(u, step: int, n: int = 1, replay=None, t: float | None = None) -> Chunk:
    return Chunk(u=np.asarray(u), t=step * 0.5 if t is None else t, step=step, n=n, dt=0.5,
                 taken=step, replay=replay)


def _kept(count: int, limit: int) -> list[int]:
    """Every ``2^j``-th of ``count`` offered states, ``j`` the smallest that keeps ``limit``."""
    stride = 1
    while len(range(0, count, stride)) > max(2, limit):
        stride *= 2
    return list(range(0, count, stride))


@pytest.mark.parametrize("limit", [2, 3, 4, 7, 8])
@pytest.mark.parametrize("count", [1, 2, 5, 9, 16, 17, 40])
def test_thinning_keeps_bounded_memory_and_every_power_of_two_th_state(limit, count):
    shots = Snapshots(limit, FLAT * 0)
    for i in range(1, count):
        shots.add(10 * i, FLAT * i)
        assert len(shots.items) <= max(2, limit)
    states, steps = shots.result()
    assert steps == [10 * i for i in _kept(count, limit)]
    np.testing.assert_array_equal(states[:, 0, 0, 0], np.array(steps) / 10)


def test_thinning_with_the_final_state_adds_only_the_last_one():
    plain, final = Snapshots(4, FLAT), Snapshots(4, FLAT, final=True)
    for i in range(1, 11):  # 11 states: every 4th is kept
        plain.check(_chunk(FLAT * i, 10 * i))
        final.check(_chunk(FLAT * i, 10 * i))
    assert plain.result()[1] == [0, 40, 80]
    assert final.result()[1] == [0, 40, 80, 100]
    final.add(110, FLAT)
    final.add(120, FLAT)  # the 13th state lies on the stride: kept once
    assert final.result()[1] == [0, 40, 80, 120]


def test_blow_up_replays_the_chunk_to_name_the_first_bad_step_and_species():
    states = [FLAT.copy() for _ in range(4)]
    states[1][1, 2, 3] = np.nan  # step 12: b
    states[2][0, 0, 0] = 2 * OVERFLOW  # step 13: a (and b)
    states[2][1] = np.inf
    states[3][:] = np.nan  # the chunk ends at step 14

    def replay():
        for i, u in enumerate(states):
            yield u, 5.0 + 0.5 * (i + 1)

    with pytest.raises(BlowUpError) as info:
        BlowUp(SPECIES, None).check(_chunk(states[-1], 14, n=4, replay=replay))
    assert (info.value.step, info.value.species, info.value.t) == (12, ("b",), 6.0)


def test_blow_up_without_a_replay_names_the_chunk_end_and_a_finite_state_passes():
    monitor = BlowUp(SPECIES, None)
    monitor.check(_chunk(FLAT * 1e14, 5))
    u = FLAT.copy()
    u[0, 1, 1] = -np.inf
    with pytest.raises(BlowUpError) as info:
        monitor.check(Chunk(u, 3.0, 6, 1, 0.5, taken=40))  # the adaptive loop: 40 accepted
    assert (info.value.step, info.value.species) == (40, ("a",))


def test_a_batch_records_the_first_failure_of_each_member_and_goes_on():
    report_calls = []
    blowup = BlowUp(SPECIES, 3)
    diverging = Divergence(SPECIES, 3, np.ones((3, 2)), checkerboard=False,
                           report=lambda *a: report_calls.append(a))
    batch = np.stack([FLAT, FLAT, FLAT])
    far = batch.copy()
    far[2, 0] = 1e6  # member 2 diverges at step 10
    nan = far.copy()
    nan[0, 1, 0, 0] = np.nan  # member 0 blows up at step 20
    with Monitors(blowup, diverging) as monitors:
        monitors.check(_chunk(batch, 5))
        monitors.check(_chunk(far, 10))
        monitors.check(_chunk(nan, 20))
    assert report_calls == []
    np.testing.assert_array_equal(first_failure(blowup, diverging), [20, 0, 10])
    np.testing.assert_array_equal(first_failure(blowup), [20, 0, 0])


def test_divergence_names_the_cause_far_values_or_a_growing_checkerboard():
    def report(chunk, names, why):
        return MorphogenError(f"{chunk.step} {names} {why}")

    far = FLAT.copy()
    far[1] = 2e4
    with pytest.raises(MorphogenError, match=r"3 \('b',\) values are orders of magnitude"):
        Divergence(SPECIES, None, np.ones((1, 2)), checkerboard=True, report=report).check(
            _chunk(far, 3))
    checker = (-1.0) ** np.add.outer(np.arange(8), np.arange(8))
    watch = Divergence(SPECIES, None, np.ones((1, 2)), checkerboard=True, report=report)
    watch.check(_chunk(np.stack([checker * 0.01, checker * 0]), 1))
    with pytest.raises(MorphogenError, match=r"2 \('a',\) a grid-scale \(checkerboard\) mode "
                                             r"is growing \(x3 per check\)"):
        watch.check(_chunk(np.stack([checker * 0.03, checker * 0]), 2))


LINEAR = Model(
    name="decay", species=("u",), params={"k": 0.5, "D": 0.1},
    reaction=lambda u, p, c: -p["k"] * u, diffusion=lambda p, c: (p["D"],),
    ground=lambda p: (0.0,),
)


def test_both_loops_thin_their_snapshots_by_the_one_policy_and_call_the_hook():
    grid = Grid((4, 4))
    u0 = np.random.default_rng(0).random((1, 4, 4)).astype(np.float32)
    fixed = simulate(LINEAR, grid, u0, dict(LINEAR.params), steps=10, dt=0.1, every=1,
                     max_snapshots=4)
    calls: list[int] = []
    adaptive = simulate_adaptive(LINEAR, grid, u0, dict(LINEAR.params), steps=10, dt=0.1,
                                 every=1, max_snapshots=4, on_chunk=calls.append)
    assert fixed.snapshot_steps == [0, 4, 8] == _kept(11, 4)
    assert adaptive.snapshot_steps == [0, 4, 8, 10]  # the same policy, and the end time
    assert adaptive.snapshot_times == pytest.approx([0.0, 0.4, 0.8, 1.0])
    assert calls == [1] * 10


class Cancelled(Exception):
    pass


def test_a_hook_that_raises_stops_either_loop():
    def stop(n: int) -> None:
        raise Cancelled

    grid = Grid((4, 4))
    u0 = np.ones((1, 4, 4), np.float32)
    for run in (simulate, simulate_adaptive):
        with pytest.raises(Cancelled):
            run(LINEAR, grid, u0, dict(LINEAR.params), steps=4, dt=0.1, every=2, on_chunk=stop)
    with pytest.raises(Cancelled), Monitors(Cancel(stop)) as monitors:
        monitors.check(_chunk(FLAT, 1))


@pytest.mark.parametrize("batched", [False, True])
def test_numpy_and_compiled_checks_agree(batched):
    """A NumPy state (the fused CPU step's) is checked by NumPy, a JAX state by a compiled
    program: the same flags and grid-scale amplitudes on a NaN, an overflow, a checkerboard and
    a smooth field."""
    import jax.numpy as jnp

    from morphogen.engine.monitors import bad_species
    from morphogen.solvers.stability import divergence_flags

    y, x = np.mgrid[0:16, 0:16]
    checker = ((x + y) % 2).astype(np.float32)
    smooth = np.sin(2 * np.pi * x / 16).astype(np.float32)
    states = np.stack([np.stack([checker, smooth]), np.stack([smooth, smooth * 3e4]),
                       np.stack([smooth, smooth])])
    states[1, 0, 3, 3] = np.nan
    states[2, 1, 5, 5] = 2 * OVERFLOW
    u = states if batched else states[0]
    scale, prev = np.ones((3 if batched else 1, 2)), np.full((3 if batched else 1, 2), 1e-3)
    np.testing.assert_array_equal(bad_species(u, batched), bad_species(jnp.asarray(u), batched))
    a = divergence_flags(u, scale, prev, batched, True)
    b = divergence_flags(jnp.asarray(u), scale, prev, batched, True)
    for x_np, x_jax in zip(a, b, strict=True):
        np.testing.assert_allclose(x_np, x_jax, rtol=1e-5, equal_nan=True)
    out, growing, grid = a
    if batched:
        assert bad_species(u, True).tolist() == [[False, False], [True, False], [False, True]]
        assert out.tolist() == [[False, False], [False, True], [False, True]]
    # the 0/1 checkerboard is all grid scale, RMS 0.5, grown from 1e-3
    assert growing[0].tolist() == [True, False] and grid[0, 0] == pytest.approx(0.5)
