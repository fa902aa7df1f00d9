"""Run the two experiments of Yamamoto et al. at the seed's budget and make docs/networks.md's
figures.

    python docs/images/networks/make_figures.py RUNS_DIR [--runs N] [--workers W] [--plot-only]
        [--experiments 1 2] [--tag TAG] [--partial] [--draw decade|log-uniform] [--seeds S ...]

Experiment 1 (§4.1, rates of the Table-2 network) and Experiment 2 (§4.2, n = 3, m ≤ 12,
networks evolved), ``N`` runs each (seeds 1, 2, …; default :data:`RUNS`), at the full Table-1
budget :data:`BUDGET` and evaluation :data:`EVAL` (150 individuals, 100 generations, 32²,
Δt = 0.1, 10 rounds from t = 2000 every 200, tournament 2; the default fixed-point start,
stationary grade in stage two (Experiment 1: graded, :data:`EVALS`), checkerboards invalid,
Experiment 1's rates drawn within a decade of Table 2's, or with ``--draw log-uniform`` over
every exponent, the seed's other reading, under the default stationary grade:
docs/networks.md). ``--experiments`` picks which to run and draw. Run folders go to
``RUNS_DIR/exp1-seedS`` and ``RUNS_DIR/exp2-seedS``; finished runs are not run again and
unfinished ones are resumed. ``W`` runs go at once, each in its own single-threaded process (one
per core). Every generation's CPU-seconds (``time.process_time`` of its process) and wall
seconds are appended to ``RUNS_DIR/<run>/times.txt``.

Then the figures: best fitness per generation, one curve per run (the seed's figs. 3 and 5),
the best pattern of each experiment and of the hand-made network as A/B/C heat maps with colour
bars (figs. 1, 4, 6), the best Experiment-2 network's reaction table next to its drawing, and
every Experiment-2 run past 256 as its pattern beside its network (figs. 6 and 7,
``runs_exp2_TAG.png``, with the correlation of A and C that §4.2 reads),
each PNG named with ``--tag`` (``fitness_exp1_TAG.png``; none for the earlier literal-reading
runs' figures); an experiment without a finished run is skipped. ``--partial`` draws unfinished
runs too (a run stopped before its last generation: its curve ends there, its legend names the
generations done, and its last population counts for the best pattern).
"""

from __future__ import annotations

import argparse
import io
import multiprocessing
import os
import time
from pathlib import Path

import jax
import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from morphogen.search.networks.draw import draw_network  # noqa: E402
from morphogen.search.networks.evolve import (  # noqa: E402
    Evaluation,
    completed,
    evaluate,
    initial_state,
    load_state,
    run,
)
from morphogen.search.networks.export import genome_network  # noqa: E402
from morphogen.search.networks.genome import (  # noqa: E402
    Genome,
    NetworkSpec,
    describe,
    make_genome,
    stack,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.operators import Operators  # noqa: E402
from morphogen.util.cluster import SINGLE_THREAD  # noqa: E402

HERE = Path(__file__).parent
RUNS = 3
BUDGET = {"population": 150, "generations": 100}
EVALS = {1: Evaluation(stage2="graded"), 2: Evaluation()}
"""Each experiment's evaluation: Experiment 1's runs were made with the graded stage two
(its populations hold spots from the first generation, so the grade orders only their tail),
Experiment 2's use the default, the stationary grade (docs/networks.md)."""
EVAL = EVALS[2]


def evaluation(number: int, draw: str = "decade") -> Evaluation:
    """The evaluation of a run: :data:`EVALS`, except that Experiment 1 with the log-uniform
    draw, whose first populations hold no spots, takes the default (stationary) grade."""
    return EVAL if draw == "log-uniform" else EVALS[number]


def experiment(number: int, draw: str = "decade") -> tuple[NetworkSpec, object, Operators]:
    """Spec, template genome and operators of Experiment 1 (rates, initial rates drawn by
    ``draw``) or 2 (network)."""
    if number == 1:
        spec = table2_spec()
        return spec, table2_genome(spec), Operators(mode="rates", draw=draw)
    spec = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1),
                       fixed_rates=(0.0, 0.0))
    return spec, make_genome(spec, [0.0] * spec.m_max), Operators(mode="network")


