"""``morphogen models``: list the library models, their parameters and defaults."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from morphogen.models.model import Model


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "models",
        help="list library models, parameters and defaults",
        description="List the library models with their species, parameters (defaults), "
        "presets and the seed equations they implement, and the shipped trained neural RD "
        "rules (neural:NAME).",
    )
    p.add_argument("name", nargs="?", help="show only this model")
    p.set_defaults(func=run)


def describe(model: Model) -> str:
    """A few lines describing a model for the terminal."""
    params = ", ".join(f"{k}={v:g}" for k, v in model.params.items())
    lines = [
        f"{model.name}: {model.description}",
        f"  species: {', '.join(model.species)} (shown: {model.display_species})",
        f"  parameters: {params}",
        f"  suggested: dt={model.dt:g}, time={model.t_end:g}, init={model.init}"
        + (f", clamp={list(model.clamp)}" if model.clamp else ""),
        f"  reference: {model.reference}",
    ]
    if model.presets:
        lines.append(f"  presets: {', '.join(model.presets)}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from morphogen.models.library import LIBRARY, get_model
    from morphogen.models.neural_library import describe_rule, load_rule, model_names

    if args.name and args.name.startswith("neural:"):
        print(describe(load_rule(args.name)))
        return 0
    names = [args.name] if args.name else list(LIBRARY)
    blocks = []
    for name in names:
        model = get_model(name)
        if name == "genrd" and not args.name:
            blocks.append(f"genrd: {model.description}\n  species: u, v; 108 coefficients "
                          "alpha_/beta_<species><term>_<i><j> plus Du, Dv "
                          "(see `morphogen models genrd`)\n  reference: " + model.reference)
            continue
        blocks.append(describe(model))
    if not args.name:
        blocks += [describe_rule(name) for name in model_names()]
    print("\n\n".join(blocks))
    return 0
