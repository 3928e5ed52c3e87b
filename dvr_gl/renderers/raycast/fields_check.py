"""What the ray caster refuses of a scene of several fields (:class:`~dvr_gl.fields.layers.FieldSet`), in
one line each with what to do (the plugin's ``check``): see :mod:`.fields` for what it renders."""

from __future__ import annotations

import math

from ...errors import SceneError
from ...fields import diagonal
from ...transfer_function_2d import is_2d

# One pass of the fragment loop: llvmpipe stops a shader's loops after 65535 iterations (renderer.PASS_SEGMENTS).
ONE_PASS_SEGMENTS = 65000


def check(scene):
    """Raise SceneError where the ray caster cannot render this scene of several fields (nothing to say for
    one field)."""
    field = scene.field
    if getattr(field, "kind", None) != "fields":
        return
    r = scene.renderer
    for layer in scene.layers:
        if layer.role != "scalar" and is_2d(layer.transfer_function):
            raise SceneError(f"{layer.name or layer.field.name}: "
                             + ("a label field is classified by its label table" if layer.role == "label"
                                else "an rgb field is classified by its data's colour and a 1D transfer function "
                                     "of its luminance")
                             + ", not by a 2D transfer function of value and gradient magnitude: give it "
                             + ("a label table" if layer.role == "label" else "a 1D transfer function"))
    roles = {m.role for m in field.members} - {"scalar"}
    if roles and r.compositing in ("mip", "minip", "average"):
        role = sorted(roles)[0]
        raise SceneError(f"renderer.compositing = {r.compositing!r} projects each field's values, and "
                         f"{'an' if role == 'rgb' else 'a'} {role} field has none to project: use "
                         f"emission_absorption, xray or isosurface")
    if r.classification == "pre" and r.compositing == "emission_absorption":
        raise SceneError("renderer.classification = 'pre' classifies one field's voxels; several fields are "
                         "classified per sample: use 'post' or 'preintegrated'")
    if r.scattering.enabled and r.compositing == "emission_absorption":
        raise SceneError("renderer.scattering takes one field's extinction; several fields render without it: "
                         "turn renderer.scattering off")
    budget = r.texture_budget_mb * 2 ** 20
    if field.nbytes > budget:
        raise SceneError(f"several fields are drawn from whole textures (no bricks), and {field.name} takes "
                         f"{field.nbytes / 2 ** 20:.3g} MB, over renderer.texture_budget_mb = "
                         f"{r.texture_budget_mb:g}: raise it, or render the fields apart")
    if math.ceil(diagonal(field) / r.sample_distance) > ONE_PASS_SEGMENTS - r.iso_refinement:
        raise SceneError(f"several fields are composited in one pass of at most {ONE_PASS_SEGMENTS} segments a "
                         f"ray, and renderer.sample_distance = {r.sample_distance:g} takes more across "
                         f"{field.name}: raise it")
