"""Where a state diffuses: the Domain protocol, grids (periodic, no-flux, Dirichlet; 5-, 9- and
7-point stencils; spectral) and triangle meshes (built, or read from PLY)."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "Domain": "morphogen.domains.base",
    "Grid": "morphogen.domains.grid",
    "Boundary": "morphogen.domains.grid",
    "Mesh": "morphogen.domains.mesh",
    "MeshBoundary": "morphogen.domains.mesh",
    "load_mesh": "morphogen.domains.ply",
    "save_ply": "morphogen.domains.ply",
})
