"""The ray caster on several fields (a :class:`~dvr_gl.fields.layers.FieldSet`): one pass of the fragment
loop over the union of the members' boxes, every member sampled in its own grid and classified by its own
transfer function at every sample, mixed per the contract (``dvr_gl/gl/shaders/common/fields.glsl``:
extinctions add, emissions add; pre-integration per member; per-channel projections; the first isosurface
of any member; a member's 2D transfer function of value and gradient magnitude, :class:`Tables2D`).  Members
on one grid travel four to a texture (:mod:`..grid.field_textures`).  A member with its own direction matrix
is sampled, box-tested and differentiated in its own frame through ``FIELDS_ORIENTED`` (its gradient turned
back to the shared frame, :mod:`dvr_gl.fields.layers`); such a frame's rays span the union box (no ray bounds).

What a frame of several fields does not do (refused in one line by :func:`.fields_check.check`): bricking
(the members' textures must fit the texture budget and the GL limit whole), rays longer than one pass,
pre-classified voxels, scattering.
"""

from __future__ import annotations

import dataclasses
from time import perf_counter as now

import moderngl
import numpy as np

from ... import limits
from ...errors import SceneError
from ...gl.shaders import create_program
from ...transfer_function_2d import is_2d
from ..grid.field_textures import epsilon_scales, fieldset_defines, frame_field_textures
from . import acceleration as accel
from . import ray_bounds

# A label member's isosurface: its visibility (0 or 1) reaching one half (as dvr_gl.reference.fields has it).
LABEL_ISO = 0.5

# "auto" bounds the rays of several fields by their members' non-empty blocks (the ray bounds of one field,
# .ray_bounds) where at least this fraction of the blocks, every member's counted, is empty: drawing the faces
# costs a few ms at 512x512 (renderer.AUTO_BOUNDS_COST), which a fifth of the samples left out repays.
AUTO_EMPTY_FRACTION = 0.2

# Defines a frame of several fields never has: one field's classification paths (fields.glsl takes central
# differences in each member's grid; pre-classified voxels and scattering are refused) and the block skipping
# of one field's blocks.
NOT_FOR_FIELDS = ("GRADIENT_TEXTURE", "CLASSIFY_PRE", "ASSOCIATED_COLORS")


def fields_features(scene, shader_features) -> dict:
    """The defines of a frame of several fields before its textures' (:meth:`FieldTextures.defines`) and the
    ray bounds: the single-field ones of the same settings (``shader_features`` of the scene with acceleration
    off) without :data:`NOT_FOR_FIELDS`."""
    off = dataclasses.replace(scene, renderer=dataclasses.replace(scene.renderer, acceleration="off"))
    defines = {k: v for k, v in shader_features(off).items() if k not in NOT_FOR_FIELDS}
    return {**defines, **tables_2d_defines(scene.layers)}


def tables_2d_defines(layers) -> dict:
    """``FIELD_TABLES_2D`` and ``FIELD_TABLE_2D_OF`` (per member 1 where its transfer function is 2D, else 0: a
    constant list, so a member's lookup compiles out where it has none) where some member's is; else none."""
    flags = [int(is_2d(layer.transfer_function)) for layer in layers]
    if not any(flags):
        return {}
    return {"FIELD_TABLES_2D": True, "FIELD_TABLE_2D_OF": ", ".join(str(f) for f in flags)}


