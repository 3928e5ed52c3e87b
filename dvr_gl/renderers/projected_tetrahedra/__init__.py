"""``projected-tetrahedra``: Shirley and Tuchman's projected tetrahedra in GL for tetrahedral meshes
(:mod:`dvr_gl.fields.mesh`), in an exact visibility order (:mod:`.order`).

Each cell is one point drawn in visibility order; a geometry shader projects it and draws its
silhouette (Shirley-Tuchman's class 1 or 2), and each fragment clips its own ray against the
cell's four faces and integrates the exact transfer function along the piece inside
(``shaders/cells/``).  See ``docs/meshes.md``; the renderer is :mod:`.renderer`.
"""

from __future__ import annotations

from ...scene import settings as s
from ...scene import sweeps
from ...scene.plugin import RendererPlugin
from .order import ORDERS

INTEGRATIONS = ("exact", "shirley-tuchman")

CELL_ORDER = s.Setting("cell_order", str, "exact", "visibility order of the cells: exact (across shared faces "
                       "by the eye's side, across gaps by the pixels' rays) or centroid (by the distance of "
                       "each cell's centre; approximate)", choices=ORDERS, group="projected-tetrahedra")

INTEGRATION = s.Setting("integration", str, "exact", "emission-absorption per cell: exact (every fragment "
                        "clips its own ray and integrates the transfer function along it) or shirley-tuchman "
                        "(colour and optical depth at the footprint's thick vertex, interpolated across its "
                        "triangles: approximate, cheaper per fragment; the exact path where the camera reaches "
                        "the mesh, with clipping or opaque geometry)", choices=INTEGRATIONS,
                        group="projected-tetrahedra")

PLUGIN = RendererPlugin(
    name="projected-tetrahedra",
    description="projected tetrahedra in GL for meshes, exact visibility order",
    renderer="dvr_gl.renderers.projected_tetrahedra.renderer:ProjectedTetrahedraRenderer",
    order=70,
    settings=(s.COMPOSITING.only(*s.COMPOSITING_BEFORE_XRAY), s.ISO_VALUE, CELL_ORDER, INTEGRATION, s.CLIPPING,
              s.GEOMETRY),
    data_kinds=("mesh",),
    needs_gl=True,
    sweeps=(sweeps.Family("cell order", "renderer.cell_order", ("centroid", "exact")),),
    # Against the closed forms on meshes (tests/closed_forms.py): float32 planes, values and
    # quadrature against float64 (measured below 2e-6; emission-absorption's Gauss-Legendre on
    # pieces of optical depth at most one is exact to float32 for these linear transfer functions).
    tolerances={"mesh boxes": 1e-5, "mesh ramp": 1e-5},
    bench="dvr_gl.renderers.projected_tetrahedra.bench:COMMANDS",
)
