"""``reference-converged``: the converged reference, float64 on the CPU (:mod:`dvr_gl.reference.converged`).

The judge of "how accurate is this setting?": the rendering integral of the continuous model
(the scene's filter, classification and shading, the exact transfer function), to a per-pixel
error budget.  It has no sampling grid, so the sample distance and jitter do not change it
(pre-integrated classification is the exact integral it computes anyway).  It renders any
field (:mod:`dvr_gl.fields`).  See ``dvr_gl/renderers/reference_converged/README.md``.
"""

from __future__ import annotations

from ...reference.fields import ROLES
from ...scene import settings as s
from ...scene.plugin import RendererPlugin

CONVERGED_TOLERANCE = s.Setting("converged_tolerance", float, 1e-4, "error budget per pixel",
                                check=s.positive, group="reference-converged")

PLUGIN = RendererPlugin(
    name="reference-converged",
    description="CPU float64, exact transfer function, integrated to a tolerance",
    renderer="dvr_gl.renderers.reference_converged.renderer:ConvergedReferenceRenderer",
    order=60,
    settings=(s.COMPOSITING, s.CLASSIFICATION, s.ASSOCIATED_COLORS, s.FILTER, s.KERNEL_WIDTH, s.KERNEL_RADIUS,
              s.GRADIENT_OPACITY, s.GRADIENT_OPACITY_REFERENCE, s.ISO_VALUE, s.JITTER, s.SHADING, s.SCATTERING,
              s.CLIPPING, s.GEOMETRY, s.DEPTH_CUE, s.HEMISPHERICAL_SHADING, CONVERGED_TOLERANCE),
    data_kinds=None,
    reference=True,
    # several fields: the members' models mixed per sample (dvr_gl/reference/fields.py), which refuses in one
    # line what the mixture does not define (a projection of a label, scattering through the mixture)
    field_roles=ROLES,
    transfer_function_2d=("grid", "fields"),
    check="dvr_gl.reference.fields:check",
    # Against the closed forms (tests/closed_forms.py), at converged_tolerance 1e-6: measured 5e-8; two
    # channels (several fields, every mode): 3e-8.
    tolerances={"box": 1e-6, "ramp": 1e-6, "sphere": 1e-6, "analytic sphere": 1e-6, "mesh boxes": 1e-6,
                "mesh ramp": 1e-6, "two channels": 1e-6},
)