def one_run(out: Path, number: int, seed: int, draw: str = "decade") -> str:
    """Run (or resume) one experiment run, logging every generation with its times."""
    spec, template, ops = experiment(number, draw)
    done = completed(out)
    clock = [time.process_time(), time.perf_counter()]
    out.mkdir(parents=True, exist_ok=True)

    def log(line: str) -> None:
        cpu, wall = time.process_time(), time.perf_counter()
        line = f"{line}, {cpu - clock[0]:.1f} CPU-s, {wall - clock[1]:.1f} s"
        clock[:] = [cpu, wall]
        with open(out / "times.txt", "a") as f:
            f.write(line + "\n")
        print(f"{out.name}: {line}", flush=True)

    run(spec, template, out, ops=ops, ev=evaluation(number, draw), seed=seed, resume=done > 0,
        log=log, **BUDGET)
    return out.name


def _one_run(args: tuple[Path, int, int, str]) -> str:
    return one_run(*args)


def run_all(root: Path, seeds: list[int], workers: int, experiments: tuple[int, ...] = (1, 2),
            draw: str = "decade") -> None:
    """Every run of the experiments with these seeds that is not finished yet, in order,
    ``workers`` at a time (the longer Experiment-2 runs first, so the workers finish
    together)."""
    todo = [(root / f"exp{number}-seed{seed}", number, seed, draw)
            for seed in seeds for number in (2, 1) if number in experiments
            if completed(root / f"exp{number}-seed{seed}") < BUDGET["generations"]]
    if workers <= 1:
        for task in todo:
            one_run(*task)
        return
    with multiprocessing.get_context("spawn").Pool(workers, maxtasksperchild=1) as pool:
        for name in pool.imap_unordered(_one_run, todo):
            print(f"{name}: finished", flush=True)


def finished(root: Path, number: int) -> list[Path]:
    """The finished run folders of an experiment, by seed (with ``--partial``, every run with
    at least one generation done)."""
    least = 1 if PARTIAL[0] else BUDGET["generations"]
    return sorted((p for p in root.glob(f"exp{number}-seed*") if completed(p) >= least),
                  key=lambda p: int(p.name.rsplit("seed", 1)[1]))


def _label(folder: Path) -> str:
    """``seedS``, with the generations done when the run is unfinished."""
    done = completed(folder)
    seed = folder.name.split("-")[1]
    return seed if done >= BUDGET["generations"] else f"{seed}, {done} of {BUDGET['generations']}"


TAG = [""]
"""Suffix of the figures' names (``--tag``)."""
PARTIAL = [False]
"""Draw unfinished runs too (``--partial``)."""


def _png(name: str) -> Path:
    return HERE / f"{name}{'_' + TAG[0] if TAG[0] else ''}.png"


