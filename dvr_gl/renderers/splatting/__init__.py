"""``splatting``: Westover's object-order method in GL.  Each sample's reconstruction kernel (the
Gaussian, :mod:`dvr_gl.fields.reconstruction`) is integrated along each pixel's ray from footprint
tables (:mod:`.footprint`), drawn as an instanced quad, and accumulated in float32 sheet buffers
that are composited front to back.

``renderer.sheet_buffer``:

* ``image_aligned`` (Mueller and Crawfis 1998, the default): slabs parallel to the image plane,
  ``renderer.slab_width`` voxels deep; each kernel adds the part of its integral that lies in a
  slab to that slab's sheet; post-classified, the sheet's mean value over the slab is classified
  per pixel (Mueller, Moeller and Crawfis 1999); pre-classified, the sheet holds the slab's optical
  depth and colour.
* ``axis_aligned`` (Westover 1990): a sheet per voxel plane across the axis that faces the view most
  squarely; each kernel adds its whole footprint to its own plane's sheet; the colour jumps where
  that axis changes (45 degrees).
* ``none``: every splat composited alone, back to front (pre-classified only): the baseline that
  shows the error where splats overlap.

See ``dvr_gl/renderers/splatting/README.md``; the renderer is :mod:`.renderer`, its same-slabs reference
:mod:`.oracle`.
"""

from __future__ import annotations

from ...clipping import clipping_in_use
from ...errors import SceneError
from ...scene import settings as s
from ...scene import sweeps
from ...scene.model import CLASSIFIED_ALONG_RAY
from ...scene.plugin import RendererPlugin
from .low_pass import SCREEN_LOW_PASS

SHEET_BUFFERS = ("image_aligned", "axis_aligned", "none")
#: The kernels splatting splats a grid with: the Gaussian (tables) and the tensor cubic B-spline (exact
#: piecewise quadrature, shaders/bspline.glsl).
GRID_KERNELS = ("gaussian", "cubic_bspline")

SHEET_BUFFER = s.Setting("sheet_buffer", str, "image_aligned", "how splats are composited: image_aligned (slabs "
                         "parallel to the image, Mueller and Crawfis), axis_aligned (a sheet per voxel plane "
                         "facing the view most squarely, Westover) or none (each splat alone, back to front; "
                         "pre-classified only)", choices=SHEET_BUFFERS, group="splatting")
FOOTPRINTS = ("exact", "ewa")
FOOTPRINT = s.Setting("footprint", str, "exact", "how a kernel's footprint is found in perspective: exact (each "
                      "pixel's own ray through the kernel) or ewa (Zwicker et al.'s affine approximation at the "
                      "kernel's centre: every ray near it taken as parallel to the central one; to measure its "
                      "error)", choices=FOOTPRINTS, group="splatting")
SLABS_PER_DRAW = s.Setting("slabs_per_draw", int, 1, "image-aligned slabs drawn at once, a render target each: "
                           "each splat drawn once per group of slabs instead of once per slab (on software GL "
                           "1 is fastest, dvr_gl/renderers/splatting/README.md)", check=s.between(1, 8),
                           group="splatting")
SLAB_WIDTH = s.Setting("slab_width", float, 1.0, "depth of an image-aligned sheet buffer's slab", check=s.positive,
                       units="voxels", group="splatting")


