"""``morphogen runs``: list the evolution runs in the archive, or summarise one."""

from __future__ import annotations

import argparse
import time

from morphogen.errors import MorphogenError
from morphogen.search.archive import Archive


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "runs",
        help="list evolution runs, or `runs show RUN` for one",
        description="List the runs of the archive (newest first), or summarise one run: its "
        "settings, fitness per generation and best individuals.",
    )
    p.add_argument("action", nargs="?", choices=("list", "show"), default="list")
    p.add_argument("run", nargs="?", metavar="RUN", help="run directory or id (for show)")
    p.add_argument("--archive", help="run archive (default $MORPHOGEN_ARCHIVE or "
                   "runs/index.sqlite)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.action == "show":
        if not args.run:
            raise MorphogenError("give the run to show: morphogen runs show RUN")
        from morphogen.search.run import resolve_run

        run_id, archive = resolve_run(args.run, args.archive)
        print(show(archive, run_id))
        return 0
    if args.run:
        raise MorphogenError(f"unexpected {args.run!r}; to summarise a run: runs show RUN")
    print(listing(Archive(args.archive, create=False)))
    return 0


def listing(archive: Archive) -> str:
    """One line per run: id, date, model, strategy, fitness, progress, best, status."""
    rows = archive.runs()
    if not rows:
        return f"no runs in {archive.path}"
    head = f"{'id':<36} {'created':<16} {'strategy':<8} {'fitness':<9} {'gens':>7} " \
           f"{'best':>8}  status"
    lines = [head]
    for r in rows:
        best = "-" if r["best"] is None else f"{r['best']:.4f}"
        lines.append(
            f"{r['id']:<36} {_date(r['created']):<16} {r['strategy']:<8} {r['fitness']:<9} "
            f"{r['done']:>3}/{r['generations']:<3} {best:>8}  {r['status']}"
        )
    return "\n".join(lines)


def show(archive: Archive, run_id: str) -> str:
    """A run's settings, a table of generations and its best individuals."""
    from morphogen.cli.evolve_cmd import gene_summary

    r = archive.run(run_id)
    c = r["config"]
    if c.get("kind") == "networks":
        from morphogen.search.networks.record import show as show_network

        return show_network(archive, run_id)
    p, s = c["problem"], c["strategy"]
    genes = ", ".join(f"{g['name']}=[{g['low']:g}, {g['high']:g}]" for g in p["genes"][:8])
    if len(p["genes"]) > 8:
        genes += f", ... ({len(p['genes']) - 8} more)"
    options = ", ".join(f"{k}={v}" for k, v in s.items() if k not in ("name", "population"))
    lines = [
        f"run {r['id']} ({r['status']}), created {_date(r['created'])}",
        f"  directory  {r['dir']}",
        f"  model      {p['model']}  grid {'x'.join(map(str, p['size']))}  dt {p['dt']:g}  "
        f"steps {p['steps']}  init {p['init']}",
        f"  genes      {genes}",
        f"  strategy   {s['name']}  population {s['population']}" + (f"  {options}" if options
                                                                     else ""),
        f"  fitness    {p['fitness']}  seed {c['seed']}  generations {c['generations']}",
        "",
        f"  {'gen':>4} {'best':>9} {'mean':>9} {'so far':>9} {'valid':>6} {'seconds':>8}",
    ]
    for g in archive.generations(run_id):
        lines.append(f"  {g['gen']:>4} {_num(g['best'])} {_num(g['mean'])} "
                     f"{_num(g['best_so_far'])} {g['valid']:>6} {g['seconds']:>8.1f}")
    best = archive.best(run_id, 3)
    if best:
        lines.append("")
        lines.append("  best individuals:")
        names = [g["name"] for g in p["genes"]]
        for rank, b in enumerate(best, start=1):
            values = gene_summary(names, b["genome"])
            lines.append(f"  {rank}. fitness {b['fitness']:.4f} (generation {b['gen']}, "
                         f"#{b['idx']}): {values}")
        lines.append(f"  parameters: {r['dir']}/best/best_1.json "
                     "(morphogen simulate --config ...)")
    return "\n".join(lines)


def _date(stamp: float) -> str:
    return time.strftime("%Y-%m-%d %H:%M", time.localtime(stamp))


def _num(x: float | None) -> str:
    return f"{'-':>9}" if x is None else f"{x:>9.4f}"
