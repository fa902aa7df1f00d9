"""``--executor auto``: a generation is split over one Ray worker per core only when it is large,
the machine has more than one core and Ray is installed; otherwise it stays in this process."""

import importlib.util

import pytest

from morphogen.search import executors
from morphogen.search.evaluate import Problem
from morphogen.search.executors import AUTO_WORK, LocalExecutor, auto_executor, make_executor
from morphogen.search.genes import preset_genes


@pytest.fixture
def two_cores_with_ray(monkeypatch):
    monkeypatch.setattr(executors, "cores", lambda: 2)
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: object())


def test_small_generations_stay_in_this_process(two_cores_with_ray):
    assert auto_executor(AUTO_WORK - 1) == "local"
    assert auto_executor(AUTO_WORK) == "ray"


def test_one_core_or_no_ray_stays_in_this_process(monkeypatch):
    monkeypatch.setattr(executors, "cores", lambda: 1)
    assert auto_executor(100 * AUTO_WORK) == "local"
    monkeypatch.setattr(executors, "cores", lambda: 2)
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    assert auto_executor(100 * AUTO_WORK) == "local"


def test_make_executor_weighs_the_generation(two_cores_with_ray, monkeypatch):
    """Skaggs' Table 5.1 generation (20 x 256^2 x 4000 steps, 5.2e9 cell-steps) is split; a
    tiny one, or any gradient search, is not."""
    chosen = []
    monkeypatch.setattr(executors, "RayExecutor",
                        lambda problem, **kw: chosen.append(kw) or "ray-executor")
    skaggs = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                     size=(256, 256), dt=0.5, steps=4000)
    assert make_executor("auto", skaggs, population=20) == "ray-executor"
    assert chosen == [{}]
    tiny = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                   size=(24, 24), dt=0.5, steps=100)
    assert isinstance(make_executor("auto", tiny, population=20), LocalExecutor)
    monkeypatch.setattr(executors, "GradientExecutor", lambda problem: "gradient-executor")
    assert make_executor("auto", skaggs, population=20, gradient=True) == "gradient-executor"
