"""The ray caster on several fields (a :class:`~dvr_gl.fields.layers.FieldSet`): one pass of the fragment
loop over the union of the members' boxes, every member sampled in its own grid and classified by its own
transfer function at every sample, mixed per the contract (``dvr_gl/gl/shaders/common/fields.glsl``:
extinctions add, emissions add; pre-integration per member; per-channel projections; the first isosurface
of any member).  Members on one grid travel four to a texture (:mod:`..grid.field_textures`).

What a frame of several fields does not do (refused in one line by :func:`.fields_check.check`): bricking
(the members' textures must fit the texture budget and the GL limit whole), rays longer than one pass,
pre-classified voxels, scattering.
"""

from __future__ import annotations

import dataclasses
from time import perf_counter as now

from ...fields import gradient_epsilon
from ...gl.shaders import create_program
from ..grid.field_textures import preintegration_atlas, table_atlas, upload_fields

# Defines a frame of several fields never has: one field's classification paths (fields.glsl takes central
# differences in each member's grid; pre-classified voxels and scattering are refused) and the block skipping
# of one field's blocks.
NOT_FOR_FIELDS = ("GRADIENT_TEXTURE", "CLASSIFY_PRE", "ASSOCIATED_COLORS")


def fields_features(scene, shader_features) -> dict:
    """The defines of a frame of several fields: the single-field ones of the same settings (``shader_features``
    of the scene with acceleration off) without :data:`NOT_FOR_FIELDS`, with the fields' own."""
    off = dataclasses.replace(scene, renderer=dataclasses.replace(scene.renderer, acceleration="off"))
    defines = {k: v for k, v in shader_features(off).items() if k not in NOT_FOR_FIELDS}
    return defines


def field_textures(frame, scene, defines: dict) -> dict:
    """The frame's textures of several fields, kept in ``frame``'s cache: the members' group textures, their
    table atlas and (CLASSIFY_PREINTEGRATED) pre-integration atlas."""
    r, fieldset = scene.renderer, scene.field
    tfs = tuple(layer.transfer_function for layer in scene.layers)
    fields = frame._cached("field textures", (fieldset,), lambda: upload_fields(frame.ctx, fieldset))
    out = {"u_field_lut": frame._cached("field lut", (tfs, r.lut_size),
                                                               lambda: table_atlas(frame.ctx, tfs, r.lut_size))}
    if "CLASSIFY_PREINTEGRATED" in defines:
        out["u_field_preint"] = frame._cached(
            "field preintegration", (tfs, r.sample_distance, r.preintegration_size, r.preintegration, r.lut_size),
            lambda: preintegration_atlas(frame.ctx, tfs, r.sample_distance, r.preintegration_size,
                                         r.preintegration, r.lut_size))
    return out, fields


def epsilon_scales(scene) -> list:
    """Per member: the scene's gradient epsilon (the first member's) over the member's own
    (:func:`dvr_gl.fields.gradient_epsilon`), by which fields.glsl scales its gradient for shading."""
    first = gradient_epsilon(scene.field)
    return [first / gradient_epsilon(layer.field) for layer in scene.layers]


def draw_fields(renderer, scene, surfaces: dict, shader_features):
    """The frame of a scene of several fields (``renderer``: the :class:`.renderer.RayCastRenderer`;
    ``surfaces``: the geometry layer's texture, if any)."""
    start = now()
    defines = fields_features(scene, shader_features)
    textures, fields = field_textures(renderer, scene, defines)
    defines.update(fields.defines())
    program = create_program(renderer.ctx, "fullscreen.vert", renderer.fragment_shader, defines,
                             roots=renderer.shaders)
    lut = textures["u_field_lut"].luts[0]
    uniforms = {**renderer.ray_uniforms(scene), **renderer.optics_uniforms(scene, lut), **fields.uniforms(),
                "u_field_iso": [float(layer.iso_value) for layer in scene.layers],
                "u_field_epsilon_scale": epsilon_scales(scene)}
    textures = {**textures, **surfaces}
    renderer.bind(program, uniforms, textures)
    fields.bind(program, len(textures))
    width, height = scene.image.width, scene.image.height
    _, fbo = renderer.target("main", width, height)
    gpu_seconds = renderer._draw(program, fbo, width, height, renderer.bands(scene))
    image = renderer.read(fbo, width, height)
    renderer.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines, "bricks": 1,
                      "accelerated": False, "field_textures": len(fields.groups)}
    return image
