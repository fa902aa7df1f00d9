"""Processes for populations: the CPUs this process may use, and one Ray start shared by the
executors of parameter searches and network evolution."""

from __future__ import annotations

import os
from typing import Any

from morphogen.errors import MorphogenError

SINGLE_THREAD = "--xla_cpu_multi_thread_eigen=false"
"""``XLA_FLAGS`` of a single-threaded XLA process: the workers of a local Ray (unless the
caller set ``XLA_FLAGS``), one worker per core, and the scripts that time one process per
core. XLA has no flag for its intra-op thread pool; this one keeps Eigen's operations on the
calling thread."""


def cores() -> int:
    """CPUs this process may run on."""
    return len(os.sched_getaffinity(0))


def import_ray() -> Any:
    """The ``ray`` module, or a one-line error naming the extra to install."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    try:
        import ray
    except ImportError:
        raise MorphogenError(
            "--executor ray needs the 'ray' package: pip install \"morphogen[ray]\""
        ) from None
    return ray


def start_ray(address: str | None = None, num_cpus: int | None = None) -> Any:
    """The ``ray`` module, connected to ``address`` or to a local Ray started here (no usage
    statistics, no dashboard; workers single-threaded, :data:`SINGLE_THREAD`)."""
    ray = import_ray()
    if not ray.is_initialized():
        env = {} if address or "XLA_FLAGS" in os.environ else {"XLA_FLAGS": SINGLE_THREAD}
        try:
            ray.init(address=address, num_cpus=num_cpus, include_dashboard=False,
                     log_to_driver=False, configure_logging=False,
                     runtime_env={"env_vars": env} if env else None)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise MorphogenError(f"cannot start or reach {address or 'a local Ray'}: "
                                 f"{exc}") from None
    return ray
