"""User-written equations: the safe expression compiler and TOML model files."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import integrate, simulate
from morphogen.errors import MorphogenError
from morphogen.models.expr import ExpressionError, compile_expression
from morphogen.models.library import get_model
from morphogen.models.model import Tensor
from morphogen.models.registry import load_model
from morphogen.models.text.equations import load_model_file, parse_model
from morphogen.solvers.step import make_step
from tests.paths import EXAMPLES

BASE = """name = "t"
species = ["u", "v"]
[parameters]
a = 0.1
Du = 1.0
[equations]
u = "a - u + Du*lap(u)"
v = "{V}"
"""
"""A two-species file whose ``v`` equation is on line 8, starting at column 6."""


def _coords(grid: Grid, t: float = 0.0) -> dict:
    return {**{k: jnp.asarray(v) for k, v in grid.coords.items()}, "t": jnp.float32(t)}


def _random_state(seed: int, shape=(2, 12, 10)) -> jnp.ndarray:
    rng = np.random.default_rng(seed)
    return jnp.asarray(rng.uniform(0.0, 1.0, shape), jnp.float32)


def _with_v(expression: str) -> str:
    return BASE.replace("{V}", expression)


# ----------------------------------------------------------------------------------------------
# parsed == built-in


@pytest.mark.parametrize(
    "library_name, file", [("gray-scott", "gray-scott"), ("schnakenberg", "schnakenberg")]
)
def test_parsed_terms_equal_library(library_name, file):
    parsed = load_model_file(EXAMPLES / f"{file}.toml")
    built_in = get_model(library_name)
    grid = Grid((12, 10))
    c = _coords(grid)
    assert parsed.species == built_in.species
    assert dict(parsed.params) == dict(built_in.params)
    for seed in range(3):
        u = _random_state(seed)
        p = {k: jnp.float32(v * (1 + 0.1 * seed)) for k, v in built_in.params.items()}
        np.testing.assert_allclose(parsed.reaction(u, p, c), built_in.reaction(u, p, c),
                                   rtol=1e-6, atol=1e-7)
        for d_parsed, d_lib in zip(parsed.diffusion(p, c), built_in.diffusion(p, c), strict=True):
            np.testing.assert_allclose(d_parsed, d_lib, rtol=1e-6)
    np.testing.assert_allclose(
        parsed.ground_state(parsed.parameters()), built_in.ground_state(built_in.parameters())
    )


@pytest.mark.slow
def test_parsed_gray_scott_simulates_identically():
    parsed = load_model_file(EXAMPLES / "gray-scott.toml")
    built_in = get_model("gray-scott")
    grid = Grid((24, 24))
    u0 = np.stack([np.ones((24, 24)), np.zeros((24, 24))]).astype(np.float32)
    u0[0, 9:15, 9:15], u0[1, 9:15, 9:15] = 0.5, 0.25
    params = built_in.parameters(preset="mazes")
    runs = [
        simulate(model, grid, jnp.asarray(u0), model.parameters(preset="mazes"), steps=300, dt=1.0)
        for model in (parsed, built_in)
    ]
    assert parsed.parameters(preset="mazes") == params
    np.testing.assert_allclose(runs[0].state, runs[1].state, rtol=1e-5, atol=1e-6)
    assert np.abs(runs[0].state - u0).max() > 0.1  # the runs did evolve the state


@pytest.mark.slow
def test_grad_through_parsed_model_matches_library_and_finite_differences():
    parsed = load_model_file(EXAMPLES / "gray-scott.toml")
    built_in = get_model("gray-scott")
    grid = Grid((8, 8))
    u0 = _random_state(3, (2, 8, 8)) * 0.5 + jnp.asarray([0.5, 0.0])[:, None, None]

    def loss(model, feed):
        p = {**{k: jnp.float32(v) for k, v in model.params.items()}, "F": feed}
        step = make_step(model, grid)
        u, _, _ = integrate(step, u0, p, steps=20, dt=1.0, key=jax.random.PRNGKey(0))
        return jnp.mean(u[1] ** 2)

    feed = jnp.float32(0.037)
    g_parsed = jax.grad(lambda f: loss(parsed, f))(feed)
    g_lib = jax.grad(lambda f: loss(built_in, f))(feed)
    # forward values agree to rounding; the backward pass may sum the repeated u*v*v terms in
    # another order, so gradients agree to float32 rounding
    np.testing.assert_allclose(float(g_parsed), float(g_lib), rtol=1e-5)
    h = 1e-3
    fd = (loss(parsed, feed + h) - loss(parsed, feed - h)) / (2 * h)
    assert abs(float(g_parsed)) > 1e-4
    np.testing.assert_allclose(float(g_parsed), float(fd), rtol=2e-2)


# ----------------------------------------------------------------------------------------------
# the Schnakenberg file and the optional sections


def test_schnakenberg_example():
    path = EXAMPLES / "schnakenberg.toml"
    model = load_model_file(path)
    assert model.species == ("u", "v")
    assert dict(model.params) == {"a": 0.1, "b": 0.9, "Du": 1.0, "Dv": 40.0}
    assert model.source == path.read_text()
    assert model.display == "u" and (model.dt, model.init) == (0.005, "noise")
    p = model.parameters()
    ground = model.ground_state(p)
    np.testing.assert_allclose(ground, [1.0, 0.9 / 1.0**2], rtol=1e-6)
    u = jnp.asarray(np.broadcast_to(ground[:, None, None], (2, 4, 4)), jnp.float32)
    c = _coords(Grid((4, 4)))
    np.testing.assert_allclose(model.reaction(u, p, c), 0.0, atol=1e-6)
    assert [float(d) for d in model.diffusion(p, c)] == [1.0, 40.0]
    spots = model.parameters(preset="spots")
    assert spots["a"] == 0.2 and spots["b"] == 1.3 and spots["Dv"] == 40.0


def test_minimal_file_without_parameters():
    model = parse_model('species = ["u"]\n[equations]\nu = "-u"\n', name="decay")
    assert model.name == "decay" and dict(model.params) == {}
    u = jnp.full((1, 3, 3), 2.0)
    np.testing.assert_array_equal(model.reaction(u, {}, _coords(Grid((3, 3)))), -u)
    assert model.diffusion({}, {}) == (0.0,)


def test_lap_forms_add_up_and_reaction_keeps_the_rest():
    text = _with_v("a - Du*lap(v)/4 + lap(v)*x - -lap(v) + u*u + lap(v)/Du")
    model = parse_model(text)
    grid = Grid((5, 6))
    c = _coords(grid)
    p = {"a": jnp.float32(0.1), "Du": jnp.float32(2.0)}
    d_u, d_v = model.diffusion(p, c)
    assert float(d_u) == 2.0
    x = np.asarray(grid.coords["x"])
    expected = np.broadcast_to(-0.5 + x + 1.0 + 0.5, (5, 6))
    np.testing.assert_allclose(np.broadcast_to(d_v, (5, 6)), expected, rtol=1e-6)
    u = _random_state(1, (2, 5, 6))
    r = model.reaction(u, p, c)
    np.testing.assert_allclose(r[1], 0.1 + u[0] * u[0], rtol=1e-6)
    np.testing.assert_allclose(r[0], 0.1 - u[0], rtol=1e-6)


def test_lap_first_and_subtracted_terms():
    model = parse_model(_with_v("lap(v) - a - u"))
    u = _random_state(2, (2, 3, 3))
    p = {"a": 0.5, "Du": 1.0}
    np.testing.assert_allclose(model.reaction(u, p, {})[1], -0.5 - u[0], rtol=1e-6)
    assert float(model.diffusion(p, {})[1]) == 1.0
    minus = parse_model(_with_v("-(Du*lap(v) - u)"))
    np.testing.assert_allclose(minus.reaction(u, p, {})[1], u[0])
    assert float(minus.diffusion(p, {})[1]) == -1.0


def test_coordinates_and_time_give_fields():
    text = """species = ["u"]
