"""``shearwarp``: Lacroute and Levoy's shear-warp; run-length encoded slices composited on the
host (:mod:`.run_length`, :mod:`.factorization`), the intermediate image warped in GL.

See ``dvr_gl/renderers/shearwarp/README.md``; the renderer is :mod:`.renderer`.
"""

from __future__ import annotations

from ...errors import SceneError
from ...scene import settings as s
from ...scene import sweeps
from ...scene.plugin import RendererPlugin

OPACITY_THRESHOLD = s.Setting("opacity_threshold", float, 0.0, "voxels at most this opaque (over one "
                              "unit_distance) are left out of the run-length encoding; 0 leaves the image "
                              "unchanged", check=s.between(0.0, 1.0, open_hi=True), group="shearwarp")


def check(scene):
    """What the settings do not say: associated colours for pre-classification.  (A perspective eye
    inside the volume is factored by pyramids: :func:`.factorization.factorize_view`.)"""
    r = scene.renderer
    if r.classification == "pre" and not r.associated_colors:
        raise SceneError("shearwarp composites associated colours; set renderer.associated_colors = true")


PLUGIN = RendererPlugin(
    name="shearwarp",
    description="shear-warp: run-length encoded slices composited on the host, warped in GL",
    renderer="dvr_gl.renderers.shearwarp.renderer:ShearWarpRenderer",
    order=40,
    settings=(s.COMPOSITING.only("emission_absorption"), s.CLASSIFICATION.only("post", "pre"), s.ASSOCIATED_COLORS,
              s.FILTER.only("linear"), s.ERT_THRESHOLD, s.LUT_SIZE, OPACITY_THRESHOLD, s.SHADING, s.GRADIENT_OPACITY,
              s.GRADIENT_OPACITY_REFERENCE, s.CLIPPING, s.GEOMETRY),
    data_kinds=("grid",),
    needs_gl=True,
    fixed_planes=True,
    check=check,
    oracle="dvr_gl.renderers.shearwarp.oracle:oracle",
    sweeps=(sweeps.CLASSIFICATION, sweeps.LUT_SIZE, sweeps.EARLY_TERMINATION,
            sweeps.Family("opacity threshold", "renderer.opacity_threshold", (0.0, 1e-3, 1e-2, 3e-2))),
    # Against the closed forms (tests/closed_forms.py), by design: the voxel planes' slabs as for 2D
    # stacks (measured 0.45 box, 0.41 ramp), and two resamplings (along the intermediate image's rays,
    # then the warp), which blur the sphere's gradient: measured 0.06.  (Against its own slices: the
    # oracle test, float32 only.)
    tolerances={"box": 0.5, "ramp": 0.45, "sphere": 0.07},
    bench="dvr_gl.renderers.shearwarp.bench:COMMANDS",
)
