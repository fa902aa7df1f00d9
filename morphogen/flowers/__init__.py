"""Flowers: procedural shapes, vertex sets, random points, positional information and veins.

Ringham et al. (2021) build flower pigmentation models from a shape, a prepattern and a
sequence of simulations (§3.1-3.4); this package supplies the shape and prepattern parts.
"""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "Organ": "morphogen.flowers.organs",
    "assemble": "morphogen.flowers.organs",
    "dianthus": "morphogen.flowers.organs",
    "orchid": "morphogen.flowers.organs",
    "urn_flower": "morphogen.flowers.organs",
    "grid_mesh": "morphogen.flowers.planar",
    "lattice_mesh": "morphogen.flowers.planar",
    "direction_field": "morphogen.flowers.positional",
    "positional_information": "morphogen.flowers.positional",
    "random_vertices": "morphogen.flowers.sampling",
    "seed_field": "morphogen.flowers.sampling",
    "surface_points": "morphogen.flowers.sampling",
    "SHAPES": "morphogen.flowers.shapes",
    "bell": "morphogen.flowers.shapes",
    "bilabiate": "morphogen.flowers.shapes",
    "corolla": "morphogen.flowers.shapes",
    "petal": "morphogen.flowers.shapes",
    "tube": "morphogen.flowers.shapes",
    "two_lipped": "morphogen.flowers.shapes",
    "urn": "morphogen.flowers.shapes",
    "estimate_vertices": "morphogen.flowers.sizing",
    "make_shape": "morphogen.flowers.sizing",
    "VeinGraph": "morphogen.flowers.veins",
    "space_colonisation": "morphogen.flowers.veins",
    "vein_fields": "morphogen.flowers.veins",
    "vein_statistics": "morphogen.flowers.veins",
    "areoles": "morphogen.flowers.veins_closed",
    "closed_colonisation": "morphogen.flowers.veins_closed",
})
