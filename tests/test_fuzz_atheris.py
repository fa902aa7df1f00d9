"""A short coverage-guided fuzzing session per reader of untrusted files (``make fuzz`` runs
longer ones, from random seeds): any input loads or raises ``MorphogenError``, within 10 s and
2 GiB. The suite's session has a fixed seed and input count, so it tries the same inputs on
every machine and a finding is reproducible."""

from __future__ import annotations

import pytest

from fuzz.run import TARGETS, fuzz

RUNS = {"equations": 20_000, "ply": 20_000, "network": 2_000}
"""Inputs per target: an input to the network reader goes through libAntimony or libSBML and
costs about eight times one to the other readers, so its session is shorter."""


@pytest.mark.parametrize("target", TARGETS)
def test_fuzz_target_finds_nothing(target, tmp_path):
    result = fuzz(target, seconds=120, artifacts=tmp_path, runs=RUNS[target], seed=1)
    assert result.ok, result.log[-3000:]
    assert result.inputs >= RUNS[target]  # the fuzzer really ran, from the seeded corpus
    assert not list(tmp_path.iterdir())  # no crash-*, timeout-* or oom-* input saved
