"""Fixtures shared by several test files."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest

from morphogen.util import compile_cache


@pytest.fixture(scope="session", autouse=True)
def shared_compile_cache(tmp_path_factory):
    """One compilation cache for the whole run, shared by the pytest-xdist workers and the
    processes the tests start (they inherit the environment), never the user's own cache;
    ``MORPHOGEN_COMPILE_CACHE`` set beforehand (a folder, or ``off``) is kept."""
    if compile_cache.ENV in os.environ:
        compile_cache.enable()
        return
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    os.environ[compile_cache.ENV] = str(root / "compile-cache")
    # A throwaway folder: unbounded (no listing of thousands of entries at every store), and
    # only programs worth a disk read.
    os.environ.setdefault("JAX_COMPILATION_CACHE_MAX_SIZE", "-1")
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.2")
    compile_cache.enable()


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray on loopback with two CPUs, no dashboard and no usage statistics."""
    ray = pytest.importorskip("ray", reason='ray is not installed (pip install "morphogen[ray]")')
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1",
             log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


@pytest.fixture
def quality_diversity_run() -> Callable[..., None]:
    """``run(archive, out, generations, seed, strategy="map-elites")``: a small Gray-Scott
    MAP-Elites search from the command line (Skaggs table 3.1, 24², 6 per generation), recorded
    in ``archive`` with its run folder ``out``."""
    from morphogen.cli.main import main

    def run(archive: str | Path, out: str | Path, generations: int, seed: int,
            strategy: str = "map-elites") -> None:
        assert main(["evolve", "gray-scott", "--size", "24", "--dt", "0.5", "--steps", "120",
                     "--init", "skaggs", "--preset", "skaggs-table-3.1", "--population", "6",
                     "--strategy", strategy, "--generations", str(generations), "--seed",
                     str(seed), "--quiet", "--archive", str(archive), "--out", str(out)]) == 0

    return run


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    """A test client of the web app with its own archive, answering a server error as HTTP 500
    instead of raising it, so that a test can assert a hostile request never gets one. Test
    modules that need another app (examples, hosts) define their own ``client``."""
    from fastapi.testclient import TestClient

    from morphogen.web.app import create_app

    archive = tmp_path_factory.mktemp("archive") / "index.sqlite"
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"]),
                    raise_server_exceptions=False) as c:
        yield c
