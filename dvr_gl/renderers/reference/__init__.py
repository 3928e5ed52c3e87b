"""``reference``: the same-discretization reference, float64 on the CPU (:mod:`dvr_gl.reference.discrete`).

The judge of "is the GPU code right?": every compositing mode, classification, filter and
shading option, sampled exactly where the conventions put the samples, through the same
transfer-function table.  It renders any field (:mod:`dvr_gl.fields`).  See
``dvr_gl/renderers/reference/README.md``.
"""

from __future__ import annotations

from ...reference.fields import ROLES
from ...scene import settings as s
from ...scene.plugin import RendererPlugin

PLUGIN = RendererPlugin(
    name="reference",
    description="CPU float64, same discretization as the GPU (samples, LUT)",
    renderer="dvr_gl.renderers.reference.renderer:DiscreteReferenceRenderer",
    order=50,
    settings=(s.SAMPLE_DISTANCE, s.SAMPLE_DISTANCE_VOXELS, s.COMPOSITING, s.ORDER, s.CLASSIFICATION,
              s.ASSOCIATED_COLORS, s.PREINTEGRATION, s.PREINTEGRATION_SIZE, s.FILTER, s.KERNEL_WIDTH, s.KERNEL_RADIUS,
              s.GRADIENT_OPACITY, s.GRADIENT_OPACITY_REFERENCE, s.ISO_VALUE, s.ISO_REFINEMENT, s.EXTREMUM_REFINEMENT,
              s.EXTREMUM_BRACKETS, s.JITTER, s.JITTER_SEED, s.ERT_THRESHOLD, s.LUT_SIZE, s.SHADING, s.SCATTERING,
              s.CLIPPING, s.GEOMETRY),
    data_kinds=None,
    reference=True,
    depth_output=True,  # the judge of depth images (dvr_gl.reference.depth)
    # several fields: the members' models mixed per sample (dvr_gl/reference/fields.py), which refuses in one
    # line what the mixture does not define (a projection of a label, scattering through the mixture)
    field_roles=ROLES,
    transfer_function_2d=("grid", "fields"),
    check="dvr_gl.reference.fields:check",
    # Against the closed forms (tests/closed_forms.py): float64, measured 3e-8 (rounding of the float32
    # data and the output).  MIP and MinIP of the ramp: the extreme sample, up to half a segment inside
    # the chord's end (measured 0.015, as the ray caster).  The analytic sphere has a sharp boundary
    # that point samples place to within a segment: measured 0.035.  The mesh boxes' gap: a segment
    # straddling one of the four faces a ray crosses counts whole or not at all (sigma d = 0.018 at
    # the closed form's d = 0.02; measured 0.0071; the X-ray alike); MIP and MinIP of the mesh ramp as of the ramp, at
    # that d (measured 0.0014).  Two channels (several fields, every mode): measured 3e-8, as the box.
    tolerances={"box": 1e-6, "ramp": 1e-6, ("ramp", "mip"): 0.02, ("ramp", "minip"): 0.02, "sphere": 1e-6,
                "analytic sphere": 0.04, "mesh boxes": 1e-6, ("mesh boxes", "emission_absorption"): 0.01,
                ("mesh boxes", "xray"): 0.01,
                "mesh ramp": 1e-6, ("mesh ramp", "mip"): 0.002, ("mesh ramp", "minip"): 0.002, "two channels": 1e-6},
)
