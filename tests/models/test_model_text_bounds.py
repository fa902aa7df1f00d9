"""The model-file front end is bounded: parsing costs work linear in the file (thousands of
parameters parse), nesting is refused beyond a small depth with one line (on the command line
and as HTTP 400 on the web routes that take ``equations``), and the fuzz targets can reach
both (the model-text target takes large inputs and is seeded with deep and wide files)."""

from __future__ import annotations

import sys

import pytest

from morphogen.errors import MorphogenError
from morphogen.models.text import equations
from morphogen.models.text.equations import parse_model
from morphogen.models.text.toml_text import MAX_DEPTH, too_deep

MODEL = """species = ["u", "v"]
[parameters]
a = 0.1
b = 0.9
[equations]
u = "a - u + u**2*v + lap(u)"
v = "b - u**2*v + 40*lap(v)"
"""


def _many_parameters(count: int) -> str:
    params = "".join(f"p{i} = {i % 7 + 0.5}\n" for i in range(count))
    used = "+".join(f"p{i}" for i in range(min(count, 100)))
    return f'species = ["u"]\n[parameters]\n{params}[equations]\nu = "({used})*1e-6 - u"\n'


class _OverBudget(BaseException):
    """Raised inside the parser when it executes more lines of Python than allowed."""


def _lines_executed(call, budget: int) -> int:
    """Lines of Python ``call()`` executes (every module: the parser, tomllib, re), stopping
    it with :class:`_OverBudget` past ``budget``: a measure of work that does not depend on
    the machine's speed or load."""
    count = 0

    def local(frame, event, arg):
        nonlocal count
        if event == "line":
            count += 1
            if count > budget:
                raise _OverBudget
        return local

    sys.settrace(lambda frame, event, arg: local)
    try:
        call()
    finally:
        sys.settrace(None)
    return count


def test_parsing_5000_parameters_is_linear_work():
    per_parameter = 300  # about 160 today, nearly all of it tomllib's
    work = {}
    for n in (1000, 5000):
        text = _many_parameters(n)
        try:
            work[n] = _lines_executed(lambda t=text: parse_model(t), per_parameter * n)
        except _OverBudget:
            pytest.fail(f"parsing {n} parameters executed more than {per_parameter * n} lines")
    assert work[5000] < 6 * work[1000], work  # five times the parameters, about five times the work
    model = parse_model(_many_parameters(5000))
    assert len(model.params) == 5000 and model.params["p4999"] == 4999 % 7 + 0.5


def test_error_positions_come_from_one_index_of_the_lines(monkeypatch):
    built = []
    original = equations.KeyIndex

    class Counting(original):
        def __init__(self, lines):
            built.append(len(lines))
            super().__init__(lines)

    monkeypatch.setattr(equations, "KeyIndex", Counting)
    text = _many_parameters(2000).replace("p1999 = ", 'p1999 = "x" #')
    with pytest.raises(MorphogenError, match=r"line 2002, column 1: parameter p1999 must be"):
        parse_model(text)
    assert len(built) == 1  # every key located through one index, built once


@pytest.mark.parametrize("text, at", [
    ('x = "[" # [[\nk = 1\n', None),
    ("x = '[[[[[[[[[[[[[[[[[[[['\n", None),
    ('x = """\n[[[[[[[[[[[[[[[[[[[[\n"""\n', None),
    ("x = '''[[[[[[[[[[[[[[[[[[[[[['''\n", None),
    ('x = "\\"[[[[[[[[[[[[[[[[[[[[[["\n', None),
    ("# [[[[[[[[[[[[[[[[[[[[[[[[\n", None),
    ("x = " + "[" * (MAX_DEPTH + 1), (1, 5 + MAX_DEPTH)),
    ("k = 1\nx = [" + "{a = " * MAX_DEPTH, (2, 6 + 5 * (MAX_DEPTH - 1))),
    ('s = "a"\nx = """\n"""\ny = ' + "[" * 40, (4, 5 + MAX_DEPTH)),
])
def test_depth_scan_skips_strings_and_comments(text, at):
    assert too_deep(text) == at