def fitness_figure(root: Path, number: int) -> None:
    """Best fitness per generation, one curve per run (the seed's figs. 3 and 5), the mean
    fitness of the valid individuals dashed in the run's colour, and beside it the number of
    valid individuals per generation (fitness -1 marks an invalid one). Each run has its own
    marker, drawn hollow, so runs with the same curve stay visible."""
    fig = Figure(figsize=(8.4, 3.6), dpi=120)
    best, valid = fig.subplots(1, 2, width_ratios=(1.4, 1))
    markers = "os^DvP"
    for i, folder in enumerate(finished(root, number)):
        history = load_state(folder / "state.npz")[1]
        gens = np.arange(1, len(history) + 1)
        style = dict(marker=markers[i % len(markers)], ms=7 - 1.5 * (i % 3), mfc="none",
                     markevery=(i, 3), lw=1, label=_label(folder))
        line = best.plot(gens, history.max(axis=1), **style)[0]
        mean = [h[h >= 0].mean() if (h >= 0).any() else np.nan for h in history]
        best.plot(gens, mean, ls="--", lw=0.8, color=line.get_color())
        valid.plot(gens, (history >= 0).sum(axis=1), **style)
    best.axhline(EVAL.size ** 2, color="0.6", ls=":", lw=1)
    best.set_xlabel("generation")
    best.set_ylabel(f"best fitness, mean of valid dashed (max {EVAL.size ** 2})", fontsize=9)
    what = "rates of the Table-2 network" if number == 1 else "networks, n = 3, m ≤ 12"
    best.set_title(f"Experiment {number}: {what}", fontsize=10)
    best.set_ylim(-20, EVAL.size ** 2 * 1.05)
    best.legend(fontsize=7, ncol=3, loc="best")  # Experiment 1 sits at the top, 2 low
    valid.set_xlabel("generation")
    valid.set_ylabel("count")
    valid.set_title(f"valid individuals of {BUDGET['population']}", fontsize=10)
    valid.set_ylim(0, BUDGET["population"] * 1.05)
    for ax in (best, valid):
        ax.grid(alpha=0.3)
        ax.set_xlim(0, BUDGET["generations"] + 1)
    fig.tight_layout()
    fig.savefig(_png(f"fitness_exp{number}"))


JUMP = 100.0
"""A single-generation gain of the best fitness at least this large is a jump."""


def slope_or_jumps(best: np.ndarray) -> dict[str, float]:
    """The seed's headline as numbers (§4: "gentle slopes" in Fig. 3 against "punctuated
    jumps" in Fig. 5), from a run's best fitness per generation ``best`` ``(G,)``:

    - ``jump_share``: the share of the run's total gain ``best[-1] - best[0]`` made in
      single-generation gains ``>= JUMP`` (0 for a gentle slope, 1 for pure jumps; NaN without a
      gain);
    - ``longest_plateau``: the longest stretch of generations before the last jump in which
      the best fitness did not rise by more than 1 (a jump after a long wait is punctuated);
    - ``jumps``: how many single-generation gains ``>= JUMP``.
    """
    best = np.asarray(best, np.float64)
    gains = np.diff(best)
    total = best[-1] - best[0]
    jumps = np.flatnonzero(gains >= JUMP)
    share = float(gains[jumps].sum() / total) if total > 0 else float("nan")
    plateau, run = 0, 0
    for g in gains[: jumps[-1]] if jumps.size else []:
        run = run + 1 if g <= 1.0 else 0
        plateau = max(plateau, run)
    return {"jump_share": share, "longest_plateau": plateau, "jumps": int(jumps.size),
            "gain": float(total)}


def best_genome(root: Path, number: int) -> tuple[Genome, float, str]:
    """The fittest genome of the experiment's runs' last generations."""
    best = None
    for folder in finished(root, number):
        genome, fitness = _fittest(folder)
        if best is None or fitness > best[1]:
            best = (genome, fitness, folder.name)
    return best


def _fittest(folder: Path) -> tuple[Genome, float]:
    """The fittest genome of a run's last saved generation, and its fitness there."""
    pop, history, _, _ = load_state(folder / "state.npz")
    i = int(np.argmax(history[-1]))
    return Genome(*(np.asarray(x)[i] for x in pop)), float(history[-1][i])


