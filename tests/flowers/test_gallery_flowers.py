"""``morphogen gallery flowers``: finding the flower pipelines, running them, the index page."""

from __future__ import annotations

import re
from pathlib import Path

from morphogen.cli.main import main
from morphogen.flowers.case_studies import EXAMPLES, find_flowers

_TINY = """# A tiny petal (Ringham et al. 2021, §4.2, used only by the tests)
seed = 1
view = "top"

[mesh]
shape = "petal"
edge = 0.15

[[stage]]
name = "colour"
kind = "fields"
fields = { m = "s" }
show = "m"
cmap = "#ffffff,#aa0000"
"""


def _examples(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "examples"
    (root / "flowers").mkdir(parents=True)
    for name, text in files.items():
        (root / "flowers" / name).write_text(text)
    return root


def test_the_repository_flowers_are_found_with_their_sections() -> None:
    flowers = {f.name: f.section for f in find_flowers(EXAMPLES)}
    # model files (no [mesh] table) are not flowers; the two older mesh pipelines are
    assert "dianthus-diffusion" not in flowers
    assert flowers["platycodon"] == "4.1"
    assert flowers["primula"] == "4.3"
    assert flowers["dianthus"] == "4.4"
    assert flowers["mimulus"] == "4.5"
    assert flowers["kohleria"] == "4.7"
    assert flowers["arctostaphylos"] == "4.2"
    assert flowers["digitalis"] == "4.6"
    assert flowers["trichoglottis"] == "4.8"
    assert flowers["phalaenopsis-nankung"] == "4.9"
    assert flowers["phalaenopsis-leopard"] == "4.10"
    sections = [tuple(map(int, s.split("."))) for s in flowers.values() if s]
    assert sections == sorted(sections)


def test_gallery_runs_each_flower_and_writes_the_index(tmp_path: Path, capsys) -> None:
    examples = _examples(tmp_path, {"tiny.toml": _TINY, "model.toml": 'species = ["m"]\n'})
    out = tmp_path / "out"
    rc = main(["gallery", "flowers", "--out", str(out), "--examples", str(examples),
               "--only", "tiny"])
    assert rc == 0
    assert "[1/1] tiny (Ringham §4.2)" in capsys.readouterr().out
    png = out / "tiny" / "01-colour" / "out.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (out / "index.html").read_text()
    assert re.findall(r'<img src="([^"]+)"', page) == ["tiny/01-colour/out.png"]
    assert "tiny (Ringham §4.2)" in page
    assert '<main class="grid smooth">' in page  # mesh renders are shrunk smoothly
    assert (out / "tiny" / "final.ply").is_file()


def test_a_broken_flower_file_is_one_line_before_anything_is_made(tmp_path: Path,
                                                                   capsys) -> None:
    broken = _TINY.replace("§4.2", "§4.3").replace('kind = "fields"', 'kind = "nope"')
    examples = _examples(tmp_path, {"tiny.toml": _TINY, "broken.toml": broken})
    out = tmp_path / "out"
    assert main(["gallery", "flowers", "--out", str(out), "--examples", str(examples)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("morphogen: error: broken ("), err
    assert "stage 1: kind" in err[0]
    assert not out.exists()  # no index.html, no tiny/ run for a gallery that cannot be whole


def test_a_flower_failing_as_it_runs_is_one_line_and_the_others_still_run(
        tmp_path: Path, capsys, monkeypatch) -> None:
    from morphogen.errors import MorphogenError
    from morphogen.flowers import pipeline

    examples = _examples(tmp_path, {"tiny.toml": _TINY,
                                    "other.toml": _TINY.replace("§4.2", "§4.3")})
    real = pipeline.run_pipeline

    def run(p, out, **kw):
        if Path(out).name == "other":
            raise MorphogenError("stage 1 blew up")
        return real(p, out, **kw)

    monkeypatch.setattr(pipeline, "run_pipeline", run)
    out = tmp_path / "out"
    assert main(["gallery", "flowers", "--out", str(out), "--examples", str(examples),
                 "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["morphogen: error: other: stage 1 blew up"]
    page = (out / "index.html").read_text()
    assert re.findall(r'<img src="([^"]+)"', page) == ["tiny/01-colour/out.png"]


def test_unknown_flower_is_a_one_line_error(tmp_path: Path, capsys) -> None:
    examples = _examples(tmp_path, {"tiny.toml": _TINY})
    rc = main(["gallery", "flowers", "--out", str(tmp_path / "o"), "--examples", str(examples),
               "--only", "rose"])
    assert rc == 2
    assert capsys.readouterr().err == ("morphogen: error: unknown flower rose; choose from "
                                       "tiny\n")
    assert not (tmp_path / "o").exists()


def test_flowers_run_side_by_side_in_their_own_processes(tmp_path: Path, capsys) -> None:
    """Two flowers in two worker processes: both pictures, the page in the flowers' order
    whichever finished first, the same picture as a run in this process."""
    other = _TINY.replace("§4.2", "§4.3").replace("#aa0000", "#0000aa")
    examples = _examples(tmp_path, {"tiny.toml": _TINY, "other.toml": other})
    out, alone = tmp_path / "out", tmp_path / "alone"
    assert main(["gallery", "flowers", "--out", str(out), "--examples", str(examples),
                 "--workers", "2"]) == 0
    printed = capsys.readouterr().out
    assert "2 flowers, 2 at a time" in printed and "[2/2]" in printed
    page = (out / "index.html").read_text()
    assert re.findall(r'<img src="([^"]+)"', page) == ["tiny/01-colour/out.png",
                                                       "other/01-colour/out.png"]
    assert main(["gallery", "flowers", "--out", str(alone), "--examples", str(examples),
                 "--only", "tiny", "--workers", "1"]) == 0
    assert ((out / "tiny" / "01-colour" / "out.png").read_bytes()
            == (alone / "tiny" / "01-colour" / "out.png").read_bytes())


def test_workers_below_one_are_refused(tmp_path: Path, capsys) -> None:
    examples = _examples(tmp_path, {"tiny.toml": _TINY})
    assert main(["gallery", "flowers", "--out", str(tmp_path / "o"), "--examples",
                 str(examples), "--workers", "0"]) == 2
    assert capsys.readouterr().err == "morphogen: error: --workers takes a number >= 1, got 0\n"
    assert not (tmp_path / "o").exists()
