"""A short coverage-guided fuzzing session per reader of untrusted files (``make fuzz`` runs
longer ones, from random seeds): any input loads or raises ``MorphogenError``, within 10 s and
2 GiB. The suite's session has a fixed seed and input count, so it tries the same inputs on
every machine and a finding is reproducible."""

from __future__ import annotations

import pytest

from fuzz.run import TARGETS, fuzz
from tests.paths import ROOT

pytestmark = pytest.mark.slow

RUNS = {"equations": 10_000, "ply": 10_000, "network": 1_000}
"""Inputs per target: an input to the network reader goes through libAntimony or libSBML and
costs about eight times one to the other readers, so its session is shorter."""
MAX_LEN = {"equations": 16 * 1024}
"""The suite's cap on the model-text input (``make fuzz`` allows 128 kB): seeds such as the
5 000-parameter model are cut to about 1 300 parameters, so the session stays short."""


@pytest.mark.parametrize("target", TARGETS)
def test_fuzz_target_finds_nothing(target, tmp_path):
    result = fuzz(target, seconds=120, artifacts=tmp_path, runs=RUNS[target], seed=1,
                  max_len=MAX_LEN.get(target))
    assert result.ok, result.log[-3000:]
    assert result.inputs >= RUNS[target]  # the fuzzer really ran, from the seeded corpus
    assert not list(tmp_path.iterdir())  # no crash-*, timeout-* or oom-* input saved


def test_the_network_seeds_catch_a_file_read(tmp_path):
    """The network target's ``import`` seeds are findings if the reader follows them (checked
    with the refusal switched off), and pass with it on."""
    import subprocess
    import sys

    from fuzz.run import seed_corpus

    seeds = sorted(seed_corpus("network", tmp_path / "seeds").glob("import*.ant"))
    assert len(seeds) >= 3
    script = (
        "import sys\n"
        "import fuzz.targets as t\n"
        "import morphogen.models.text.sbml as sbml\n"
        "if sys.argv[1] == 'off':\n"
        "    sbml.refuse_imports = lambda text, where='': None\n"
        "found = 0\n"
        "for name in sys.argv[2:]:\n"
        "    try:\n"
        "        t.network(open(name, 'rb').read())\n"
        "    except t.FileRead:\n"
        "        found += 1\n"
        "print(found)\n"
    )
    counts = {}
    for mode in ("on", "off"):
        proc = subprocess.run([sys.executable, "-c", script, mode, *map(str, seeds)],
                              capture_output=True, text=True, cwd=ROOT, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        counts[mode] = int(proc.stdout.split()[-1])
    assert counts == {"on": 0, "off": len([s for s in seeds if "in-comment" not in s.name])}