def pattern_figure(genome: Genome, spec: NetworkSpec, name: str, title: str
                   ) -> tuple[float, float]:
    """A/B/C heat maps with colour bars of ``genome``'s state at the last evaluation round
    (figs. 1, 4, 6), from the shared initial state of key 0; returns its fitness there and
    :func:`catalyst_correlation`."""
    fitness, states = _last_round(genome, spec)
    fig = Figure(figsize=(9.6, 3.2), dpi=120)
    for i, species in enumerate(spec.species):
        _field_panel(fig, fig.add_subplot(1, spec.n, i + 1), states[0, i], species)
    t = EVAL.t_start + (EVAL.rounds - 1) * EVAL.interval
    fig.suptitle(f"{title}: t = {t:g}, fitness {fitness[0]:.1f} of {EVAL.size ** 2}",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(_png(name))
    return float(fitness[0]), catalyst_correlation(states)


def _last_round(genome: Genome, spec: NetworkSpec) -> tuple[np.ndarray, np.ndarray]:
    """Fitness ``(1,)`` and state ``(1, n, H, W)`` of ``genome`` at the last evaluation round,
    from the shared initial state of key 0."""
    u0 = initial_state(jax.random.key(0), spec, EVAL)
    fitness, states = evaluate(stack([genome]), u0, spec, EVAL)
    return np.asarray(fitness), np.asarray(states)


def _field_panel(fig: Figure, ax, field: np.ndarray, species: str) -> None:
    """One species' heat map with its colour bar."""
    # the scale runs from the field's min to its max (centred on the mean it clipped the
    # spots' tops and showed negative values no cell had); a uniform field shows uniform
    mid, lo, hi = float(field.mean()), float(field.min()), float(field.max())
    flat = (hi - lo) / 2 < 5e-4 * max(abs(mid), 1.0)
    if flat:
        lo, hi = mid - 5e-4 * max(abs(mid), 1.0), mid + 5e-4 * max(abs(mid), 1.0)
    im = ax.imshow(field, cmap="viridis", interpolation="nearest", vmin=lo, vmax=hi)
    bar = fig.colorbar(im, ax=ax, shrink=0.8)
    bar.formatter = matplotlib.ticker.ScalarFormatter(useOffset=False)
    bar.update_ticks()
    ax.set_title(f"{species} (uniform, {mid:.4g})" if flat else species)
    ax.set_xticks([])
    ax.set_yticks([])


def catalyst_correlation(states: np.ndarray) -> float:
    """Pearson correlation of A and C over the grid (§4.2: in the evolved networks "the peaks
    of C now coincide with those of A", where the hand-made network's C is consumed under A's
    peaks); NaN where either field is flat."""
    a, c = (np.asarray(states[0, i], np.float64).ravel() for i in (0, 2))
    if a.std() == 0 or c.std() == 0:
        return float("nan")
    return float(np.corrcoef(a, c)[0, 1])


def runs_figure(root: Path) -> None:
    """Figs. 6 and 7 for every finished Experiment-2 run whose best passed 256: per run, the
    A/B/C heat maps of its last generation's fittest genome (key-0 start, last round) and the
    drawing of its evolvable reactions."""
    spec = experiment(2)[0]
    rows = [(folder.name, genome) for folder in finished(root, 2)
            for genome, fitness in [_fittest(folder)] if fitness > 256]
    if not rows:
        return
    fig = Figure(figsize=(13.0, 2.9 * len(rows)), dpi=100)
    for r, (name, genome) in enumerate(rows):
        fitness, states = _last_round(genome, spec)
        for j, species in enumerate(spec.species):
            _field_panel(fig, fig.add_subplot(len(rows), 4, 4 * r + j + 1), states[0, j],
                         f"{name}: {species}" if j == 0 else species)
        ax = fig.add_subplot(len(rows), 4, 4 * r + 4)
        ax.imshow(_network_image(genome, spec, name))
        ax.set_axis_off()
        corr = catalyst_correlation(states)
        ax.set_title(f"fitness {fitness[0]:.1f}, corr(A, C) {corr:+.2f}", fontsize=9)
        print(f"{name}: fitness {fitness[0]:.2f} on key 0, corr(A, C) {corr:+.3f}")
        for d in describe(genome, spec):
            if d["k"] and not d["fixed"]:
                print(f"  {d['reaction']:<28} {d['k']:.2g}")
    fig.tight_layout()
    fig.savefig(_png("runs_exp2"))


def _network_image(genome: Genome, spec: NetworkSpec, label: str) -> np.ndarray:
    """The Fig. 7-style drawing of ``genome``'s evolvable reactions (static inflow and decay
    left out), as an RGBA image."""
    net = genome_network(genome, spec, name=label)
    keep = [j for j, r in enumerate(net.reaction_ids) if not r.startswith(("inflow_", "decay_"))]
    png = draw_network(net, "png", reactions=keep or None, title="")
    return matplotlib.image.imread(io.BytesIO(png), format="png")


def network_figure(genome: Genome, spec: NetworkSpec, label: str) -> None:
    """The best Experiment-2 network: its reaction table next to its Fig. 7-style drawing."""
    rows = [(r["reaction"].replace("->", "→"), f"{r['k']:.2g}")
            for r in describe(genome, spec) if r["k"] or not r["fixed"]]
    fig = Figure(figsize=(11.0, 5.2), dpi=120)
    left = fig.add_axes((0.03, 0.05, 0.38, 0.85))
    left.set_axis_off()
    table = left.table(cellText=rows, colLabels=("reaction", "k"), loc="center",
                       colWidths=(0.7, 0.25), cellLoc="left")
    table.auto_set_font_size(False)
    table.set_fontsize(10)
    table.scale(1.0, 1.5)
    right = fig.add_axes((0.44, 0.0, 0.56, 0.95))
    right.imshow(_network_image(genome, spec, label))
    right.set_axis_off()
    fig.suptitle(f"best network of Experiment 2 ({label}); static inflow/decay in the table "
                 "only", fontsize=10)
    fig.savefig(_png("network_exp2"))


def _name(folder: Path) -> str:
    """The run folder's name, with the generations done when the run is unfinished."""
    done = completed(folder)
    return (folder.name if done >= BUDGET["generations"]
            else f"{folder.name}, generation {done} of {BUDGET['generations']}")


def make_figures(root: Path, experiments: tuple[int, ...] = (1, 2)) -> None:
    experiments = tuple(n for n in experiments if finished(root, n))
    for number in experiments:
        fitness_figure(root, number)
        for folder in finished(root, number):
            best = load_state(folder / "state.npz")[1].max(axis=1)
            print(f"{folder.name}: {slope_or_jumps(best)}")
    spec = table2_spec()
    hand, corr = pattern_figure(table2_genome(spec), spec, "pattern_table2",
                                "hand-made (Table 2)")
    print(f"hand-made Table-2 network: fitness {hand:.2f}, corr(A, C) {corr:+.3f}")
    if 2 in experiments:
        runs_figure(root)
    for number in experiments:
        genome, fit, folder = best_genome(root, number)
        spec = experiment(number)[0]
        again, corr = pattern_figure(genome, spec, f"pattern_exp{number}",
                                     f"Experiment {number}, best ({_name(root / folder)})")
        print(f"experiment {number}: best {fit:.2f} in {folder} ({again:.2f} on key 0, "
              f"corr(A, C) {corr:+.3f})")
        for r in describe(genome, spec):
            print(f"  {r['reaction']:<28} {r['k']:.2g}{'  (imposed)' if r['fixed'] else ''}")
        if number == 2:
            network_figure(genome, spec, _name(root / folder))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs_dir", nargs="?", type=Path, default=Path("runs/networks-figures"))
    parser.add_argument("--runs", type=int, default=RUNS)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--plot-only", action="store_true")
    parser.add_argument("--experiments", type=int, nargs="+", choices=(1, 2), default=(1, 2))
    parser.add_argument("--tag", default="")
    parser.add_argument("--partial", action="store_true",
                        help="draw unfinished runs too (their generations so far)")
    parser.add_argument("--seeds", type=int, nargs="+", metavar="S",
                        help="run these seeds, in this order, instead of 1 .. --runs (a "
                        "second process on the same folder takes other seeds)")
    parser.add_argument("--draw", choices=("decade", "log-uniform"), default="decade",
                        help="Experiment 1's initial rates (a run resumes only with its own)")
    args = parser.parse_args()
    TAG[0] = args.tag
    PARTIAL[0] = args.partial
    if not args.plot_only:
        os.environ.setdefault("XLA_FLAGS", SINGLE_THREAD)
        seeds = args.seeds or list(range(1, args.runs + 1))
        run_all(args.runs_dir, seeds, args.workers, tuple(args.experiments), args.draw)
    make_figures(args.runs_dir, tuple(args.experiments))
