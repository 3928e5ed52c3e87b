"""``slicing3d`` on several fields (:class:`~dvr_gl.fields.layers.FieldSet`, docs/several-fields.md).

The view-aligned slices span the union of the fields' boxes; at each slice's fragment every field is sampled
in its own 3D texture (fields on one grid travel together, up to four channels a texture:
:mod:`dvr_gl.renderers.grid.field_textures`), classified by its own transfer function, shaded by its own
gradient, and mixed (extinctions add, emissions add; a field contributes only inside its box,
``common/fields.glsl``); the slabs are blended back to front with the over operator, as for one field.
Pre-integrated classification mixes the fields' own tables by the contract's rule.  A label member is
classified by the label rule (``common/labels.glsl``) and its colour table, an rgb member by the data's colour
and its transfer function of ``x``, as in the ray caster (the same GLSL, the same tables:
:func:`~dvr_gl.renderers.grid.field_textures.frame_field_textures`).  A field with its own direction matrix is
sampled in its own frame the same way (``FIELDS_ORIENTED``), the slices spanning the union's bounding box.

What the mixture cannot take here is refused in one line (:func:`check`): pre-classified voxels, scattering
(half-angle slicing and the light volume march one field), and fields whose textures exceed the texture budget
(several fields are not bricked).
"""

from __future__ import annotations

from time import perf_counter as now

import numpy as np

from ... import limits
from ...errors import SceneError
from ...gl.shaders import create_program
from ..grid.classification import classification_features
from ..grid.field_textures import epsilon_scales, frame_field_textures
from ..grid.slicing import SHADERS


def several(scene) -> bool:
    return getattr(scene.field, "kind", None) == "fields"


def check(scene):
    """Refuse, in one line, a scene of several fields the slicer does not mix (see the module doc)."""
    if not several(scene):
        return
    r = scene.renderer
    if r.classification == "pre":
        raise SceneError("slicing3d classifies several fields per sample (each by its own transfer function, then "
                         "mixed), not per voxel: set renderer.classification to post or preintegrated")
    if r.scattering.enabled:
        raise SceneError("slicing3d lights one field by scattering, not a mixture of several: set "
                         "renderer.scattering.enabled = false, or render one field")
    budget = r.texture_budget_mb * 2 ** 20
    if scene.field.nbytes > budget:
        raise SceneError(f"{scene.field.name}: several fields are drawn from whole textures, "
                         f"{scene.field.nbytes / 2 ** 20:.1f} MB, over renderer.texture_budget_mb = "
                         f"{r.texture_budget_mb:g}: raise it, or render fewer fields")


# One field's paths a frame of several never takes: gradients come from central differences in each field's
# grid (a gradient texture holds the same values: the filters are linear in the samples), and pre-classified
# voxels are refused (:func:`check`).
NOT_FOR_FIELDS = ("GRADIENT_TEXTURE", "CLASSIFY_PRE", "ASSOCIATED_COLORS")


def fields_defines(scene) -> dict:
    """The single field's classification features (filter, shading, gradient opacity, clipping, geometry) but
    :data:`NOT_FOR_FIELDS`: what the fields' program takes beside the fields' own (:meth:`FieldTextures.defines`)."""
    return {k: v for k, v in classification_features(scene).items() if k not in NOT_FOR_FIELDS}


def draw_fields(renderer, scene, surfaces: dict) -> np.ndarray:
    """The frame of several fields (``renderer``: a :class:`~dvr_gl.renderers.slicing3d.renderer.Slicing3DRenderer`;
    ``surfaces``: the meshes' layer, :mod:`dvr_gl.renderers.surfaces`)."""
    renderer.activate()
    start = now()
    ctx = renderer.ctx
    side = limits.gl_limits(ctx).texture_3d_size
    for m in scene.field.members:
        if max(m.field.dims) > side:
            raise SceneError(f"{m.name}: {max(m.field.dims)} voxels along an axis, more than this GL's 3D textures "
                             f"hold ({side}); several fields are not bricked: resample it or render it alone")
    defines = fields_defines(scene)
    tables, textures = frame_field_textures(renderer, scene, defines, renderer.slab_length(scene))
    defines.update(textures.defines())
    program = create_program(ctx, "slice.vert", "slice.frag", defines, roots=SHADERS)
    uniforms = {**renderer.camera_uniforms(scene), **renderer.optics_uniforms(scene, tables["u_field_lut"].luts[0]),
                **renderer.view_uniforms(scene), **textures.uniforms(),
                "u_field_epsilon_scale": epsilon_scales(scene)}
    tris = renderer.geometry(scene, _WHOLE)
    passes = [(uniforms, {**tables, **surfaces}, tris)] if len(tris) else []
    image, gpu_seconds, triangles = renderer.blend_passes(scene, program, passes, bind_more=textures.bind)
    renderer.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines, "bricks": 1,
                      "triangles": triangles, "light_volume_seconds": 0.0, "field_textures": len(textures.groups)}
    return image


class _Whole:
    """The grid view of the whole union box (several fields are not bricked)."""

    brick = None


_WHOLE = _Whole()
