"""The scheme registry, the :class:`Stepper` behind each fixed-step row, the :class:`Step`
object and the :class:`Domain` protocol."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from morphogen.domains.base import Domain
from morphogen.domains.grid import Grid
from morphogen.domains.mesh import Mesh
from morphogen.engine.simulate import integrate
from morphogen.errors import MorphogenError
from morphogen.solvers.base import Stepper, stepper
from morphogen.solvers.registry import FIXED_STEP, IMPLICIT_DIFFUSION, SCHEMES
from morphogen.solvers.step import Step, make_step, max_stable_dt
from tests.core_models import pure_diffusion


@pytest.mark.parametrize("name", FIXED_STEP)
def test_every_fixed_step_row_has_its_stepper_in_its_module(name):
    s = stepper(name)
    assert isinstance(s, Stepper)
    assert s.name == name
    assert type(s).__module__ == SCHEMES[name].module
    assert s.order == SCHEMES[name].order


@pytest.mark.parametrize("name", ["adaptive", "auto", "leapfrog"])
def test_schemes_without_a_stepper_are_refused_in_one_line(name):
    with pytest.raises(MorphogenError, match="chosen per run|unknown scheme") as err:
        make_step(pure_diffusion(), Grid((8, 8)), scheme=name)
    assert "\n" not in str(err.value)


def test_implicit_diffusion_limits_come_from_the_reaction_alone():
    """Pure diffusion has no decaying reaction eigenvalue: unlimited for the schemes the
    registry marks ``implicit_diffusion``, limited by diffusion for the others."""
    model, grid = pure_diffusion(d=0.5), Grid((16, 16))
    for name in FIXED_STEP:
        limit = max_stable_dt(model, grid, {"D": 0.5}, name)
        assert (limit == float("inf")) == (name in IMPLICIT_DIFFUSION), name


@pytest.mark.parametrize("name", FIXED_STEP)
def test_a_step_is_an_explicit_object_with_its_invariants(name):
    """Only ETDRK4 precomputes something per run; with or without it, the same step."""
    model, grid = pure_diffusion(d=0.5), Grid((8, 8))
    step = make_step(model, grid, scheme=name)
    assert isinstance(step, Step)
    p = {"D": jnp.float32(0.5)}
    dt = jnp.float32(0.1)
    aux = step.invariants(p, jnp.float32(0.0), dt)
    assert (aux is None) == (name != "etdrk4")
    u0 = jnp.asarray(np.random.default_rng(0).random((1, 8, 8)), jnp.float32)
    key = jax.random.PRNGKey(0)
    once = jax.jit(step)(u0, p, jnp.float32(0.0), dt, key)
    np.testing.assert_allclose(np.asarray(step(u0, p, 0.0, dt, key, aux)), np.asarray(once),
                               rtol=1e-6, atol=1e-7)
    looped, _, _ = integrate(step, u0, p, steps=1, dt=dt, key=key)
    assert looped.shape == u0.shape


def test_grids_and_meshes_declare_their_kind():
    grid = Grid((8, 8))
    s = trimesh.creation.icosphere(subdivisions=1)
    mesh = Mesh(s.vertices, s.faces)
    assert isinstance(grid, Domain) and isinstance(mesh, Domain)
    assert (grid.kind, mesh.kind) == ("grid", "mesh")
    assert not grid.stochastic and not mesh.stochastic
    u = jnp.ones((1, 8, 8))
    noise = grid.diffusion_noise(u, (1.0,), grid.boundaries(("u",)), 0.1, jax.random.PRNGKey(0))
    assert np.all(np.asarray(noise) == 0)
