"""`morphogen export-web` without a browser: what the page refuses, and the generated shader.

The page's state matching `morphogen simulate` is checked in headless Chromium
(tests/e2e/test_browser.py::test_exported_page_matches_simulate).
"""

from __future__ import annotations

import json

import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.models.registry import load_model
from morphogen.render.webgl import glsl_float, step_shader
from morphogen.runs.config import RunConfig
from morphogen.runs.web_page import export_page


@pytest.mark.parametrize("settings,words", [
    ({"scheme": "imex"}, "scheme 'imex' is not supported"),
    ({"size": [8, 8, 8]}, "3D grid is not supported"),
    ({"boundary": "dirichlet=0"}, "boundary 'dirichlet=0' is not supported"),
    ({"noise": {"amplitude": 0.01}}, "noise is not supported"),
    ({"clamp": [0, 1]}, "--clamp is not supported"),
    ({"cmap": "step: #fff < 0.5 < #a00"}, "transfer-function colour maps"),
])
def test_unsupported_settings_are_refused_in_one_line(settings, words):
    config = RunConfig(model="gray-scott", **{"size": [16, 16], **settings})
    with pytest.raises(MorphogenError) as err:
        export_page(config)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_the_shader_comes_from_the_models_own_operations():
    model = load_model("gray-scott")
    shader = step_shader(model, model.parameters({}), boundary="periodic", stencil=5, dx=1.0)
    assert shader.params == ("F", "k", "Du", "Dv")
    # u*v*v, then -(...) + F*(1 - u), as _gray_scott_reaction writes it
    assert "(c.x * c.y)" in shader.source and "(1.0 - c.x)" in shader.source
    assert "o.y = c.y + u_dt * (r1 + d1 * lap.y);" in shader.source
    assert "% n" in shader.source  # periodic ghost cells wrap
    nine = step_shader(model, model.parameters({}), boundary="neumann", stencil=9, dx=0.5)
    assert glsl_float(2 / 3) in nine.source and "clamp(q, ivec2(0)" in nine.source
    assert "(0.5 * 0.5)" in nine.source


def test_a_model_file_with_where_and_exp_becomes_glsl(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text('name = "w"\nspecies = ["u"]\n[parameters]\na = 0.5\nD = 1.0\n'
                    '[equations]\nu = "where(u > a, exp(-u), u*u) + D*lap(u)"\n')
    from morphogen.models.text.equations import load_model_file

    model = load_model_file(path)
    source = step_shader(model, model.parameters({}), boundary="periodic", stencil=5,
                         dx=1.0).source
    assert "exp(" in source and " > " in source and " ? " in source


def test_cli_writes_one_self_contained_page(tmp_path, capsys):
    out = tmp_path / "page.html"
    assert main(["export-web", "gray-scott", "--size", "16x16", "--seed", "1",
                 "--out", str(out)]) == 0
    text = out.read_text()
    assert "<canvas" in text and "#version 300 es" in text
    assert "http://" not in text and "https://" not in text  # nothing to fetch
    tag = '<script id="data" type="application/json">'
    start = text.index(tag) + len(tag)
    data = json.loads(text[start:text.index("</script>", start)])
    assert (data["width"], data["height"], data["stencil"]) == (16, 16, 5)
    assert data["params"]["F"] == pytest.approx(0.037)
    capsys.readouterr()
    assert main(["export-web", "gray-scott", "--scheme", "etdrk4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "scheme 'etdrk4' is not supported" in err
