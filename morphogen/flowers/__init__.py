"""Flowers: procedural shapes, vertex sets, random points, positional information and veins.

Ringham et al. (2021) build flower pigmentation models from a shape, a prepattern and a
sequence of simulations (§3.1-3.4); this package supplies the shape and prepattern parts.
"""

from morphogen.flowers.organs import Organ as Organ
from morphogen.flowers.organs import assemble as assemble
from morphogen.flowers.organs import dianthus as dianthus
from morphogen.flowers.organs import orchid as orchid
from morphogen.flowers.organs import urn_flower as urn_flower
from morphogen.flowers.planar import grid_mesh as grid_mesh
from morphogen.flowers.planar import lattice_mesh as lattice_mesh
from morphogen.flowers.positional import direction_field as direction_field
from morphogen.flowers.positional import positional_information as positional_information
from morphogen.flowers.sampling import random_vertices as random_vertices
from morphogen.flowers.sampling import seed_field as seed_field
from morphogen.flowers.sampling import surface_points as surface_points
from morphogen.flowers.shapes import SHAPES as SHAPES
from morphogen.flowers.shapes import bell as bell
from morphogen.flowers.shapes import bilabiate as bilabiate
from morphogen.flowers.shapes import corolla as corolla
from morphogen.flowers.shapes import petal as petal
from morphogen.flowers.shapes import tube as tube
from morphogen.flowers.shapes import two_lipped as two_lipped
from morphogen.flowers.shapes import urn as urn
from morphogen.flowers.sizing import estimate_vertices as estimate_vertices
from morphogen.flowers.sizing import make_shape as make_shape
from morphogen.flowers.veins import VeinGraph as VeinGraph
from morphogen.flowers.veins import space_colonisation as space_colonisation
from morphogen.flowers.veins import vein_fields as vein_fields
from morphogen.flowers.veins import vein_statistics as vein_statistics
from morphogen.flowers.veins_closed import areoles as areoles
from morphogen.flowers.veins_closed import closed_colonisation as closed_colonisation
