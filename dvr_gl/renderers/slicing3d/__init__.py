"""``slicing3d``: a 3D texture cut by view-aligned slices, blended back to front (GPU).

See ``dvr_gl/renderers/slicing3d/README.md``; the renderer is :class:`Slicing3DRenderer` in
:mod:`.renderer`, on the slicers' shared base (:mod:`dvr_gl.renderers.grid.slicing`).
"""

from __future__ import annotations

from ...scene import settings as s
from ...scene import sweeps
from ...scene.model import SPLINE_FILTERS
from ...scene.plugin import RendererPlugin

PLUGIN = RendererPlugin(
    name="slicing3d",
    description="3D texture, view-aligned slices blended back to front (GPU)",
    renderer="dvr_gl.renderers.slicing3d.renderer:Slicing3DRenderer",
    order=20,
    view_aligned_slices=True,
    settings=(s.SAMPLE_DISTANCE, s.SAMPLE_DISTANCE_VOXELS, s.COMPOSITING.only("emission_absorption"),
              s.CLASSIFICATION, s.ASSOCIATED_COLORS, s.PREINTEGRATION, s.PREINTEGRATION_SIZE,
              s.FILTER.only(*SPLINE_FILTERS), s.FILTERING, s.GRADIENT, s.GRADIENT_OPACITY,
              s.GRADIENT_OPACITY_REFERENCE, s.LUT_SIZE, s.TEXTURE_BUDGET_MB, s.SHADING, s.SCATTERING, s.CLIPPING,
              s.GEOMETRY),
    data_kinds=("grid", "fields"),
    field_roles=("scalar", "label", "rgb"),
    check="dvr_gl.renderers.slicing3d.fields:check",
    needs_gl=True,
    oracle="dvr_gl.renderers.slicing3d.oracle:oracle",
    sweeps=(sweeps.POST, sweeps.PRE_CLASSIFIED, sweeps.PREINTEGRATED, sweeps.NEAREST, sweeps.LUT_SIZE,
            sweeps.PREINTEGRATION_TABLE, sweeps.BRICKED),
    # Against the closed forms (tests/closed_forms.py), by design: each slice stands for the slab to the
    # next one (d / cos along the ray), so where a box face cuts a slab the optical depth is off by up
    # to one slab, 0.9 x 0.25 / cos here: measured 0.16 (box) and 0.13 (ramp); the sphere's density
    # falls to zero at its edge, where slabs cost nothing: measured 0.  (The slicer against its own
    # planes: the oracle test, float32 only.)  Two constant channels: the same slabs at the faces, of the
    # mixture's extinction, (0.9 + 0.5) x 0.25 / cos: measured 0.19 (perspective) and 0.24 (orthographic).
    tolerances={"box": 0.2, "ramp": 0.15, "sphere": 1e-5, "two channels": 0.3},
)