DEEP = {
    "arrays 17 deep": "deep = " + "[" * 17 + "1" + "]" * 17 + "\n",
    "arrays 500 deep": "deep = " + "[" * 500 + "1" + "]" * 500 + "\n",
    "arrays 100000 deep": "deep = " + "[" * 100_000 + "\n",
    "arrays 1500 deep, unclosed": "deep = " + "[" * 1500 + "\n",
    "inline tables 700 deep, unclosed": "deep = " + "{a = " * 700 + "\n",
    "inline tables 2000 deep": "deep = " + "{a = " * 2000 + "1" + "}" * 2000 + "\n",
    "mixed 1000 deep": "deep = " + "[{a = " * 500 + "1" + "}]" * 500 + "\n",
    "in a parameter": "[parameters]\nq = " + "[" * 3000 + "\n",
    "in an equation": '[equations]\nw = ' + "[" * 3000 + "\n",
}


@pytest.mark.parametrize("case", sorted(DEEP))
def test_deep_nesting_is_one_line(case):
    with pytest.raises(MorphogenError, match="nested more than") as info:
        parse_model(DEEP[case] + MODEL)
    message = str(info.value)
    assert "\n" not in message and ("line 1," in message or "line 2," in message), message


def test_a_recursion_error_from_tomllib_is_one_line_too(monkeypatch):
    monkeypatch.setattr(equations, "too_deep", lambda text: None)  # as if the scan missed it
    with pytest.raises(MorphogenError, match="nested more than"):
        parse_model(DEEP["arrays 100000 deep"] + MODEL)


def test_the_bounded_toml_reader_for_other_files():
    import tomllib

    from morphogen.models.text.toml_text import loads

    assert loads('a = [[1], {b = "[[["}]\n') == {"a": [[1], {"b": "[[["}]}
    for text in (DEEP["arrays 100000 deep"], DEEP["inline tables 2000 deep"]):
        with pytest.raises(tomllib.TOMLDecodeError, match=r"nested more than 16 deep \(at line"):
            loads(text)


def test_deep_nesting_on_the_command_line(tmp_path, capsys):
    from morphogen.cli.main import main

    model = tmp_path / "deep.toml"
    model.write_text(DEEP["arrays 500 deep"] + MODEL)
    assert main(["simulate", str(model), "--size", "8x8", "--steps", "2", "--quiet", "--out",
                 str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nested more than" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("route, body", [
    ("/api/models/parse", lambda text: {"equations": text}),
    ("/api/mesh", lambda text: {"model": {"equations": text}}),
    ("/api/evolve", lambda text: {"model": {"equations": text}}),
    ("/api/live", lambda text: {"model": {"equations": text}, "size": 16}),
])
def test_deep_nesting_on_the_web_is_400(client, route, body):
    for case in ("arrays 1500 deep, unclosed", "inline tables 700 deep, unclosed"):  # < 4000
        r = client.post(route, json=body(DEEP[case] + MODEL))
        assert r.status_code == 400, (route, r.status_code, r.text[:200])
        assert "nested more than" in r.json()["error"]


def test_fuzz_seeds_reach_deep_nesting_and_many_parameters(tmp_path):
    from fuzz.run import MAX_LEN, seed_corpus

    seeds = {p.name: p.read_bytes() for p in seed_corpus("equations", tmp_path).iterdir()}
    assert MAX_LEN["equations"] >= 64 * 1024
    assert all(len(data) <= MAX_LEN["equations"] for data in seeds.values())
    deep = [n for n in seeds if n.startswith(("deep-", "inline-"))]
    wide = [n for n in seeds if n.startswith("parameters-")]
    assert deep and wide
    for name in deep:
        with pytest.raises(MorphogenError, match="nested more than"):
            parse_model(seeds[name].decode())
    for name in wide:
        text = seeds[name].decode()
        assert text.count("\n") > 4000
        _lines_executed(lambda t=text: parse_model(t), 300 * 5000)
