"""Run a fuzz target for a time budget and report how many inputs it tried.

``python -m fuzz.run equations --seconds 60`` seeds a fresh corpus with valid inputs
(:func:`fuzz.targets.seed_corpus`), runs libFuzzer through atheris in a subprocess, and prints
one line: the target, inputs tried, corpus size, and whether anything escaped the
``MorphogenError`` contract. A finding is saved as ``crash-*``/``timeout-*``/``oom-*`` in
``--artifacts`` (default ``out/fuzz/``) and the exit status is 1.
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

_RUNS = re.compile(r"^#(\d+)\s", re.MULTILINE)
TARGETS = ("equations", "ply", "network")
"""The targets of :mod:`fuzz.targets` (kept here so this runner stays uninstrumented)."""
EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
MAX_LEN = {"equations": 128 * 1024, "ply": 4096, "network": 4096}
"""Largest input per target, in bytes: a model file with thousands of parameters (about 60 kB
for 5 000) must fit, so the model-text target's cap is far above the others'."""
CANARY = Path(tempfile.gettempdir()) / "morphogen-fuzz-canary.ant"
"""A file the network target writes before fuzzing and the network seeds ``import``. A network
file must never make libAntimony read another file; the canary is not Antimony, so reading it
fails with a message naming it (or, if it ever parsed, leaves ``FUZZ_CANARY`` in the model):
either trace is a finding."""
CANARY_TEXT = "FUZZ_CANARY FUZZ_CANARY FUZZ_CANARY\n"


def _deep(depth: int) -> str:
    """A model file whose unknown key ``deep`` holds arrays nested ``depth`` levels."""
    return f"deep = {'[' * depth}1{']' * depth}\n"


def _many_parameters(count: int) -> str:
    """A valid model file with ``count`` parameters (all used in the equation of ``u``)."""
    names = [f"p{i}" for i in range(count)]
    params = "".join(f"{n} = {i % 7 + 0.5}\n" for i, n in enumerate(names))
    terms = "+".join(names[:200])
    return (f'species = ["u"]\n[parameters]\n{params}[equations]\n'
            f'u = "({terms})*1e-6 - u + lap(u)"\n')


def seed_corpus(target: str, folder: Path) -> Path:
    """Write starting inputs for ``target`` into ``folder``: the example model files plus
    hostile ones (arrays and inline tables nested 20 to 2 000 deep, a model with 5 000
    parameters), a small mesh saved as ASCII and binary PLY, or the example Antimony networks
    with the library network as SBML and Antimony, and that network after ``import`` lines
    naming :data:`CANARY` (plain, after a string and a comment, and inside a comment)."""
    folder.mkdir(parents=True, exist_ok=True)
    if target == "equations":
        for toml in sorted(EXAMPLES.glob("*.toml")):
            (folder / toml.name).write_bytes(toml.read_bytes())
        model = (EXAMPLES / "schnakenberg.toml").read_text(encoding="utf-8")
        for depth in (20, 2000):
            (folder / f"deep-{depth}.toml").write_text(_deep(depth) + model, encoding="utf-8")
        (folder / "inline-tables.toml").write_text(
            "deep = " + "{a = " * 200 + "1" + "}" * 200 + "\n" + model, encoding="utf-8")
        (folder / "parameters-5000.toml").write_text(_many_parameters(5000), encoding="utf-8")
    elif target == "network":
        from morphogen.models.network import yamamoto_network
        from morphogen.models.text.sbml import to_antimony, to_sbml

        for ant in sorted((EXAMPLES / "networks").glob("*.ant")):
            (folder / ant.name).write_bytes(ant.read_bytes())
        net = yamamoto_network()
        (folder / "yamamoto.xml").write_text(to_sbml(net), encoding="utf-8")
        (folder / "yamamoto.ant").write_text(to_antimony(net), encoding="utf-8")
        body = to_antimony(net)
        for name, head in (("import", f'import "{CANARY}"\n'),
                           ("import-after-string", f'A is "//"; import "{CANARY}"\n'),
                           ("import-after-comment", f'/* a */ import "{CANARY}"\n'),
                           ("import-in-comment", f'// import "{CANARY}"\n')):
            (folder / f"{name}.ant").write_text(head + body, encoding="utf-8")
    else:
        from morphogen.domains.mesh import Mesh
        from morphogen.domains.ply import save_ply

        mesh = Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]], [[0, 1, 2], [1, 3, 2]])
        for binary in (False, True):
            save_ply(folder / f"square-{'binary' if binary else 'ascii'}.ply", mesh,
                     fields={"u": [0.0, 1.0, 2.0, 3.0]}, binary=binary)
    return folder


@dataclass(frozen=True)
class FuzzResult:
    """What one fuzzing session did: inputs executed, corpus entries kept, libFuzzer status."""

    target: str
    inputs: int
    corpus: int
    returncode: int
    log: str

    @property
    def ok(self) -> bool:
        return self.returncode == 0


def fuzz(target: str, seconds: int, artifacts: Path, max_len: int | None = None,
         runs: int | None = None, seed: int | None = None) -> FuzzResult:
    """Fuzz ``target`` for ``seconds`` (or until ``runs`` inputs, if given, whichever comes
    first); each input may take at most 10 s and 2 GiB, and at most ``max_len`` bytes (default
    :data:`MAX_LEN` of the target; a longer seed is cut). A fixed ``seed`` with ``runs`` replays
    the same inputs every time (the suite's check); without them each session explores anew.

    libFuzzer reads its memory as the process's peak RSS, which a child inherits from the
    process that started it (a pytest worker may hold gigabytes), so the limit is 2 GiB above
    this process's own peak.
    """
    artifacts.mkdir(parents=True, exist_ok=True)
    max_len = MAX_LEN[target] if max_len is None else max_len
    rss_limit = 2048 + resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024
    with tempfile.TemporaryDirectory(prefix=f"corpus-{target}-") as tmp:
        corpus = seed_corpus(target, Path(tmp))
        cmd = [sys.executable, "-m", "fuzz.targets", target,
               f"-max_total_time={seconds}", f"-max_len={max_len}", "-timeout=10",
               f"-rss_limit_mb={rss_limit}", "-print_final_stats=1",
               f"-artifact_prefix={artifacts}/",
               *([f"-runs={runs}"] if runs is not None else []),
               *([f"-seed={seed}"] if seed is not None else []), str(corpus)]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              cwd=Path(__file__).resolve().parent.parent,
                              timeout=seconds + 120)
        kept = len(list(corpus.iterdir()))
    runs = [int(n) for n in _RUNS.findall(proc.stdout)]
    return FuzzResult(target, max(runs, default=0), kept, proc.returncode, proc.stdout)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fuzz.run", description=__doc__)
    parser.add_argument("targets", nargs="*", metavar="TARGET",
                        help=f"one of {', '.join(TARGETS)} (default: all)")
    parser.add_argument("--seconds", type=int, default=60, help="budget per target")
    parser.add_argument("--artifacts", type=Path, default=Path("out/fuzz"))
    args = parser.parse_args(argv)
    unknown = sorted(set(args.targets) - set(TARGETS))
    if unknown:
        parser.error(f"unknown target {unknown[0]!r}; choose from {', '.join(TARGETS)}")
    status = 0
    for target in args.targets or TARGETS:
        result = fuzz(target, args.seconds, args.artifacts)
        verdict = "no findings" if result.ok else f"FINDING (see {args.artifacts}/)"
        print(f"{target}: {result.inputs} inputs in {args.seconds} s, "
              f"corpus {result.corpus}, {verdict}")
        if not result.ok:
            print(result.log[-3000:], file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    raise SystemExit(main())
