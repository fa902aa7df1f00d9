"""What a stochastic mesh step costs, and the random-number generator's share of it.

Ringham's Dianthus case study (§4.4, ``examples/flowers/dianthus.toml``, stage ``morphogen``:
24 100 vertices, 46 795 triangles, ``Ω = 10⁶``, ``dt = 10⁻⁴``), its inputs as the pipeline
builds them (:func:`bench.bench_case_schemes.prepare`). CPU seconds of this process per step
(``time.process_time``), medians of :data:`ROUNDS` interleaved rounds of :data:`STEPS` steps in
one compiled ``lax.scan`` each, after compiling:

- ``deterministic``: the Euler step with the noise off (``omega=None``);
- ``stochastic``: the shipped step (Chemical-Langevin flux noise, eq. 17), and the same with the
  key made by ``jax.random.key(0, impl="rbg")`` and ``"unsafe_rbg"`` (every split and draw of
  the run in that generator);
- ``stochastic_rows``: the previous increment, one ``(F,)`` row per border from the draw to the
  fluxes (:func:`rows_increment`), which XLA on CPU fused so that the normals were computed
  several times over;
- ``increment_normals_given``: the increment alone with its normals passed in (no generator);
- ``draw_*``: the draw alone, ``split`` plus ``normal((3, F))`` per step, for each generator,
  and as one larger draw ``(S, 3, F)`` for all species (the case has one species, so that is the
  same size here).
"""

from __future__ import annotations

import os
import statistics
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from bench.bench_case_schemes import prepare
from bench.timing import interleaved_cpu
from morphogen.domains.mesh import Mesh
from morphogen.engine.simulate import integrate
from morphogen.solvers.step import make_step

STEPS, ROUNDS = 500, 5
IMPLS = ("threefry2x32", "rbg", "unsafe_rbg")


def rows_increment(ops, u, tensor, dt, omega, normal):
    """The previous form of
    :meth:`~morphogen.domains.mesh_operators.MeshOperators.langevin_increment`:
    a ``(F,)`` row per border."""
    txx, txy, tyy = tensor
    a, b, n1, n2 = ([jnp.asarray(np.ascontiguousarray(m[:, k]), u.dtype) for k in range(3)]
                    for m in (ops.grad_e1, ops.grad_e2, ops.nu_e1, ops.nu_e2))
    j1 = [txx * a[c] + txy * b[c] for c in range(3)]
    j2 = [txy * a[c] + tyy * b[c] for c in range(3)]
    uf = [jnp.maximum(c, 0.0) for c in ops._corner_values(u)]
    eta = []
    for k in range(3):
        var = sum(jnp.abs(n1[k] * j1[c] + n2[k] * j2[c]) * uf[c] for c in range(3))
        eta.append(jnp.sqrt(var * (dt / omega)) * normal[k])
    return ops.corners.apply(jnp.concatenate([eta[(k - 1) % 3] - eta[(k + 1) % 3]
                                              for k in range(3)]))


def _looped(body: Callable, carry) -> Callable[[], object]:
    run = jax.jit(lambda c: jax.lax.scan(body, c, None, length=STEPS)[1])
    jax.block_until_ready(run(carry))
    return lambda: jax.block_until_ready(run(carry))


