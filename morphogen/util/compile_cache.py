"""A persistent cache of compiled programs, shared by every command on this machine.

JAX compiles each model's step (and each search's batched evaluation) the first time it runs,
which takes seconds on a small CPU, and forgets it when the process ends. With the cache, XLA's
compiled program is stored on disk under a key of the program's text, the JAX version, the
device and the compiler flags, and a later process that builds the same program loads it
instead of compiling: a repeated ``morphogen simulate``, a web server switching back to a model
or a resumed search starts without the compile.

The ``morphogen`` command turns it on for every sub-command. Python users call :func:`enable`.
``MORPHOGEN_COMPILE_CACHE`` chooses the folder (default ``$XDG_CACHE_HOME/morphogen/jax``, else
``~/.cache/morphogen/jax``); ``MORPHOGEN_COMPILE_CACHE=off`` turns it off. The folder is bounded
(:data:`MAX_BYTES`, least recently used entries go first) and may be deleted at any time.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ENV = "MORPHOGEN_COMPILE_CACHE"
MAX_BYTES = 2 * 1024**3
"""The cache's bound (JAX's ``JAX_COMPILATION_CACHE_MAX_SIZE``, when set, takes precedence; ``-1``
is unbounded). A bounded cache lists its whole folder at every store to find what to evict, which
costs time once it holds thousands of programs."""
MIN_COMPILE_SECONDS = 0.0
"""Programs that compile faster than this are not stored. Zero: a small simulate compiles a few
dozen programs of a few hundredths of a second each, and loading them all from disk saved 0.35 s
of its 3 s start (bench/bench_startup.py). JAX's own ``JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS``,
when set, takes precedence."""


def default_directory() -> Path:
    """The cache folder when ``MORPHOGEN_COMPILE_CACHE`` is not set."""
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "morphogen" / "jax"


def enable(directory: str | Path | None = None) -> Path | None:
    """Store and reuse compiled programs in ``directory`` (default: ``MORPHOGEN_COMPILE_CACHE``
    or :func:`default_directory`); return the folder, or ``None`` when the cache is off or the
    folder cannot be created (the cache only saves time, so that is not an error).

    It sets JAX's environment variables, which JAX reads when it is imported (so a command that
    never computes does not pay for importing JAX) and which the processes this one starts
    inherit (Ray workers, a server); when JAX is already imported it also updates its
    configuration.
    """
    chosen = str(directory) if directory is not None else os.environ.get(ENV, "")
    if chosen.strip().lower() == "off":
        return None
    path = Path(chosen) if chosen.strip() else default_directory()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    settings = {"jax_compilation_cache_dir": str(path),
                "jax_persistent_cache_min_compile_time_secs": float(os.environ.get(
                    "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", MIN_COMPILE_SECONDS)),
                "jax_compilation_cache_max_size": int(os.environ.get(
                    "JAX_COMPILATION_CACHE_MAX_SIZE", MAX_BYTES))}
    for name, value in settings.items():
        os.environ[name.upper()] = str(value)  # for this process's JAX and the workers it starts
    if "jax" in sys.modules:
        import jax

        for name, value in settings.items():
            jax.config.update(name, value)
    return path
