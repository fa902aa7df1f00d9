"""``morphogen match IMAGE``: find the model, parameters and scale that grow a pattern like the
one in a picture, or in a vertex field of a mesh (:func:`morphogen.match.match`)."""

from __future__ import annotations

import argparse

from morphogen.cli import options


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "match",
        help="find the model, parameters and scale that grow a pattern like a picture",
        description="Describe IMAGE with the simulator's pattern descriptors (wavelength, "
        "topology, coherence, spectrum, histogram; blind to colours, contrast, rotation and "
        "resolution), search every candidate model's parameter box as batched populations "
        "(families first, then a texture-loss refinement), fit the grid spacing so the "
        "wavelength matches the picture's pixels, and write the best candidates: "
        "candidate_K.json (replay with `morphogen simulate --config`), sheet.png (target | "
        "best | next best), report.txt and match.json. Run the same command again to resume "
        "an interrupted match. IMAGE may be a mesh (.ply, e.g. a pipeline's final.ply): one "
        "vertex field (--field) is flattened onto the mesh's best-fit plane, only the pixels "
        "the mesh covers are described, and wavelengths are quoted in mesh units too.",
    )
    p.add_argument("image", metavar="IMAGE",
                   help="picture file (PNG, JPEG, ...) or mesh file (.ply)")
    p.add_argument("--models", metavar="NAME[,NAME...]",
                   help="candidate models: library names or model files (default: gray-scott, "
                   "schnakenberg, fitzhugh-nagumo, turing, brusselator)")
    p.add_argument("--gene", action="append", default=[], metavar="NAME=LOW:HIGH",
                   help="searched parameter and range, replacing the models' boxes (needed for "
                   "a model file; repeatable)")
    p.add_argument("--budget", type=options.positive_int, default=96,
                   help="simulations of the search (default 96)")
    p.add_argument("--minutes", type=options.positive_float,
                   help="stop searching after this many minutes and answer with the best so far")
    p.add_argument("--channel", default="auto",
                   help="auto (first principal colour axis), luma, red, green, blue, saturation "
                   "or a colour axis R,G,B such as 1,-1,0")
    p.add_argument("--crop", metavar="X,Y,W,H", help="match only this region (pixels; "
                   "pictures only)")
    p.add_argument("--field", metavar="NAME",
                   help="a mesh's vertex field to match, or 'colours' for its vertex colours "
                   "(read through --channel); default: the first species (from pipeline.json "
                   "or state.npz beside the file), else the colours, else the first field")
    p.add_argument("--polarity", choices=("auto", "as-is", "inverted"), default="auto",
                   help="whether the species' high is the picture's light (as-is), dark "
                   "(inverted) or either (auto)")
    p.add_argument("--top", type=options.positive_int, default=3, help="candidates to answer")
    p.add_argument("--seed", type=options.seed, default=0, help="random seed (0)")
    p.add_argument("--out", required=True, metavar="DIR", help="answer directory")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from morphogen.match import DEFAULT_MODELS, match
    from morphogen.match.picture import parse_crop

    models = list(DEFAULT_MODELS) if args.models is None \
        else [m.strip() for m in args.models.split(",") if m.strip()]
    result = match(args.image, models=models, genes=args.gene, budget=args.budget,
                   minutes=args.minutes, channel=args.channel, crop=parse_crop(args.crop),
                   field=args.field,
                   polarity=args.polarity, seed=args.seed, top=args.top, out=args.out,
                   progress=options.show_progress(args), log=lambda line: print(line, flush=True))
    print((result.directory / "report.txt").read_text(), end="")
    return 0
