"""``cell-raycast``: ray casting from cell to cell through tetrahedral meshes
(:mod:`dvr_gl.fields.mesh`) in GL, after Garrity (1990) and Weiler et al. (2003).

Each pixel's ray enters the mesh at its nearest entering boundary face (per-pixel lists of them,
drawn once a frame), walks through the cells by their face neighbours, clipping itself against
each cell's four face planes and integrating the exact transfer function along each piece (the
same shader code as ``projected-tetrahedra``), and goes on at the next entry beyond each exit:
front to back along every ray, so no visibility order and no footprints.  See ``docs/meshes.md``;
the renderer is :mod:`.renderer`.
"""

from __future__ import annotations

from ...scene import settings as s
from ...scene import sweeps
from ...scene.plugin import RendererPlugin

PLUGIN = RendererPlugin(
    name="cell-raycast",
    description="ray casting from cell to cell through meshes in GL, no visibility order",
    renderer="dvr_gl.renderers.cell_raycast.renderer:CellRaycastRenderer",
    order=80,
    settings=(s.COMPOSITING.only(*s.COMPOSITING_BEFORE_XRAY), s.ISO_VALUE, s.ERT_THRESHOLD, s.CLIPPING, s.GEOMETRY),
    data_kinds=("mesh",),
    needs_gl=True,
    sweeps=(sweeps.EARLY_TERMINATION,),
    # Against the closed forms on meshes (tests/closed_forms.py), measured below: float32 planes,
    # values and quadrature against float64, as projected tetrahedra.
    tolerances={"mesh boxes": 1e-5, "mesh ramp": 1e-5},
)
