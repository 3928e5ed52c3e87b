"""``raycast``: GPU ray casting in one GLSL fragment loop per pixel (``shaders/raycast.frag``).

Every compositing mode, filter and classification, shading, jitter, early termination,
empty-space skipping (:mod:`.acceleration`), bricking, and rendering to a tolerance.
See ``dvr_gl/renderers/raycast/README.md``.  The renderer itself is :mod:`.renderer` (imported when
first created).
"""

from __future__ import annotations

from typing import Optional

from ...scene import settings as s
from ...scene import sweeps
from ...scene.model import SPLINE_FILTERS
from ...scene.plugin import RendererPlugin


def _fitted_range(value):
    if not 5e-4 <= value <= 0.1:
        return "is outside the range the error model is fitted for (5e-4 to 0.1 RMS); choose a value in it"
    return None


TOLERANCE = s.Setting("tolerance", Optional[float], None, "RMS error to meet against the converged reference "
                      "(5e-4 to 0.1): chooses the sample distance, classification and early termination "
                      "(docs/tolerance.md)", check=_fitted_range, must_support=True, group="raycast",
                      excludes=("sample_distance", "sample_distance_voxels"))  # it chooses the sample distance
ACCELERATION = s.Setting("acceleration", str, "auto", "jump empty and constant blocks (the image is unchanged): "
                         "auto (where the frame's block statistics say it pays), on, off",
                         choices=("auto", "on", "off"), aliases=((True, "on"), (False, "off")), group="raycast")
BLOCK_SIZE = s.Setting("block_size", int, 8, "voxels per edge of the finest acceleration blocks",
                       choices=(4, 8, 16, 32), group="raycast")
HOMOGENEITY_TOLERANCE = s.Setting("homogeneity_tolerance", float, 0.0, "> 0 also jumps nearly constant blocks, "
                                  "approximately (docs/acceleration.md)", check=s.at_least(0), group="raycast",
                                  flag=False)
SCREEN_SPACE_ERROR = s.Setting("screen_space_error", float, 1.0, "volumes with coarser levels (OME-Zarr "
                               "multiscales, dvr pyramid): draw each brick from the coarsest level whose voxel "
                               "covers at most this many pixels; 0: always the finest (docs/multiresolution.md)",
                               check=s.at_least(0), group="raycast")


PLUGIN = RendererPlugin(
    name="raycast",
    description="GPU ray casting in a GLSL fragment loop",
    renderer="dvr_gl.renderers.raycast.renderer:RayCastRenderer",
    settings=(s.SAMPLE_DISTANCE, s.SAMPLE_DISTANCE_VOXELS, TOLERANCE, s.COMPOSITING, s.ORDER, s.CLASSIFICATION,
              s.ASSOCIATED_COLORS, s.PREINTEGRATION, s.PREINTEGRATION_SIZE, s.FILTER.only(*SPLINE_FILTERS), s.FILTERING,
              s.GRADIENT, s.GRADIENT_OPACITY, s.GRADIENT_OPACITY_REFERENCE, s.ISO_VALUE, s.ISO_REFINEMENT,
              s.EXTREMUM_REFINEMENT, s.EXTREMUM_BRACKETS, s.JITTER, s.JITTER_SEED, s.ERT_THRESHOLD, s.LUT_SIZE,
              s.TEXTURE_BUDGET_MB, s.MEMORY_BUDGET_MB, ACCELERATION, BLOCK_SIZE, HOMOGENEITY_TOLERANCE,
              SCREEN_SPACE_ERROR, s.SHADING, s.SCATTERING, s.CLIPPING, s.GEOMETRY),
    data_kinds=("grid", "fields"),
    field_roles=("scalar", "label", "rgb"),
    transfer_function_2d=("grid", "fields"),
    check="dvr_gl.renderers.raycast.fields_check:check",
    needs_gl=True,
    out_of_core=True,
    depth_output=True,  # shaders/depth.glsl, one pass (bricked frames and several fields refuse it)
    order=10,
    sort_last=True,
    # shadow rays march from each sample; the light volume interpolates them (half-angle slicing needs slices)
    scattering_methods=("shadow_rays", "light_volume"),
    oracle="dvr_gl.renderers.raycast.oracle:oracle",
    resolve="dvr_gl.renderers.raycast.defaults:resolve",
    resolve_unless=("sample_distance", "sample_distance_voxels", "tolerance"),  # defaults.resolve_defaults
    sweeps=(sweeps.POST, sweeps.PRE_CLASSIFIED, sweeps.PREINTEGRATED, sweeps.PREINTEGRATED_FAST, sweeps.NEAREST,
            sweeps.CUBIC_BSPLINE, sweeps.LUT_SIZE, sweeps.PREINTEGRATION_TABLE, sweeps.EARLY_TERMINATION,
            sweeps.BRICKED, sweeps.LIGHT_VOLUME),
    # Against the conformance tests' closed forms (tests/closed_forms.py), float32 arithmetic only:
    # measured 1.4e-6 (box, ramp), 2.4e-8 (sphere).  MIP and MinIP of the ramp take the extreme
    # *sample*, up to half a segment (0.11 world units here) inside the chord's end, where the
    # extinction differs by 0.25 x 0.11: measured 0.015 in opacity.
    # Two constant channels (several fields, every mode): measured 1.6e-6, float32 arithmetic only.
    tolerances={"box": 1e-5, "ramp": 1e-5, ("ramp", "mip"): 0.02, ("ramp", "minip"): 0.02, "sphere": 1e-5,
                "two channels": 1e-5},
    bench="dvr_gl.renderers.raycast.bench:COMMANDS",
)
