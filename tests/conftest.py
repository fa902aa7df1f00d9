"""Fixtures shared by several test files."""

from __future__ import annotations

import os

import pytest


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray on loopback with two CPUs, no dashboard and no usage statistics."""
    ray = pytest.importorskip("ray", reason="the ray package is not installed (pip install ray)")
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1",
             log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()