def run() -> dict:
    case = prepare("flowers/dianthus.toml", "morphogen")
    mesh: Mesh = case.domain
    ops, faces, species = mesh.ops, mesh.n_faces, len(case.model.species)
    p = {k: jnp.asarray(v) for k, v in case.params.items()}
    u0 = jnp.asarray(case.u0)
    runs: dict[str, Callable[[], object]] = {}

    def simulate_with(domain, impl: str = "threefry2x32") -> Callable[[], object]:
        step = make_step(case.model, domain)
        key = jax.random.key(0, impl=impl)
        f = jax.jit(lambda u, k: integrate(step, u, p, steps=STEPS, dt=case.dt, key=k)[0])
        jax.block_until_ready(f(u0, key))
        return lambda: jax.block_until_ready(f(u0, key))

    runs["deterministic"] = simulate_with(mesh.replace(omega=None))
    for impl in IMPLS:
        runs[f"stochastic_{impl}"] = simulate_with(mesh, impl)

    d = jnp.asarray(case.params["D"], jnp.float32)
    tensor = ops.face_tensor(d, 0.0, d, jnp.float32)
    u = u0[0]
    omega = float(mesh.omega)

    def rows_body(k, _):
        k, sub = jax.random.split(k)
        normal = jax.random.normal(sub, (3, faces), jnp.float32)
        return k, rows_increment(ops, u, tensor, case.dt, omega, normal).sum()

    def shipped_body(k, _):
        k, sub = jax.random.split(k)
        return k, ops.langevin_increment(u, tensor, case.dt, omega, sub).sum()

    normals = jax.random.normal(jax.random.key(1), (STEPS, 3, faces), jnp.float32)

    def given_body(i, _):
        # the shipped increment's arithmetic with the normals read from memory
        txx, txy, tyy = tensor
        a, b = ([jnp.asarray(np.ascontiguousarray(m[:, c]), u.dtype) for c in range(3)]
                for m in (ops.grad_e1, ops.grad_e2))
        n1, n2 = (jnp.asarray(np.ascontiguousarray(m.T), u.dtype)
                  for m in (ops.nu_e1, ops.nu_e2))
        j1 = [txx * a[c] + txy * b[c] for c in range(3)]
        j2 = [txy * a[c] + tyy * b[c] for c in range(3)]
        uf = [jnp.maximum(c, 0.0) for c in ops._corner_values(u)]
        var = sum(jnp.abs(n1 * j1[c] + n2 * j2[c]) * uf[c] for c in range(3))
        eta = jnp.sqrt(var * (case.dt / omega)) * normals[i]
        flux = eta[np.array([2, 0, 1])] - eta[np.array([1, 2, 0])]
        return i + 1, ops.corners.apply(flux.reshape(-1)).sum()

    runs["increment_rows"] = _looped(rows_body, jax.random.key(0))
    runs["increment_shipped"] = _looped(shipped_body, jax.random.key(0))
    runs["increment_normals_given"] = _looped(given_body, 0)
    for impl in IMPLS:
        def per_species(k, _):
            k, sub = jax.random.split(k)
            keys = jax.random.split(sub, species)
            return k, sum(jax.random.normal(keys[i], (3, faces)).sum() for i in range(species))

        def one_draw(k, _):
            k, sub = jax.random.split(k)
            return k, jax.random.normal(sub, (species, 3, faces)).sum()

        runs[f"draw_{impl}"] = _looped(per_species, jax.random.key(0, impl=impl))
        runs[f"draw_{impl}_one_draw"] = _looped(one_draw, jax.random.key(0, impl=impl))

    load_before = os.getloadavg()
    cpu, wall = interleaved_cpu(runs, ROUNDS)
    load_after = os.getloadavg()
    ms = {k: 1e3 * statistics.median(v) / STEPS for k, v in cpu.items()}
    return {
        "case": "Dianthus §4.4, stage morphogen (examples/flowers/dianthus.toml)",
        "vertices": mesh.n_vertices, "faces": faces, "species": species, "omega": omega,
        "steps_per_round": STEPS, "rounds": ROUNDS,
        "cpu_ms_per_step": ms,
        "wall_ms_per_step": {k: 1e3 * statistics.median(v) / STEPS for k, v in wall.items()},
        "stochastic_over_deterministic": ms["stochastic_threefry2x32"] / ms["deterministic"],
        "rows_over_shipped_increment": ms["increment_rows"] / ms["increment_shipped"],
        "draw_share_of_stochastic_step": ms["draw_threefry2x32"] / ms["stochastic_threefry2x32"],
        "load_average_before": list(load_before), "load_average_after": list(load_after),
    }


if __name__ == "__main__":
    import json
    from pathlib import Path

    from bench.run import machine
    from morphogen.util.io import write_json

    result = run()
    result["machine"] = machine()
    print(json.dumps(result, indent=2))
    write_json(Path(__file__).parent / "results" / "mesh_noise.json", result)
