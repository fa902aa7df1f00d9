"""End-to-end tests of how the pages show results: numerically unstable atlas tiles, and the
Explore page's Match panel (``results.mjs``, ``match.mjs``; the Evolve page's reload and stop
are in ``test_browser.py``'s Evolve scenario)."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest

from tests.e2e.browser_support import OUT, scenario

pytestmark = pytest.mark.slow


def test_atlas_counts_and_names_unstable_tiles(server):
    """Gray-Scott at k = 0 ends in a checkerboard at dt = 1: the page counts those tiles (the
    server's full report as the line's title) and names them on hover; a sound tile is not."""
    data = scenario(server, "atlasunstable")
    # before it, the user's own cancel of a long atlas: said plainly, not as an error
    assert data["cancelled"] == {"error": "", "message": "Cancelled: no atlas computed."}
    assert data["valid"] == [[True, True], [False, False]]
    line = data["line"]
    assert not line["hidden"] and line["text"].startswith("2 of 4 tiles numerically unstable")
    assert line["title"].startswith("2 of 4 tiles were numerically unstable at dt=1")
    top, bottom = data["hovers"]
    assert "unstable" not in top and bottom.endswith("numerically unstable (not a pattern)")
    # the mosaic downloads; once the server has forgotten it, the page says so (no 404 saved)
    assert data["gone"]["saved"] == "atlas.png"
    assert "no longer on the server" in data["gone"]["error"]


def _spots(n: int = 128, period: float = 12.0) -> np.ndarray:
    """Three cosines 120 degrees apart, sharpened: dark spots on a light ground, grey uint8."""
    y, x = np.mgrid[0:n, 0:n].astype(float)
    k = 2 * np.pi / (period * np.sqrt(3) / 2)
    f = sum(np.cos(k * (x * np.cos(a) + y * np.sin(a))) for a in (0, 2 * np.pi / 3, 4 * np.pi / 3))
    return (255 * (np.tanh(f) + 1) / 2).astype(np.uint8)


def test_match_panel_finds_a_model_and_opens_it_in_explore(server):
    """The panel offers the match's models with the smallest budget; a chosen picture is shown,
    matched against Gray-Scott with a progress bar, and its candidate (picture, model,
    parameters, an Open in Explore button) replaces Explore's Schnakenberg with Gray-Scott at
    the candidate's parameters, grid spacing and grid."""
    iio.imwrite(OUT / "match-target.png", _spots())
    data = scenario(server, "match")
    panel = data["panel"]
    assert ["gray-scott", True] in panel["models"] and panel["budget"] == "8" and panel["go"]
    assert data["shown"] == 128
    assert any("simulations" in m for m in data["messages"]), data["messages"]
    assert len(data["result"]["candidates"]) == 1
    card = data["cards"][0]
    assert card["image"] > 0 and card["button"] == "Open in Explore"
    assert "gray-scott" in card["text"] and "F = " in card["text"] and "dx = " in card["text"]
    best, opened = data["best"], data["opened"]
    assert opened["model"] == "gray-scott" == best["model"]
    assert opened["params"]["F"] == pytest.approx(best["params"]["F"])
    assert opened["params"]["k"] == pytest.approx(best["params"]["k"])
    assert opened["dx"] == pytest.approx(best["dx"])
    assert [opened["height"], opened["size"]] == best["size"]
    assert opened["dt"] <= best["dt"] * (1 + 1e-6) and opened["init"] == best["init"]
    assert opened["cmap"] == "magma"  # the page's colour map, not the run file's grey


def test_a_failing_model_list_is_said_with_a_way_to_try_again(server):
    """``/api/models`` fails: the page says why where the app would be (not a blank page), and
    its button starts the app once the server answers."""
    data = scenario(server, "modelsdown")
    assert "could not list its models" in data["shown"] and "the catalogue is away" in data["shown"]
    assert data["failures"] == 1 and data["gone"]
