"""``morphogen networks export``: a network as a model file, Antimony, SBML or a drawing."""

from __future__ import annotations

import argparse
from pathlib import Path

FORMATS = ("toml", "antimony", "sbml", "png", "svg")
BY_SUFFIX = {".toml": "toml", ".ant": "antimony", ".antimony": "antimony", ".xml": "sbml",
             ".sbml": "sbml", ".png": "png", ".svg": "svg"}
NETWORK_FILES = (".toml", ".ant", ".antimony", ".xml", ".sbml")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export",
        help="write a network as a model file, Antimony, SBML, PNG or SVG",
        description="Export a reaction network. SOURCE is a `morphogen networks` run folder "
        "(its best genome of the last saved generation), 'table2' (the hand-made network of "
        "Yamamoto et al. Table 2, species A B C), 'yamamoto-network' (the same network as the "
        "library model of that name, species a h c), or an Antimony (.ant) or SBML (.xml) "
        "file. Formats: toml (a model file for `morphogen simulate`), antimony, sbml, png and "
        "svg (a drawing as in "
        "Yamamoto Fig. 7: dots are reactions, lines educts, arrows products, dotted arrows "
        "catalysts, numbers stoichiometric coefficients). Reactions of rate 0 are left out; "
        "species diffuse with the parameters D_<species>.",
    )
    p.add_argument("source", metavar="SOURCE",
                   help="run folder, 'table2', 'yamamoto-network', or a .ant/.xml file")
    p.add_argument("--format", choices=FORMATS, default=None,
                   help="output format (default: from the --out suffix)")
    p.add_argument("--out", required=True, metavar="FILE", help="file to write")
    p.add_argument("--all-reactions", action="store_true",
                   help="drawings: show the static inflow and decay reactions too (Fig. 7 "
                   "shows only the evolvable ones)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from morphogen.errors import MorphogenError
    from morphogen.search.networks.export import run_network, table2_network, write_network

    out = Path(args.out)
    fmt = args.format or BY_SUFFIX.get(out.suffix.lower())
    if fmt is None:
        raise MorphogenError(f"cannot tell the format from {out.name!r}; give --format "
                             f"{'|'.join(FORMATS)} or an --out ending in "
                             f"{', '.join(BY_SUFFIX)}")
    source = Path(args.source)
    genome = True
    if args.source == "table2":
        net = table2_network()
    elif args.source == "yamamoto-network":
        from morphogen.models.network import yamamoto_network

        net, genome = yamamoto_network(), False
    elif source.suffix.lower() in NETWORK_FILES and not source.is_dir():
        from morphogen.models.text.sbml import read_network_file

        if source.suffix.lower() == ".toml":
            raise MorphogenError("a .toml model file holds equations, not a reaction network; "
                                 "export from a run folder, 'table2' or a .ant/.xml file")
        net = read_network_file(source)
        genome = False
    else:
        net, _ = run_network(source)
    from morphogen.util.io import check_out_name, ensure_writable_dir

    check_out_name(out)
    ensure_writable_dir(out.absolute().parent)  # like every --out: made if absent, once checked
    write_network(net, fmt, out, evolvable_only=genome and not args.all_reactions)
    print(f"wrote {out} ({fmt})")
    return 0
