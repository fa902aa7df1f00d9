"""Neural RD model (seed 002 eq. 1): the update rule, diffusion groups, save/load, any domain."""

from __future__ import annotations

import imageio.v3 as iio
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.grid import Grid
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.models.neural import (
    KERNEL_SCALE,
    NeuralConfig,
    fixed_diffusion,
    init_weights,
    load_neural_model,
    neural_model,
    read_neural_file,
    save_neural_model,
)
from morphogen.solvers.step import make_step


def random_weights(config: NeuralConfig, seed: int = 0, scale: float = 0.1) -> dict:
    rng = np.random.default_rng(seed)
    w = init_weights(config, jax.random.PRNGKey(seed))
    w["b0"] = (scale * rng.standard_normal(config.hidden)).astype(np.float32)
    w["W1"] = (scale * rng.standard_normal((config.hidden, config.channels))).astype(np.float32)
    return w


def test_fixed_diffusion_groups_and_parameter_count():
    c = fixed_diffusion(32)
    np.testing.assert_array_equal(c[:8], 1 / 8)
    np.testing.assert_array_equal(c[8:16], 1 / 4)
    np.testing.assert_array_equal(c[16:24], 1 / 2)
    np.testing.assert_array_equal(c[24:], 1.0)
    assert NeuralConfig(32, 128).parameter_count == 8320  # seed 002: "equals to 8320"
    assert list(fixed_diffusion(12)) == [0.125] * 3 + [0.25] * 3 + [0.5] * 3 + [1.0] * 3


@pytest.mark.slow
def test_one_euler_step_is_eq1_with_the_3x3_kernel():
    """x' = x + c_i (K * x_i) d + f(x) r with K = KERNEL_SCALE * 9-point Laplacian."""
    config = NeuralConfig(4, 8)
    w = random_weights(config)
    model = neural_model(config, w)
    grid = Grid((10, 12), stencil=9)
    rng = np.random.default_rng(1)
    x = rng.normal(size=(4, 10, 12)).astype(np.float32)
    r, d = 0.7, 0.9
    p = {**model.params, "r": r, "d": d}
    got = np.asarray(make_step(model, grid)(jnp.asarray(x), p, 0.0, 1.0, None))

    kernel = KERNEL_SCALE * np.array([[1, 4, 1], [4, -20, 4], [1, 4, 1]]) / 6.0
    lap = sum(
        kernel[i + 1, j + 1] * np.roll(x, (-i, -j), axis=(1, 2))
        for i in (-1, 0, 1) for j in (-1, 0, 1)
    )
    xs = np.moveaxis(x, 0, -1).astype(np.float64)
    z = xs @ w["W0"] + w["b0"]
    f = (z / (1 + np.exp(-5 * z))) @ w["W1"]  # act(z) = z sigmoid(5 z)
    want = x + fixed_diffusion(4)[:, None, None] * lap * d + np.moveaxis(f, -1, 0) * r
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)


def test_reaction_uses_only_the_cell_and_a_spatial_rate_field():
    """With a uniform state there is no diffusion; where r = 0 nothing changes (fig. 4's r)."""
    config = NeuralConfig(5, 16)
    model = neural_model(config, random_weights(config, 2, 0.3))
    grid = Grid((6, 8), stencil=9)  # the seed's stencil; dt = 1 sits on the 5-point margin
    x = np.broadcast_to(np.linspace(-0.5, 0.5, 5)[:, None, None], (5, 6, 8)).astype(np.float32)
    r = np.zeros((6, 8), np.float32)
    r[:, 4:] = 1.0
    sol = simulate(model, grid, x, {**model.params, "r": r}, steps=1, dt=1.0)
    np.testing.assert_allclose(sol.state[:, :, :4], x[:, :, :4], rtol=0, atol=1e-6)
    change = sol.state[:, :, 4:] - x[:, :, 4:]
    assert np.abs(change).max() > 1e-3
    np.testing.assert_allclose(change, change[:, :1, :1] * np.ones_like(change), atol=1e-6)


def test_pure_diffusion_decays_a_3d_fourier_mode_exactly():
    """W1 = 0: channel i decays by 1 + c_i d KERNEL_SCALE lambda_k per step (7-point, 3D)."""
    config = NeuralConfig(4, 4)
    model = neural_model(config, init_weights(config, jax.random.PRNGKey(0)))
    shape = (8, 10, 12)
    grid = Grid(shape)
    z, y, x = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    k = 2 * np.pi * np.array([1 / 8, 2 / 10, 1 / 12])
    mode = np.cos(k[0] * z + k[1] * y + k[2] * x)
    u0 = np.broadcast_to(mode, (4, *shape)).astype(np.float32)
    lam = sum(2 * np.cos(ki) - 2 for ki in k)
    steps, dt = 20, 0.5
    sol = simulate(model, grid, u0, model.params, steps=steps, dt=dt)
    for i, c in enumerate(fixed_diffusion(4)):
        factor = (1 + dt * c * KERNEL_SCALE * lam) ** steps
        np.testing.assert_allclose(sol.state[i], factor * mode, atol=2e-5)