class Tables2D:
    """The members' 2D transfer functions (:meth:`~dvr_gl.transfer_function_2d.TransferFunction2D.tabulate_2d`,
    ``NV_i x NG_i`` texels of ``(r, g, b, sigma)``) in one RGBA32F texture (fetched, not filtered), stacked along
    y: member ``i``'s texel ``(v, g)`` at column ``v``, row ``row_i + g``.  A member with a 1D function has no
    rows (its uniforms are never read: ``FIELD_TABLE_2D_OF``)."""

    def __init__(self, ctx, transfer_functions):
        self.tables = [tf.tabulate_2d() if is_2d(tf) else None for tf in transfer_functions]
        blocks = [t.texels() for t in self.tables if t is not None]  # (NG, NV, 4) each
        width = max(b.shape[1] for b in blocks)
        data = np.concatenate([np.pad(b, ((0, 0), (0, width - b.shape[1]), (0, 0))) for b in blocks])
        self.texture = ctx.texture((width, len(data)), 4, np.ascontiguousarray(data, np.float32).tobytes(),
                                   dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False

    def uniforms(self) -> dict:
        """Per member (vec2 arrays): its block's first texel (``u_field_tf2d_origin``, column and row) and size
        (``u_field_tf2d_size``, NV and NG), the value and gradient magnitude of its first texel
        (``u_field_tf2d_lo``) and texels per unit along each (``u_field_tf2d_scale``); zeros for a 1D member."""
        out = {"origin": [], "size": [], "lo": [], "scale": []}
        row = 0
        for t in self.tables:
            if t is None:
                for key in out:
                    out[key] += [0.0, 0.0]
                continue
            u = t.uniforms()
            out["origin"] += [0.0, float(row)]
            out["size"] += [float(n) for n in u["u_tf2d_size"]]
            out["lo"] += [float(x) for x in u["u_tf2d_lo"]]
            out["scale"] += [float(x) for x in u["u_tf2d_scale"]]
            row += int(u["u_tf2d_size"][1])
        return {f"u_field_tf2d_{key}": value for key, value in out.items()}


def frame_features(scene, shader_features, bounded: bool) -> dict:
    """Every define a frame of several fields may have, without uploading anything (the shader-variant
    tests): :func:`fields_features`, the fields' own, and RAY_BOUNDS where ``bounded`` (emission and X-ray)."""
    defines = {**fields_features(scene, shader_features), **fieldset_defines(scene.field)}
    if bounded and "COMPOSITE_EMISSION" in defines:
        defines["RAY_BOUNDS"] = True
    return defines


def member_occupancy(frame, scene, i: int, lut, snap) -> np.ndarray:
    """Member ``i``'s non-empty level-0 blocks ``(nbz, nby, nbx)`` under its table ``lut`` (``snap``: the
    pre-integration table's (domain, nodes), as one field's blocks take them), its pyramid kept in ``frame``."""
    r, layer = scene.renderer, scene.layers[i]
    volume = layer.field
    label = layer.role == "label"
    support = (0, 1) if label else accel.SUPPORT[r.filter]  # a label's sample reads its 8 taps alone
    # an rgb member's extinction is its x's (the fourth component)
    values = (lambda: volume.data[..., 3]) if layer.role == "rgb" else (lambda: volume.data)
    pyramid = frame._cached(f"field pyramid {i}", (volume, support, r.block_size),
                            lambda: accel.MinMaxPyramid.build(values(), r.block_size, support))
    if label:  # empty where no label between the block's least and greatest has opacity
        table = layer.transfer_function
        return frame._cached(f"field occupancy {i}", (pyramid, table), lambda: np.asarray(
            table.opaque_somewhere(*pyramid.levels[0]), dtype=bool))
    return frame._cached(f"field occupancy {i}", (pyramid, lut, r.filter, snap), lambda: ray_bounds.occupied(
        accel.table_classes(pyramid, lut, r.filter, volume.spacing, 0.0, False, snap)[0]))


def bound_rays(renderer, scene, defines: dict, textures: dict) -> tuple[dict, dict]:
    """Emission-absorption and the X-ray: the rays bounded by the union of every member's non-empty blocks
    (a block is empty where its member's extinction is zero for every value the filter can make there; the
    faces of every member's blocks, each on its own grid, drawn into one MIN-blended target: the first entry
    into and the last exit from any member's non-empty blocks).  Where ``renderer.acceleration`` is "on", or
    "auto" finds :data:`AUTO_EMPTY_FRACTION` of the blocks empty.  Not where a member is oriented (its direction
    differs from the first's, :mod:`dvr_gl.fields.layers`): its blocks are not axis-aligned in the shared frame,
    and the rays span the union box (every sample taken).  The defines and textures to add."""
    r = scene.renderer
    mode = {True: "on", False: "off"}.get(r.acceleration, r.acceleration) if isinstance(r.acceleration, bool) \
        else r.acceleration
    if "COMPOSITE_EMISSION" not in defines or mode == "off" or scene.field.oriented:
        return defines, {}  # an oriented member's blocks are not axis-aligned here: the rays span the union box
    preint = textures.get("u_field_preint")
    occupancy = []
    for i, layer in enumerate(scene.layers):
        table = preint.tables[i] if preint is not None else None
        lut = table.source if table is not None else textures["u_field_lut"].luts[i]
        snap = (table.domain, table.size) if table is not None else None
        occupancy.append(member_occupancy(renderer, scene, i, lut, snap))
    empty = sum(int((~occ).sum()) for occ in occupancy)
    total = sum(occ.size for occ in occupancy)
    if empty == 0 or (mode == "auto" and empty < AUTO_EMPTY_FRACTION * total) or \
            any(min(layer.field.dims) < 2 for layer in scene.layers):  # a flat box's faces are seen edge on
        return defines, {}
    faces = renderer._cached("field ray bounds faces", tuple(occupancy), lambda: _faces(renderer, scene, occupancy))
    planes = faces.clip_depths(scene.camera)
    if planes is None:
        return defines, {}
    return {**defines, "RAY_BOUNDS": True}, {"u_ray_bounds": renderer.draw_ray_bounds(scene, faces, planes, defines)}


def _faces(renderer, scene, occupancy) -> ray_bounds.BoundsFaces:
    """Every member's non-empty blocks' faces and boxes, on its own grid, in one vertex buffer."""
    bs = scene.renderer.block_size
    rows, los, his = [], [], []
    for occ, layer in zip(occupancy, scene.layers):
        v = layer.field
        rows.append(ray_bounds.boundary_faces(occ, bs, v.dims, v.spacing, v.origin))
        lo, hi = ray_bounds.block_boxes(occ, bs, v.dims, v.spacing, v.origin)
        los.append(lo)
        his.append(hi)
    return ray_bounds.BoundsFaces.of(renderer.ctx, np.concatenate(rows), (np.concatenate(los), np.concatenate(his)),
                          scene.field.box)


def draw_fields(renderer, scene, surfaces: dict, shader_features):
    """The frame of a scene of several fields (``renderer``: the :class:`.renderer.RayCastRenderer`;
    ``surfaces``: the geometry layer's texture, if any)."""
    start = now()
    side = limits.gl_limits(renderer.ctx).texture_3d_size
    for layer in scene.layers:
        if max(layer.field.dims) > side:
            raise SceneError(f"{layer.name or layer.field.name}: {max(layer.field.dims)} voxels along an axis, more "
                             f"than this GL's 3D textures hold ({side}); several fields are not bricked: resample "
                             f"it or render it alone")
    defines = fields_features(scene, shader_features)
    textures, fields = frame_field_textures(renderer, scene, defines, scene.renderer.sample_distance)
    if "FIELD_TABLES_2D" in defines:  # uploaded only where a member classifies by value and gradient magnitude
        tfs = tuple(layer.transfer_function for layer in scene.layers)
        textures["u_field_tf2d"] = renderer._cached("field tables 2d", tfs, lambda: Tables2D(renderer.ctx, tfs))
    defines.update(fields.defines())
    defines, bounds = bound_rays(renderer, scene, defines, textures)
    program = create_program(renderer.ctx, "fullscreen.vert", renderer.fragment_shader, defines,
                             roots=renderer.shaders)
    lut = textures["u_field_lut"].luts[0]
    uniforms = {**renderer.ray_uniforms(scene), **renderer.optics_uniforms(scene, lut), **fields.uniforms(),
                "u_field_iso": [LABEL_ISO if layer.role == "label" else float(layer.iso_value)
                                for layer in scene.layers],
                "u_field_epsilon_scale": epsilon_scales(scene)}
    textures = {**textures, **surfaces, **bounds}
    renderer.bind(program, uniforms, textures)
    fields.bind(program, len(textures))
    width, height = scene.image.width, scene.image.height
    _, fbo = renderer.target("main", width, height)
    # every mode's empty state here is zero, which a ray that misses the union box writes (box_rectangle)
    rect = ray_bounds.box_rectangle(scene, defines=defines)
    gpu_seconds = renderer._draw(program, fbo, width, height, renderer.bands(scene), rect)
    image = renderer.read(fbo, width, height)
    renderer.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines, "bricks": 1,
                      "accelerated": False, "ray_bounds": "RAY_BOUNDS" in defines,
                      "field_textures": len(fields.groups)}
    return image
