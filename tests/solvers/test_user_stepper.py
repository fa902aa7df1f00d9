"""A user's own fixed-step scheme, passed as a :class:`morphogen.Stepper` object: it runs
through ``make_step``, the stability check and ``simulate`` like a registered one, keeps its
order of accuracy, and does not replace a registered scheme of the same name."""

from __future__ import annotations

import numpy as np
import pytest

import morphogen as mg
from morphogen.solvers.base import stepper
from morphogen.solvers.stability import bisect_ray_limit, linear_limit


class Heun(mg.Stepper):
    """Heun's method (explicit trapezoid), second order: ``R(z) = 1 + z + z²/2``."""

    name = "heun"

    def amplification(self, z):
        return 1.0 + z + z**2 / 2.0

    def limit(self, model, domain, params, *, batched=False):
        return linear_limit(model, domain, params,
                            lambda lam: bisect_ray_limit(self.amplification, lam),
                            batched=batched)

    def advance(self, model, domain):
        rhs = mg.make_rhs(model, domain)

        def update(u, p, t, dt, aux=None):
            k1 = rhs(u, p, t)
            k2 = rhs(u + dt * k1, p, t + dt)
            return u + 0.5 * dt * (k1 + k2)

        return mg.Advance(update)


class Impostor(Heun):
    name = "euler"  # a user's class with a registered name stays out of the registry


def _run(scheme, dt, t_end=50.0):
    model, grid = mg.load_model("gray-scott"), mg.Grid((16, 16))
    params = model.parameters()
    u0 = mg.make_initial("square", model, grid, params)
    return mg.simulate(model, grid, u0, params, scheme=scheme, dt=dt, t_end=t_end,
                       clamp=None)


def test_a_user_scheme_runs_with_second_order_accuracy():
    with_x64 = pytest.importorskip("jax").enable_x64(True)
    with with_x64:
        reference = _run("rk4", 1 / 16).state
        errors = [np.abs(_run(Heun(), dt).state - reference).max() for dt in (0.25, 0.125)]
    sol = _run(Heun(), 0.5)
    assert sol.scheme == "heun" and sol.steps == 100
    assert np.log2(errors[0] / errors[1]) == pytest.approx(2.0, abs=0.15)


def test_a_user_scheme_is_checked_against_its_own_limit():
    model, grid = mg.load_model("gray-scott"), mg.Grid((16, 16))
    params = model.parameters()
    limit = mg.max_stable_dt(model, grid, params, Heun())
    # diffusion's real spectrum: Heun's region and Euler's both end at z = -2 on that axis
    assert limit == pytest.approx(mg.max_stable_dt(model, grid, params, "euler"), rel=1e-3)
    u0 = mg.make_initial("square", model, grid, params)
    with pytest.raises(mg.MorphogenError, match="heun"):
        mg.simulate(model, grid, u0, params, scheme=Heun(), dt=1.01 * limit, steps=1)
    default = mg.simulate(model, grid, u0, params, scheme=Heun(), t_end=10.0)
    assert default.dt == min(model.dt, limit)  # an explicit scheme: the model's dt within


def test_a_user_class_does_not_replace_a_registered_scheme():
    assert type(stepper("euler")).__name__ == "Euler"
    assert stepper(Impostor()).info.module == __name__