def check(scene):
    """What the settings do not say: ``none`` composites each splat's own colour, so the colour must
    be the voxel's (pre-classification, associated)."""
    r = scene.renderer
    grid = scene.field.kind == "grid"
    kernels = GRID_KERNELS if grid else ("m4",)
    if r.filter not in kernels:
        raise SceneError(f"splatting splats a "
                         f"{'grid with the gaussian or cubic_bspline' if grid else 'particle set with its m4'} "
                         f"kernel; set renderer.filter = {kernels[0]} (got {r.filter})")
    if grid and r.filter == "gaussian" and not r.kernel_width <= max(scene.volume.dims):
        largest = max(scene.volume.dims)
        raise SceneError(f"renderer.kernel_width = {r.kernel_width:g} voxels is wider than the volume ({largest} "
                         f"voxels along its longest axis), whose field would be flat; splatting pads the grid with "
                         f"border copies as far as the kernel reaches: use at most {largest}")
    if r.screen_low_pass > 0 and r.filter != "gaussian":
        raise SceneError("renderer.screen_low_pass widens Gaussian footprints (EWA); set renderer.filter = "
                         "gaussian, or screen_low_pass = 0"
                         + ("" if grid else " (particles smaller than a pixel are averaged over its square already)"))
    if not grid and r.sheet_buffer == "axis_aligned":
        raise SceneError("renderer.sheet_buffer = axis_aligned stacks a grid's voxel planes; SPH particles have none: "
                         "use image_aligned or none")
    if r.shading.enabled and r.shading.lights and not (r.sheet_buffer == "image_aligned" and r.classification == "post"
                                                      and r.compositing == "emission_absorption"):
        raise SceneError("splatting shades post-classified image-aligned sheets of emission-absorption (gradients "
                         "of the slab means in screen space); turn shading off or use those settings")
    if r.compositing in CLASSIFIED_ALONG_RAY and r.sheet_buffer == "none" and r.classification != "pre":
        raise SceneError("splatting with renderer.sheet_buffer = none composites each splat's own colour: set "
                         "renderer.classification = pre, or use sheet_buffer image_aligned")
    if r.classification == "pre" and not r.associated_colors:
        raise SceneError("splatting splats associated colours (sigma c); set renderer.associated_colors = true")
    if not grid and (clipping_in_use(r.clipping) or r.geometry):
        raise SceneError("splatting clips and stops at meshes along each pixel's ray, and averages particles "
                         "smaller than a pixel over its square instead: turn renderer.clipping and "
                         "renderer.geometry off for particle sets, or resample them onto a grid")


PLUGIN = RendererPlugin(
    name="splatting",
    description="splatting: each sample's kernel integrated into footprints, sheet buffers in GL",
    renderer="dvr_gl.renderers.splatting.renderer:SplattingRenderer",
    order=90,
    settings=(s.COMPOSITING.only("emission_absorption", "average", "xray"), s.CLASSIFICATION.only("post", "pre"),
              s.ASSOCIATED_COLORS, s.FILTER.only("gaussian", "cubic_bspline", "m4"), s.KERNEL_WIDTH, s.KERNEL_RADIUS,
              SHEET_BUFFER, SLAB_WIDTH, SLABS_PER_DRAW, FOOTPRINT, SCREEN_LOW_PASS, s.ERT_THRESHOLD, s.LUT_SIZE,
              s.SHADING, s.CLIPPING, s.GEOMETRY),
    data_kinds=("grid", "particles"),
    needs_gl=True,
    check=check,
    oracle="dvr_gl.renderers.splatting.oracle:oracle",
    # the slab width, with each kind's kernel (a grid's default filter, linear, is not splatted)
    sweeps=(sweeps.Family("slab width", "renderer.slab_width", (2.0, 1.0, 0.5, 0.25),
                          (("renderer.filter", "gaussian"),), data_kinds=("grid",)),
            sweeps.Family("slab width", "renderer.slab_width", (2.0, 1.0, 0.5, 0.25),
                          (("renderer.filter", "m4"),), data_kinds=("particles",))),
    # Against the closed forms (tests/closed_forms.py), with the Gaussian, which is not the trilinear filter
    # their bounds assume: the box is constant to the float32 tables (measured 1.3e-6); the ramp bends
    # within the kernel's reach of its x faces, where the clamped taps repeat the border samples (its grids
    # are 6-9 samples wide: measured 6.7e-3 emission-absorption and X-ray, 1.7e-2 average); the Gaussian adds
    # sigma^2 h^2 per axis to the sphere's quadratic data (measured 2.7e-2).  The same-kernel reference
    # (the oracle) is off the bounds by the same amounts, to 1e-5: the model's difference, not the GL's.
    tolerances={"box": 1e-5, ("ramp", "emission_absorption"): 0.01, ("ramp", "xray"): 0.01, ("ramp", "average"): 0.025,
                "sphere": 0.04},
    bench="dvr_gl.renderers.splatting.bench:COMMANDS",
)
