"""The persistent compilation cache: a second process loads what the first one compiled."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from morphogen.util import compile_cache

RUN = """
import json, sys
import jax.monitoring
from morphogen.cli.main import main
hits = []
jax.monitoring.register_event_listener(
    lambda event, **kw: hits.append(1) if event == "/jax/compilation_cache/cache_hits" else None)
code = main(sys.argv[1:])
print(json.dumps({"code": code, "hits": len(hits)}))
"""


def _simulate(out, cache) -> dict:
    env = {**os.environ, compile_cache.ENV: str(cache), "JAX_PLATFORMS": "cpu",
           "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0"}
    argv = ["simulate", "gray-scott", "--size", "16x16", "--steps", "20", "--quiet", "--out",
            str(out)]
    done = subprocess.run([sys.executable, "-c", RUN, *argv], env=env, capture_output=True,
                          text=True, timeout=180, check=True)
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.slow
def test_a_second_process_loads_the_compiled_programs_and_gives_the_same_state(tmp_path):
    cache = tmp_path / "cache"
    first = _simulate(tmp_path / "a", cache)
    stored = list(cache.glob("*-cache"))
    second = _simulate(tmp_path / "b", cache)
    assert first["code"] == second["code"] == 0 and stored
    assert second["hits"] > first["hits"]
    a, b = np.load(tmp_path / "a" / "state.npz"), np.load(tmp_path / "b" / "state.npz")
    for name in a.files:
        np.testing.assert_array_equal(a[name], b[name])  # the same program, replayed


def test_off_or_an_unusable_folder_leaves_the_cache_off(tmp_path, monkeypatch):
    monkeypatch.setenv(compile_cache.ENV, "off")
    assert compile_cache.enable() is None
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert compile_cache.enable(blocker / "cache") is None
    monkeypatch.delenv(compile_cache.ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compile_cache.default_directory() == tmp_path / "xdg" / "morphogen" / "jax"
