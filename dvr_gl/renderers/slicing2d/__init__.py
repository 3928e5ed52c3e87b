"""``slicing2d``: three stacks of 2D slices, the most view-aligned one blended back to front (GPU).

See ``dvr_gl/renderers/slicing2d/README.md``; the renderer is :class:`Slicing2DRenderer` in
:mod:`.renderer`, on the slicers' shared base (:mod:`dvr_gl.renderers.grid.slicing`).
"""

from __future__ import annotations

from ...errors import SceneError
from ...scene import settings as s
from ...scene import sweeps
from ...scene.plugin import RendererPlugin


def check(scene):
    r = scene.renderer
    if r.shading.enabled and r.gradient == "texture":
        raise SceneError("slicing2d computes gradients by central differences across the stack: set "
                         "renderer.gradient to central_differences")


PLUGIN = RendererPlugin(
    name="slicing2d",
    description="three stacks of 2D slices, the most view-aligned one blended back to front (GPU)",
    renderer="dvr_gl.renderers.slicing2d.renderer:Slicing2DRenderer",
    order=30,
    settings=(s.COMPOSITING.only("emission_absorption"), s.CLASSIFICATION.only("post", "preintegrated"),
              s.PREINTEGRATION, s.PREINTEGRATION_SIZE, s.FILTER.only("nearest", "linear"), s.FILTERING, s.GRADIENT,
              s.GRADIENT_OPACITY, s.GRADIENT_OPACITY_REFERENCE, s.LUT_SIZE, s.TEXTURE_BUDGET_MB, s.SHADING, s.CLIPPING,
              s.GEOMETRY),
    data_kinds=("grid",),
    needs_gl=True,
    fixed_planes=True,
    check=check,
    oracle="dvr_gl.renderers.slicing2d.oracle:oracle",
    sweeps=(sweeps.CLASSIFICATION, sweeps.LUT_SIZE),
    # Against the closed forms (tests/closed_forms.py), by design: every voxel plane is drawn, each
    # standing for the slab to the next plane (spacing / |cos| along the ray, up to 1.2 world units at
    # these angles), so the planes on the box's faces add up to one slab of optical depth: measured
    # 0.45 (box) and 0.31 (ramp); the sphere's density is zero at the box's faces: measured 0.
    # (The stacks against their own planes: the oracle test, float32 only.)
    tolerances={"box": 0.5, "ramp": 0.35, "sphere": 1e-5},
    bench="dvr_gl.renderers.slicing2d.bench:COMMANDS",
)
