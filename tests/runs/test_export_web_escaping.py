"""User text on the pages the project writes is escaped for where it lands (no browser here).

The exported page (`morphogen export-web`, morphogen/runs/web_page.py) is filled in one pass
and its user text is escaped per context: a model named with markup, ``</script>``, ``<!--``,
U+2028 or the template's own placeholders (``@DATA@``, ``@STEP@``, ``@SCRIPT@``) gives a page
whose elements are exactly the template's and whose data hold the name unchanged. The same for
the gallery page (`write_gallery`, used by `gallery`, `demo` and the neural gallery). The pages
are run in Chromium by tests/e2e/test_export_page_injection.py.
"""

from __future__ import annotations

import json
from html.parser import HTMLParser

import pytest

from morphogen.cli.main import main
from morphogen.runs.config import RunConfig
from morphogen.runs.web_page import export_page
from morphogen.util.markup import fill, html_text, script_json

# the handler needs no quotes, so it would survive being written into JSON: in a page filled
# by chained replacements it ran (window.__pwned = 1, the title "pwned")
HOSTILE_NAME = ("x@DATA@<img src=x onerror=window.__pwned=1;document.title=/pwned/.source>"
                "@STEP@ @SCRIPT@ @TITLE@</script><script>window.__pwned=2</script><!-- "
                "\u2028\u2029 & ' \"")

# a model file the equation parser accepts: the name is free text, the species and parameters
# are names a page's script or markup might trip on
HOSTILE_MODEL = """name = {name}
species = ["img", "script"]
display = "script"
dt = 0.05

[parameters]
constructor = 0.5
onerror = 1.0
Du = 1.0
Dv = 0.5

[equations]
img = "onerror*(constructor - img) + Du*lap(img)"
script = "img - script + Dv*lap(script)"
"""


def hostile_model_text(name: str = HOSTILE_NAME) -> str:
    return HOSTILE_MODEL.format(name=json.dumps(name))


class _Elements(HTMLParser):
    """The start tags of a page, with the text of each <script> and of <title> and <h1>."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.text: dict[str, list[str]] = {}
        self._open: str | None = None

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag in ("script", "title", "h1"):
            self._open = tag
            self.text.setdefault(tag, []).append("")

    def handle_endtag(self, tag):
        if tag == self._open:
            self._open = None

    def handle_data(self, data):
        if self._open:
            self.text[self._open][-1] += data

    def handle_comment(self, data):
        self.tags.append("<!--")


def elements(page: str) -> _Elements:
    parser = _Elements()
    parser.feed(page)
    parser.close()
    return parser


# --- the escaping itself ----------------------------------------------------------------------


def test_script_json_cannot_close_the_script_or_open_a_comment():
    value = {"name": HOSTILE_NAME, "k</script>": ["<!--", "-->", "\u2028"]}
    text = script_json(value)
    for bad in ("<", ">", "&", "\u2028", "\u2029"):
        assert bad not in text
    assert "\\u003c/script\\u003e" in text and "\\u003c!--" in text
    assert json.loads(text) == value  # still the same JSON value


def test_script_json_refuses_non_finite_numbers():
    with pytest.raises(ValueError):
        script_json({"dt": float("nan")})


def test_html_text_escapes_text_and_both_quotes():
    assert html_text("<a href='x' title=\"y\">&") == (
        "&lt;a href=&#x27;x&#x27; title=&quot;y&quot;&gt;&amp;")


def test_fill_is_one_pass_and_strict():
    template = "<h1>@A@</h1><p>@B@</p>"
    assert fill(template, {"A": "@B@", "B": "@A@"}) == "<h1>@B@</h1><p>@A@</p>"
    with pytest.raises(KeyError, match="@B@"):
        fill(template, {"A": "a"})
    with pytest.raises(KeyError, match="@C@"):
        fill(template, {"A": "a", "B": "b", "C": "c"})


# --- the exported page ------------------------------------------------------------------------


def _page_data(page: str) -> tuple[dict, str]:
    parsed = elements(page)
    data_script, step_script, _ = parsed.text["script"]
    assert step_script.startswith("const STEP_SHADER = ")
    shader = json.loads(step_script.removeprefix("const STEP_SHADER = ").removesuffix(";"))
    return json.loads(data_script), shader


def _check_page(page: str, name: str) -> None:
    parsed = elements(page)
    # exactly the template's elements: no img, no fourth script, no comment
    assert "img" not in parsed.tags and "<!--" not in parsed.tags
    assert parsed.tags.count("script") == 3
    assert parsed.text["h1"] == [parsed.text["title"][0]]
    assert parsed.text["h1"][0].startswith(name + ": ")
    data, shader = _page_data(page)
    assert data["model"] == name
    assert data["species"] == ["img", "script"] and data["show"] == 1
    assert data["names"] == ["constructor", "onerror", "Du", "Dv"]
    assert "#version 300 es" in shader
    # the page's own program is there whole, once
    assert page.count("window.morphogenPage = page;") == 1


@pytest.mark.parametrize("name", [
    HOSTILE_NAME,
    "@STEP@",
    "@SCRIPT@",
    "x@DATA@<img src=x onerror=alert(1)>",
    "</script><!--",
    "]]>\u2028<svg onload=alert(1)>",
])
def test_a_hostile_model_name_stays_text_in_the_page(tmp_path, name):
    path = tmp_path / "hostile.toml"
    path.write_text(hostile_model_text(name), encoding="utf-8")
    page = export_page(RunConfig(model=str(path), size=[12, 10], scheme="euler", seed=1,
                                 cmap="0:#000000, 0.5:#ff8800, 1:#ffffff"))
    _check_page(page, name)
    data, _ = _page_data(page)
    assert data["cmap"] == "0:#000000, 0.5:#ff8800, 1:#ffffff"
    assert (data["width"], data["height"]) == (10, 12)


def test_a_hostile_run_json_gives_a_working_page(tmp_path, capsys):
    """The model's text travels inside run.json (`model_source`): export-web from it."""
    model = tmp_path / "hostile.toml"
    model.write_text(hostile_model_text(), encoding="utf-8")
    run = tmp_path / "run"
    assert main(["simulate", str(model), "--size", "12x12", "--steps", "2", "--scheme", "euler",
                 "--quiet", "--out", str(run)]) == 0
    model.unlink()  # the run file alone holds the model
    out = tmp_path / "page.html"
    assert main(["export-web", str(run / "run.json"), "--out", str(out)]) == 0
    capsys.readouterr()
    _check_page(out.read_text(encoding="utf-8"), HOSTILE_NAME)


# --- the gallery page -------------------------------------------------------------------------


def test_gallery_captions_and_title_stay_text(tmp_path):
    from morphogen.render.gallery import write_gallery

    (tmp_path / "a b\"'<x>.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    caption = "<img src=x onerror=alert(1)>\" onmouseover=\"alert(2)"
    page = write_gallery(tmp_path, "</title><script>alert(3)</script>", [
        ("a b\"'<x>.png", caption)], intro="<!-- @TITLE@ -->").read_text()
    parsed = elements(page)
    assert parsed.tags.count("img") == 1 and "script" not in parsed.tags
    assert "<!--" not in parsed.tags
    assert parsed.text["title"] == ["</title><script>alert(3)</script>"]

    class Attrs(HTMLParser):
        img: dict = {}

        def handle_starttag(self, tag, attrs):
            if tag == "img":
                Attrs.img = dict(attrs)

    Attrs().feed(page)
    assert Attrs.img["alt"] == caption and "onmouseover" not in Attrs.img
    assert Attrs.img["src"] == "a%20b%22%27%3Cx%3E.png"