@pytest.mark.slow
def test_runs_on_a_mesh_and_conserves_mass_without_reaction():
    trimesh = pytest.importorskip("trimesh")
    from morphogen.domains.mesh import Mesh

    sphere = trimesh.creation.icosphere(subdivisions=2, radius=3.0)
    mesh = Mesh(np.asarray(sphere.vertices), np.asarray(sphere.faces))
    config = NeuralConfig(4, 8)
    model = neural_model(config, init_weights(config, jax.random.PRNGKey(0)))
    rng = np.random.default_rng(0)
    u0 = rng.uniform(-1, 1, (4, mesh.n_vertices)).astype(np.float32)
    sol = simulate(model, mesh, u0, model.params, steps=50, dt=0.05)
    before = np.asarray(mesh.mass(jnp.asarray(u0)))
    after = np.asarray(mesh.mass(jnp.asarray(sol.state)))
    np.testing.assert_allclose(after, before, rtol=1e-4, atol=1e-4)
    assert sol.state.std(axis=1).max() < u0.std(axis=1).min()


@pytest.mark.slow
def test_save_load_round_trip_gives_bit_identical_rollouts(tmp_path):
    config = NeuralConfig(6, 12, learn_diffusion=True)
    w = random_weights(config, 3)
    w["c_hat"] = np.linspace(-2, 2, 6).astype(np.float32)
    path = save_neural_model(tmp_path / "rule.npz", config, w, {"target": "dots.png"})
    loaded = load_neural_model(path)
    original = neural_model(config, w)
    grid = Grid((16, 16), stencil=9)
    u0 = np.random.default_rng(4).normal(0, 0.5, (6, 16, 16)).astype(np.float32)
    a = simulate(original, grid, u0, original.params, steps=30, dt=1.0).state
    b = simulate(loaded, grid, u0, loaded.params, steps=30, dt=1.0).state
    np.testing.assert_array_equal(a, b)
    cfg, weights, meta = read_neural_file(path)
    assert cfg == config and meta["target"] == "dots.png"
    assert set(weights) == {"W0", "b0", "W1", "c_hat"}


def test_bad_files_and_weights_are_one_line_errors(tmp_path):
    config = NeuralConfig(4, 8)
    w = init_weights(config, jax.random.PRNGKey(0))
    with pytest.raises(MorphogenError, match="W1"):
        neural_model(config, {k: v for k, v in w.items() if k != "W1"})
    with pytest.raises(MorphogenError, match="shape"):
        neural_model(config, {**w, "W0": np.zeros((3, 8))})
    with pytest.raises(MorphogenError, match="does not exist"):
        load_neural_model(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(MorphogenError, match="not a morphogen neural model"):
        load_neural_model(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip file")
    with pytest.raises(MorphogenError, match="cannot read"):
        load_neural_model(tmp_path / "junk.npz")
    with pytest.raises(MorphogenError, match="at least 3 channels"):
        NeuralConfig(2, 8)


@pytest.mark.slow
def test_weights_are_runtime_parameters_with_gradients():
    """Weights passed in the parameter dict override the model's own inside one compiled step,
    and jax.grad reaches them."""
    config = NeuralConfig(4, 8)
    w_a, w_b = random_weights(config, 5), random_weights(config, 6)
    model = neural_model(config, w_a)
    assert set(model.params) == {"r", "d"}
    grid = Grid((8, 8), stencil=9)
    step = jax.jit(make_step(model, grid))
    u = jnp.asarray(np.random.default_rng(7).normal(0, 0.3, (4, 8, 8)), jnp.float32)
    own = step(u, model.params, 0.0, 1.0, None)
    via_a = step(u, {**model.params, **w_a}, 0.0, 1.0, None)
    via_b = step(u, {**model.params, **w_b}, 0.0, 1.0, None)
    # Baked-in constants and runtime weights compile to different programs: equal to rounding.
    np.testing.assert_allclose(own, via_a, rtol=1e-6, atol=1e-6)
    assert float(jnp.abs(via_b - via_a).max()) > 1e-3
    other = neural_model(config, w_b)
    own_b = jax.jit(make_step(other, grid))(u, other.params, 0.0, 1.0, None)
    np.testing.assert_allclose(via_b, own_b, rtol=1e-6, atol=1e-6)

    def loss(w1):
        return jnp.sum(step(u, {**model.params, **w_a, "W1": w1}, 0.0, 1.0, None) ** 2)

    g = jax.grad(loss)(jnp.asarray(w_a["W1"]))
    assert g.shape == (8, 4) and float(jnp.abs(g).max()) > 0


@pytest.mark.parametrize("size", ["24x20", "6x12x10"])
@pytest.mark.slow
def test_simulate_command_draws_the_rgb_channels(tmp_path, size):
    """``morphogen simulate rule.npz`` shows x0, x1, x2 as red, green, blue (x + 0.5) in
    ``final.png`` (the mid-plane of a volume, plus a montage of slices); ``--species`` or
    ``--cmap`` draws one channel through a colour map instead."""
    config = NeuralConfig(4, 8)
    path = save_neural_model(tmp_path / "rule.npz", config, random_weights(config, 2, 0.3))
    out = tmp_path / "run"
    assert main(["simulate", str(path), "--size", size, "--steps", "20", "--out", str(out)]) == 0
    state = np.load(out / "state.npz")
    rgb = np.stack([state[f"x{i}"] for i in range(3)], axis=-1) + 0.5
    if rgb.ndim == 4:
        rgb = rgb[rgb.shape[0] // 2]
        assert (out / "montage.png").is_file()
    assert rgb.std() > 0.01
    expected = np.clip(rgb * 255 + 0.5, 0, 255).astype(np.uint8)
    drawn = iio.imread(out / "final.png").astype(int)
    assert np.abs(drawn - expected).max() <= 1  # one level of rounding between programs
    mapped = tmp_path / "mapped"
    assert main(["simulate", str(path), "--size", size, "--steps", "20", "--species", "x1",
                 "--out", str(mapped)]) == 0
    assert not np.array_equal(iio.imread(mapped / "final.png"), expected)
