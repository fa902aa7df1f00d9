"""A short coverage-guided fuzzing session per reader of untrusted files (``make fuzz`` runs
longer ones): any input loads or raises ``MorphogenError``, within 10 s and 2 GiB."""

from __future__ import annotations

import pytest

from fuzz.run import TARGETS, fuzz


@pytest.mark.parametrize("target", TARGETS)
def test_fuzz_target_finds_nothing(target, tmp_path):
    result = fuzz(target, seconds=15, artifacts=tmp_path)
    assert result.ok, result.log[-2000:]
    assert result.inputs > 1000  # the fuzzer really ran, from the seeded corpus
    assert not list(tmp_path.iterdir())  # no crash-*, timeout-* or oom-* input saved