[parameters]
D0 = 0.5
[equations]
u = "x + 10*y + 100*t + D0*(1 + x)*lap(u)"
"""
    model = parse_model(text)
    grid = Grid((4, 6))
    c = _coords(grid, t=0.25)
    r = np.asarray(model.reaction(jnp.zeros((1, 4, 6)), {"D0": 0.5}, c))[0]
    cols, rows = (np.arange(6) + 0.5) / 6, (np.arange(4) + 0.5) / 4
    np.testing.assert_allclose(r, cols[None, :] + 10 * rows[:, None] + 25.0, rtol=1e-6)
    (d,) = model.diffusion({"D0": 0.5}, c)
    np.testing.assert_allclose(np.broadcast_to(d, (4, 6))[0], 0.5 * (1 + cols), rtol=1e-6)


def test_initial_excited_presets_and_hints():
    text = """species = ["u", "v"]
display = "v"
clamp = [0, 5]
t_end = 50
[parameters]
a = 2.0
[equations]
u = "a - u"
v = "u - v"
[initial]
u = "a"
v = 1
[excited]
u = "a/2"
v = 0.5
[presets.big]
a = 4
"""
    model = parse_model(text)
    assert model.ground({"a": 3.0}) == (3.0, 1.0)
    assert model.excited({"a": 3.0}) == (1.5, 0.5)
    assert model.parameters(preset="big") == {"a": 4.0}
    assert model.display == "v" and model.clamp == (0.0, 5.0) and model.t_end == 50.0


def test_anisotropy_tensor_has_the_given_principal_axes():
    text = """species = ["u"]
