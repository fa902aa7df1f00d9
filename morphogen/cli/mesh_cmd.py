"""``morphogen mesh``: generate flower meshes, grow veins on them, render their fields through
colour maps and transfer functions, and describe mesh files."""

from __future__ import annotations

import argparse
from pathlib import Path

from morphogen.cli import options
from morphogen.errors import MorphogenError


def _floats(text: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        message = f"expected numbers separated by commas, got {text!r}"
        raise argparse.ArgumentTypeError(message) from None


SHAPES = ("petal", "corolla", "tube", "urn", "bell", "two_lipped", "bilabiate", "urn_flower",
          "orchid", "dianthus")
"""The shapes of :data:`morphogen.flowers.SHAPES` (listed here so that the parser does not import
the mesh code)."""


def _setting(text: str) -> tuple[str, object]:
    """``NAME=VALUE`` with VALUE read as a TOML value (number, list, string, boolean)."""
    import tomllib

    from morphogen.models.text import toml_text

    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep or not name.isidentifier():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    try:
        return name, toml_text.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return name, value.strip()


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("mesh", help="generate flower meshes (PLY) and describe mesh files",
                       description="Procedural flower meshes with near-equilateral triangles, "
                       "per-vertex fields and named vertex sets (margin, base, throat, midline).")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    make = actions.add_parser(
        "make", help="write a generated shape to a PLY file",
        description="--edge is the mean edge of the written mesh, after --scale (as edge in a "
        "pipeline's [mesh] table); the vertex count is estimated first and requests over 2 "
        "million vertices are refused.")
    make.add_argument("shape", nargs="?", choices=SHAPES, help="the shape (or --shape)")
    make.add_argument("--shape", dest="shape_option", choices=SHAPES, metavar="SHAPE",
                      help=f"the shape: {', '.join(SHAPES)}")
    make.add_argument("--out", required=True, metavar="FILE.ply", help="output PLY file")
    make.add_argument("--edge", type=float, default=0.02,
                      help="mean edge length of the result, after --scale (default 0.02)")
    make.add_argument("--scale", type=float, default=1.0, help="uniform scale of the result")
    make.add_argument("--petals", type=int, help="corolla: number of petals (default 5)")
    make.add_argument("--lobes", type=int, help="tube, urn, bell, two_lipped: number of lobes")
    make.add_argument("--lobe-scales", type=_floats, metavar="A,B,...",
                      help="tube: relative lobe sizes, e.g. 0.75,0.75,1.1,1.3,1.1")
    make.add_argument("--length", type=float, help="petal or tube length")
    make.add_argument("--width", type=float, help="petal width")
    make.add_argument("--radius", type=float, help="corolla radius or tube base radius")
    make.add_argument("--eye", type=float, help="corolla: central hole, fraction of the radius")
    make.add_argument("--notch", type=float, help="depth of the notch at each tip")
    make.add_argument("--teeth", type=int, help="corolla: teeth per petal (Dianthus)")
    make.add_argument("--fringe", type=float, help="corolla: depth of the teeth")
    make.add_argument("--set", dest="settings", action="append", default=[], type=_setting,
                      metavar="NAME=VALUE",
                      help="any other argument of the shape's generator, e.g. mouth=0.5, "
                      "column=0.12, upper=0.7 (repeatable; values as in TOML)")
    make.add_argument("--png", action="store_true", help="also write FILE.png, a rendered view")
    make.set_defaults(func=run_make)
    veins = actions.add_parser(
        "veins", help="grow veins on a mesh by space colonisation (Ringham et al. 3.4.1)",
        description="Writes OUT.ply with the per-vertex fields vein (1 on veins), "
        "vein_thickness and vein_distance (path length over mesh edges to the nearest vein, "
        "mesh units), and the vein graph as OUT.veins.npz. Lengths default to multiples of "
        "the mean edge e: step 2e, kill 3 step, influence 15 step. --venation closed grows "
        "reticulate veins that meet and form loops (Runions et al. 2005).")
    veins.add_argument("file", metavar="MESH.ply")
    veins.add_argument("--out", required=True, metavar="OUT.ply", help="output PLY file")
    veins.add_argument("--seeds", required=True, metavar="SET",
                       help="where veins start: a vertex set (e.g. base) or an expression")
    veins.add_argument("--points", type=int, default=2000, help="attraction points (2000)")
    veins.add_argument("--influence", type=float, help="influence radius (mesh units)")
    veins.add_argument("--kill", type=float, help="kill distance (mesh units)")
    veins.add_argument("--step", type=float, help="growth step (mesh units)")
    veins.add_argument("--iterations", type=int, default=400, help="most growth steps (400)")
    veins.add_argument("--density", metavar="EXPR",
                       help="acceptance probability of attraction points, from fields")
    veins.add_argument("--refill", type=int,
                       help="attraction points drawn each growth step as the surface fills (0)")
    veins.add_argument("--birth", type=float,
                       help="a refilled point is kept only this far from veins and points "
                       "(mesh units; default the kill distance)")
    veins.add_argument("--min-branch", type=float,
                       help="remove terminal branches shorter than this (mesh units; 0 keeps all)")
    veins.add_argument("--gamma", type=float, help="Murray's-law exponent of vein thickness (3)")
    veins.add_argument("--tip-radius", type=float, help="vein radius at the tips (mesh units)")
    veins.add_argument("--venation", choices=("open", "closed"), default="open",
                       help="open: a tree, each attraction point pulls its nearest vein; closed: "
                       "each point pulls every vein of its relative neighbourhood and is "
                       "removed when all have reached it, so veins meet in loops (open)")
    veins.add_argument("--same-piece", action="store_true",
                       help="keep each vein on the connected piece of the mesh its root is on")
    veins.add_argument("--seed", type=options.seed, default=0, help="random seed (0)")
    veins.add_argument("--cmap", default="#f4f1fb,#7b68c8",
                       help="colour map of vein_distance under the veins")
    veins.add_argument("--view", default="oblique", help="view of the --png picture")
    veins.add_argument("--png", action="store_true", help="also write OUT.png, a rendered view")
    veins.set_defaults(func=run_veins)
    render = actions.add_parser(
        "render", help="colour a field of a PLY mesh through a colour map or transfer function",
        description="Writes OUT.png (a rendered view) and, with --ply, a PLY with the colours. "
        "--cmap takes a colour map name, a ramp '#fff,#a00', or a transfer function at the "
        "field's own values (Ringham et al. 3.5): 'step: #f4c430 < 0.08 < #3b0612' (a "
        "threshold; more levels for a step map) or 'ramp: 0 #fff, 0.3 #f4d6dc, 0.35 #c0143c, "
        "1 #6e0019' (non-linear; '; gamma G' bends it).")
    render.add_argument("file", metavar="MESH.ply")
    render.add_argument("--field", required=True, metavar="EXPR",
                        help="the field to colour, or an expression of fields and x, y, z")
    render.add_argument("--cmap", "--transfer", dest="cmap", default="viridis",
                        help="colour map, ramp or transfer function (default viridis)")
    render.add_argument("--out", required=True, metavar="OUT.png", help="output picture")
    render.add_argument("--ply", metavar="OUT.ply", help="also write the coloured mesh")
    render.add_argument("--view", default="oblique", help="view: oblique, top, or ELEV,AZIM")
    render.set_defaults(func=run_render)
    info = actions.add_parser("info", help="describe a PLY mesh: size, edges, fields, sets")
    info.add_argument("file", metavar="FILE.ply")
    info.set_defaults(func=run_info)


def run_make(args: argparse.Namespace) -> int:
    import inspect

    from morphogen import flowers
    from morphogen.domains.ply import save_ply

    if not args.out.lower().endswith(".ply"):
        raise MorphogenError(f"--out must name a .ply file, got {args.out}")
    if (args.shape is None) == (args.shape_option is None):
        raise MorphogenError("name one shape, as mesh make SHAPE or --shape SHAPE, "
                             f"one of {', '.join(SHAPES)}")
    shape = args.shape or args.shape_option
    given = {k: v for k, v in vars(args).items()
             if k in {"petals", "lobes", "lobe_scales", "length", "width", "radius", "eye",
                      "notch", "teeth", "fringe"} and v is not None}
    for key, value in args.settings:
        if key in given or key in {"edge", "scale"}:
            raise MorphogenError(f"--set {key} repeats an option; give it once")
        given[key] = value
    accepted = set(inspect.signature(getattr(flowers, shape)).parameters) - {"edge"}
    unused = sorted(set(given) - accepted)
    if unused:
        flags = ", ".join("--" + k.replace("_", "-") for k in unused)
        raise MorphogenError(f"{flags} do(es) not apply to a {shape}; it takes "
                             f"{', '.join(sorted(accepted))}")
    mesh = flowers.make_shape(shape, edge=args.edge, scale=args.scale, **given)
    path = save_ply(args.out, mesh)
    if args.png:
        from morphogen.render.colour import colourise
        from morphogen.render.images import write_png
        from morphogen.render.mesh import render_mesh

        key = "r" if "r" in mesh.fields else "s"
        image = render_mesh(mesh.vertices, mesh.faces, colourise(mesh.fields[key], "viridis"))
        write_png(Path(args.out).with_suffix(".png"), image)
    print(f"wrote {path} ({mesh.n_vertices} vertices, {mesh.n_faces} triangles, "
          f"mean edge {mesh.edge_length:.4g}; fields: {', '.join(mesh.fields)})")
    return 0


def run_render(args: argparse.Namespace) -> int:
    from morphogen.domains.ply import load_mesh, save_ply
    from morphogen.flowers.stages import evaluate
    from morphogen.render.colour import check_cmap, colourise
    from morphogen.render.images import write_png
    from morphogen.render.mesh import parse_view, render_mesh

    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise MorphogenError(f"--out must name a .png file, got {args.out}")
    if args.ply is not None and not args.ply.lower().endswith(".ply"):
        raise MorphogenError(f"--ply must name a .ply file, got {args.ply}")
    check_cmap(args.cmap)
    parse_view(args.view)
    mesh = load_mesh(args.file)
    values = evaluate(args.field, mesh)
    colours = colourise(values, args.cmap)
    image = render_mesh(mesh.vertices, mesh.faces, colours, view=args.view)
    if args.ply is not None:
        save_ply(args.ply, mesh, colours=colours)
    write_png(out, image)
    print(f"wrote {out}" + (f" and {args.ply}" if args.ply else "")
          + f": {args.field} from {values.min():.4g} to {values.max():.4g} through {args.cmap}")
    return 0


def run_info(args: argparse.Namespace) -> int:
    from morphogen.domains.ply import load_mesh

    mesh = load_mesh(args.file)
    print(f"{args.file}: {mesh.n_vertices} vertices, {mesh.n_faces} triangles")
    print(f"mean edge {mesh.edge_length:.4g}, area {mesh.areas.sum():.4g}, "
          f"{len(mesh.boundary_vertices)} boundary vertices")
    print(f"largest stable Euler dt for D = 1: {2.0 / mesh.spectral_radius():.4g}")
    for name, values in mesh.fields.items():
        count = int((values > 0.5).sum())
        print(f"  field {name}: min {values.min():.4g}, max {values.max():.4g}, "
              f"{count} vertices > 0.5")
    return 0


def run_veins(args: argparse.Namespace) -> int:
    from morphogen.domains.ply import load_mesh, save_ply
    from morphogen.flowers.stages import grow_veins
    from morphogen.flowers.veins import vein_statistics
    from morphogen.flowers.veins_closed import areoles
    from morphogen.render.colour import colourise
    from morphogen.render.mesh import overlay_veins, parse_view
    from morphogen.util.io import write_npz

    out = Path(args.out)
    if out.suffix.lower() != ".ply":
        raise MorphogenError(f"--out must name a .ply file, got {args.out}")
    parse_view(args.view)
    mesh = load_mesh(args.file)
    stage = {k: getattr(args, k) for k in ("seeds", "points", "influence", "kill", "step",
                                            "iterations", "density", "seed", "refill", "birth",
                                            "min_branch", "gamma", "tip_radius", "venation")
             if getattr(args, k) is not None}
    stage["same_piece"] = args.same_piece
    graph, fields = grow_veins(stage, mesh)
    colours = overlay_veins(colourise(fields["vein_distance"], args.cmap), fields["vein"],
                            fields["vein_thickness"])
    image = None
    if args.png:
        from morphogen.render.mesh import render_mesh

        image = render_mesh(mesh.vertices, mesh.faces, colours, view=args.view)
    graph_path = out.with_suffix(".veins.npz")
    write_npz(graph_path, graph.arrays())
    path = save_ply(out, mesh.with_fields(**fields), colours=colours)
    if image is not None:
        from morphogen.render.images import write_png

        write_png(out.with_suffix(".png"), image)
    stats = vein_statistics(graph, float(mesh.areas.sum()))
    order = f"Strahler order up to {stats['strahler']}" if len(graph.links) == 0 \
        else "joined by links (no Strahler order)"
    print(f"wrote {path} and {graph_path}: {len(graph.nodes)} vein nodes from "
          f"{len(graph.seeds)} seeds, {order}, "
          f"{int(fields['vein'].sum())} of {mesh.n_vertices} vertices on veins, "
          f"{len(graph.remaining)} attraction points unreached")
    print(f"{stats['tips']} tips, {stats['loops']} loops, "
          f"{len(areoles(mesh, fields['vein']))} areoles, vein length {stats['length']:.4g}, "
          f"spacing {stats['spacing']:.4g}")
    return 0