[parameters]
D1 = 3.0
D2 = 0.5
[equations]
u = "-u"
[anisotropy]
u = { angle = "0.3 + x", along = "D1", across = "D2" }
"""
    model = parse_model(text)
    grid = Grid((3, 4))
    (d,) = model.diffusion({"D1": 3.0, "D2": 0.5}, _coords(grid))
    assert isinstance(d, Tensor)
    x = np.asarray(grid.coords["x"])[0]
    for j, theta in enumerate(0.3 + x):
        tensor = np.array([[d.xx[0, j], d.xy[0, j]], [d.xy[0, j], d.yy[0, j]]], np.float64)
        e, e_perp = np.array([math.cos(theta), math.sin(theta)]), np.array(
            [-math.sin(theta), math.cos(theta)]
        )
        np.testing.assert_allclose(tensor @ e, 3.0 * e, atol=1e-5)
        np.testing.assert_allclose(tensor @ e_perp, 0.5 * e_perp, atol=1e-5)


def test_anisotropic_example_runs_and_stays_finite():
    model = load_model_file(EXAMPLES / "turing-anisotropic.toml")
    grid = Grid((16, 16))
    p = model.parameters()
    u0 = model.ground_state(p)[:, None, None] * (1 + 0.01 * _random_state(4, (2, 16, 16)))
    sol = simulate(model, grid, jnp.asarray(u0, jnp.float32), p, steps=50, dt=model.dt)
    assert np.all(np.isfinite(sol.state))


# ----------------------------------------------------------------------------------------------
# expression numerics


@pytest.mark.parametrize(
    "text, expected",
    [
        ("where(x < 0.5, a, b)", lambda x, a, b: np.where(x < 0.5, a, b)),
        ("where(0.22 <= x < 0.71, 1, 0)", lambda x, a, b: ((0.22 <= x) & (x < 0.71)) * 1.0),
        ("where(x != 0.5, x, -1)", lambda x, a, b: np.where(x != 0.5, x, -1.0)),
        ("lerp(a, b, x)", lambda x, a, b: a + (b - a) * x),
        ("min(x, 0.5) + max(x, a)", lambda x, a, b: np.minimum(x, 0.5) + np.maximum(x, a)),
        ("clip(x, 0.25, 0.75)", lambda x, a, b: np.clip(x, 0.25, 0.75)),
        ("sigmoid(x)", lambda x, a, b: 1 / (1 + np.exp(-x))),
        ("pow(x, 1.5) - x**3 + x**-1", lambda x, a, b: x**1.5 - x**3 + 1 / x),
        ("exp(-x) * log(1 + x) / sqrt(b) + abs(-a)", lambda x, a, b: np.exp(-x) * np.log1p(x)
         / np.sqrt(b) + abs(a)),
        ("tanh(x) + sin(x)*cos(x) - -+x", lambda x, a, b: np.tanh(x) + np.sin(x) * np.cos(x) + x),
        ("2**0.5 + 1/4 - 3", lambda x, a, b: 2**0.5 + 0.25 - 3 + 0 * x),
    ],
)
def test_functions_match_numpy(text, expected):
    expr = compile_expression(text, ["x", "a", "b"])
    x = np.linspace(0.05, 1.0, 20).astype(np.float32)
    got = np.broadcast_to(expr({"x": jnp.asarray(x), "a": 0.3, "b": 2.0}), x.shape)
    np.testing.assert_allclose(got, expected(x.astype(np.float64), 0.3, 2.0), rtol=1e-5, atol=1e-6)


def test_expression_reports_its_names():
    assert compile_expression("a*exp(u) + min(u, t)", ["a", "u", "t"]).names == {"a", "u", "t"}


# ----------------------------------------------------------------------------------------------
# rejection


@pytest.mark.parametrize(
    "expression, column, fragment",
    [
        ("__import__('os').system('x')", 22, "attribute access"),
        ("u.__class__", 7, "attribute access"),
        ("().__class__.__bases__[0]", 6, "indexing"),
        ("(u, v)", 6, "tuple"),
        ("lambda: 1", 6, "lambda"),
        ("open('f')", 6, "unknown function 'open'"),
        ("getattr(u, 'x')", 6, "unknown function 'getattr'"),
        ("__builtins__", 6, "names starting with '_'"),
        ("u[0]", 6, "indexing"),
        ("[c for c in u]", 6, "comprehension"),
        ("'abc'", 6, "strings are not allowed"),
        ("exp(x=1)", 6, "no keywords"),
        ("exp(*u)", 10, "unpacking"),
        ("a if u else v", 6, "where("),
        ("u % 2", 6, "operator %"),
        ("u > 1", 6, "condition of where"),
        ("where(u > 0 and v > 0, 1, 0)", 12, "'and'/'or'"),
        ("min(u)", 6, "takes 2 argument"),
        ("exp", 6, "exp is a function"),
        ("u + c", 10, "unknown name 'c'"),
        ("u*\\u0061 + \\\"s\\\"", 17, "strings are not allowed"),  # TOML escapes
        ("u + * v", 10, "syntax error"),
        ("u + (v", 10, "never closed"),
        ("u +", 9, "ends too early"),
        ("True", 6, "True is not allowed"),
        ("Du*lap(u)", 9, "own species"),
        ("exp(lap(v))", 10, "inside exp()"),
        ("u*lap(v)", 6, "species 'u'"),
        ("lap(v)**2", 6, "in a power"),
        ("a/lap(v)", 8, "denominator"),
        ("a*(lap(v) + u)", 9, "inside brackets"),
        ("t*lap(v)", 6, "time t"),
        ("lap(u + v)", 10, "takes a species name"),
    ],
)
def test_unsafe_or_invalid_equations_are_rejected_with_position(expression, column, fragment):
    with pytest.raises(MorphogenError) as info:
        parse_model(_with_v(expression), path="bad.toml")
    message = str(info.value)
    assert message.startswith(f"bad.toml: line 8, column {column}: ")
    assert fragment in message
    assert "\n" not in message


def test_payload_is_never_executed(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for payload in ("__import__('pathlib').Path('pwned').touch()", "open('pwned', 'w')"):
        with pytest.raises(MorphogenError):
            parse_model(_with_v(payload))
    assert not (tmp_path / "pwned").exists()


def test_multiline_equation_positions():
    text = 'species = ["u"]\n[equations]\nu = """\n1 +\n  2 * q\n"""\n'
    with pytest.raises(MorphogenError, match=r"line 5, column 7: .*unknown name 'q'"):
        parse_model(text)
    ok = parse_model('species = ["u"]\n[equations]\nu = """\n  1 +\n    2 * u\n  + lap(u)\n"""\n')
    assert float(ok.reaction(jnp.ones((1, 3, 3)), {}, {})[0, 0, 0]) == 3.0
    assert ok.diffusion({}, {}) == (1.0,)


def test_expression_errors_are_positioned_in_other_sections():
    aniso = 'species = ["u"]\n[equations]\nu = "0"\n[anisotropy]\n' \
            'u = { angle = "0.3 + q", along = "1", across = "2" }\n'
    with pytest.raises(MorphogenError, match=r"line 5, column 22: anisotropy u.angle"):
        parse_model(aniso)
    initial = 'species = ["u"]\n[equations]\nu = "0"\n[initial]\nu = "u"\n'
    with pytest.raises(MorphogenError, match=r"line 5, column 6: \[initial\] u: unknown name"):
        parse_model(initial)


def test_overlong_or_deep_expressions_are_rejected():
    with pytest.raises(ExpressionError, match="nests deeper"):
        compile_expression("+".join(["u"] * 400), ["u"])
    with pytest.raises(ExpressionError, match="line 1"):
        compile_expression("(" * 300 + "u" + ")" * 300, ["u"])
    with pytest.raises(ExpressionError, match="longer than"):
        compile_expression("u" * 30_000, ["u"])


@pytest.mark.parametrize(
    "text, fragment",
    [
        ('name = "t"\nspecies = ["u"\n', "line 2, column 15: invalid TOML"),
        ('[equations]\nu = "1"\n', "no species list"),
        ('species = ["u"]\n', "no [equations] table"),
        ('species = ["u"]\n[equations]\nu = "1"\nw = "2"\n', "line 4, column 1: [equations] "
         "has an equation for 'w'"),
        ('species = ["u", "v"]\n[equations]\nu = "1"\n', "species 'v' has no equation"),
        ('species = ["u", "u"]\n[equations]\nu = "1"\n', "listed twice"),
        ('species = []\n[equations]\n', "non-empty list"),
        ('species = ["u"]\n[parameters]\nexp = 1\n[equations]\nu = "1"\n', "'exp' is reserved"),
        ('species = ["u"]\n[parameters]\nx = 1\n[equations]\nu = "1"\n', "'x' is reserved"),
        ('species = ["t"]\n[equations]\nt = "1"\n', "species name 't' is reserved"),
        ('species = ["u"]\n[parameters]\nu = 1\n[equations]\nu = "1"\n', "both a species"),
        ('species = ["u"]\n[parameters]\na = 1\na = 2\n[equations]\nu = "1"\n',
         "line 4, column 6: invalid TOML: Cannot overwrite"),
        ('species = ["u"]\n[parameters]\na = "1"\n[equations]\nu = "1"\n', "must be a number"),
        ('species = ["u"]\n[parameters]\nlambda = 1\n[equations]\nu = "1"\n', "not usable"),
        ('species = ["u"]\n[parameter]\na = 1\n[equations]\nu = "1"\n', "unknown key 'parameter'"),
        ('species = ["u"]\n[equations]\nu = [1]\n', "line 3, column 1: the equation for u"),
        ('species = ["u"]\ndisplay = "w"\n[equations]\nu = "0"\n', "display = 'w'"),
        ('species = ["u"]\n[parameters]\na = 1\n[equations]\nu = "0"\n[presets.s]\nb = 1\n',
         "preset 's' sets unknown parameter 'b'"),
        ('species = ["u"]\n[equations]\nu = "lap(u)"\n[anisotropy]\n'
         'u = { along = "1", across = "2" }\n', "both a lap() term and an [anisotropy]"),
        ('species = ["u"]\n[equations]\nu = "0"\n[anisotropy]\nu = { along = "1" }\n',
         "takes angle"),
        ('species = ["u"]\n[equations]\nu = "0"\n[initial]\n', "needs a value for every"),
        ('species = ["u"]\nclamp = [1, 0]\n[equations]\nu = "0"\n', "low < high"),
        ('species = ["u"]\ninit = "nope"\n[equations]\nu = "0"\n', "not an initial condition"),
    ],
)
def test_malformed_files_give_one_line_errors(text, fragment):
    with pytest.raises(MorphogenError) as info:
        parse_model(text, path="m.toml")
    message = str(info.value)
    assert message.startswith("m.toml: ") and fragment in message and "\n" not in message


# ----------------------------------------------------------------------------------------------
# loading


def test_load_model_resolves_names_and_files(tmp_path):
    assert load_model("gray-scott").name == "gray-scott"
    assert load_model(str(EXAMPLES / "schnakenberg.toml")).name == "schnakenberg-file"
    plain = tmp_path / "mymodel"
    plain.write_text('species = ["u"]\n[equations]\nu = "-u"\n')
    assert load_model(plain).name == "mymodel"
    with pytest.raises(MorphogenError, match="not found"):
        load_model(tmp_path / "missing.toml")
    with pytest.raises(MorphogenError, match="unknown model"):
        load_model("no-such-model")
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(MorphogenError, match="not UTF-8"):
        load_model_file(tmp_path / "bin.toml")
