"""Several fields (:class:`~dvr_gl.fields.layers.FieldSet`) as textures, for the grid renderers' shaders
(``dvr_gl/gl/shaders/common/fields.glsl``).

* :func:`upload_fields`: one 3D texture per group of :meth:`FieldSet.groups` (members on the same grid, of
  the same dtype, up to four: channels R, RG, RGB, RGBA; an RGB member alone, RGBA), each in the members'
  own precision (:mod:`.textures`: uint8 as half float, uint16 and int16 as unorm16, float32 as float32) with
  its own world-to-voxel transform, dims and box.  Member ``i`` is channel :attr:`FieldTextures.channel`
  ``[i]`` of texture :attr:`FieldTextures.group` ``[i]``; its data value is ``texel * scale + offset``.
* :func:`table_atlas`: the members' transfer-function tables, one row each (N x members, RGBA32F), with each
  row's value domain and unit distance; :func:`preintegration_atlas`: their pre-integration tables stacked
  (N x N per member, member ``i`` in rows ``i N`` to ``(i + 1) N - 1``).

What the shaders read: :meth:`FieldTextures.bind` (the sampler array ``u_field_group``),
:meth:`FieldTextures.uniforms` and :meth:`FieldTextures.defines`; the atlases' own ``uniforms()``.
World coordinates are the shared frame's (the first member's own frame, :mod:`dvr_gl.fields.layers`), in
world units.  A group whose direction differs from the first member's (its members share a grid, so one map)
carries its rigid map ``q = A p + b`` into its own frame (:attr:`FieldGroup.turn`); its scale, offset and box
are its own frame's, and the shaders read it through ``FIELDS_ORIENTED`` (``u_field_turn``, ``u_field_shift``).
Every per-member uniform is a float array indexed by member; per group, vec3 arrays indexed by group.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ...errors import SceneError
from ...fields import gradient_epsilon
from ...preintegration import preintegrate
from ...transfer_function import TransferFunction
from .textures import FORMATS, texels

#: How far (voxels) a member's box faces on the union box's are moved out (:meth:`FieldTextures._boxes`): far
#: below a sample's spacing, far above float32 rounding.
BOX_MARGIN = 1e-4

#: A member's role in the shaders' FIELD_ROLE_OF.
ROLE_CODES = {"scalar": 0, "label": 1, "rgb": 2}

#: Textures of one FieldSet a shader samples at most (GL guarantees 16 units a fragment shader; the tables,
#: block textures and targets take others).
MAX_GROUPS = 6


@dataclass
class FieldGroup:
    """One texture of several fields on one grid: ``members`` (indices) in channel order."""

    members: tuple
    texture: moderngl.Texture3D
    dims: tuple            # (nx, ny, nz) voxels
    scale: np.ndarray      # voxel = world * scale + offset (voxel i at its centre, i)
    offset: np.ndarray
    spacing: np.ndarray    # world units per voxel along x, y, z
    box: tuple             # (lo, hi) world units: where its members contribute (closed), its own frame
    nbytes: int
    turn: tuple | None = None  # (A, b): shared frame -> its own frame, q = A p + b; None: the identity
    shared_box: tuple | None = None  # its box's bounding box in the shared frame (the box where turn is None)


class FieldTextures:
    """A FieldSet's textures (:func:`upload_fields`): ``groups``, and per member ``group`` and ``channel``,
    ``value_scale`` and ``value_offset`` (data value = texel * scale + offset)."""

    def __init__(self, groups: list, group: tuple, channel: tuple, value_scale: tuple, value_offset: tuple,
                 roles: tuple = ()):
        self.groups, self.group, self.channel = groups, group, channel
        self.value_scale, self.value_offset = value_scale, value_offset
        self.roles = roles or ("scalar",) * len(group)

    @property
    def nbytes(self) -> int:
        return sum(g.nbytes for g in self.groups)

    def defines(self) -> dict:
        """:func:`field_defines` of these textures."""
        oriented = any(g.turn is not None for g in self.groups)
        out = field_defines(self.group, self.channel, self.roles,
                            not oriented and _same_boxes([g.box for g in self.groups]))
        return {**out, "FIELDS_ORIENTED": True} if oriented else out

    def _boxes(self) -> dict:
        """``u_field_box_lo``, ``u_field_box_hi``: each group's box, its faces on the union box's moved out by
        :data:`BOX_MARGIN` voxels.  A ray's entry and exit points lie on the union box's faces in float64 and
        on either side of them in float32: a member whose box shares the face must count them in, as the
        reference does (closed boxes); faces inside the union are tested exactly.  An oriented group's box (its
        own frame) has every face moved out: which of its faces lie on the union's is not tested (a sample
        within 1e-4 voxel outside an inner face counts in, where the reference's does not)."""
        lo = np.array([g.box[0] for g in self.groups])
        hi = np.array([g.box[1] for g in self.groups])
        margin = BOX_MARGIN * np.array([g.spacing for g in self.groups])
        turned = np.array([g.turn is not None for g in self.groups])[:, None]
        union_lo = np.array([g.box[0] if g.shared_box is None else g.shared_box[0] for g in self.groups]).min(axis=0)
        union_hi = np.array([g.box[1] if g.shared_box is None else g.shared_box[1] for g in self.groups]).max(axis=0)
        lo = np.where(turned | (lo <= union_lo), lo - margin, lo)
        hi = np.where(turned | (hi >= union_hi), hi + margin, hi)
        return {"u_field_box_lo": [float(x) for x in lo.ravel()], "u_field_box_hi": [float(x) for x in hi.ravel()]}

    def bind(self, program, first_unit: int) -> int:
        """Bind the group textures to units ``first_unit``, ``first_unit + 1``, ... and the sampler array
        ``u_field_group`` to them (after :meth:`dvr_gl.gl.frame.GLFrame.bind` of the frame's other textures,
        which took the units below ``first_unit``); returns the next free unit."""
        units = list(range(first_unit, first_unit + len(self.groups)))
        for unit, group in zip(units, self.groups):
            group.texture.use(location=unit)
        if "u_field_group" in program:  # a sampler array: ints, which set_uniform's lists are not
            program["u_field_group"].write(np.asarray(units, dtype=np.int32).tobytes())
        return first_unit + len(self.groups)

    def uniforms(self) -> dict:
        """Per group (vec3 arrays): world to voxel (``u_field_scale``, ``u_field_offset``), dims as floats
        (``u_field_dims``), spacing and box; per member (float arrays): ``u_field_value_scale``,
        ``u_field_value_offset``."""
        def vec3s(name):
            return [float(x) for g in self.groups for x in np.asarray(getattr(g, name), dtype=np.float64)]

        out = {"u_field_scale": vec3s("scale"), "u_field_offset": vec3s("offset"),
               "u_field_dims": [float(x) for g in self.groups for x in g.dims],
               "u_field_spacing": vec3s("spacing"),
               **self._boxes(),
               "u_field_value_scale": list(self.value_scale), "u_field_value_offset": list(self.value_offset)}
        if any(g.turn is not None for g in self.groups):  # FIELDS_ORIENTED: mat3s column-major, A's columns
            turns = [(np.eye(3), np.zeros(3)) if g.turn is None else g.turn for g in self.groups]
            out["u_field_turn"] = [float(x) for a, _ in turns for x in np.asarray(a, np.float64).T.ravel()]
            out["u_field_shift"] = [float(x) for _, b in turns for x in np.asarray(b, np.float64)]
        return out

    def release(self):
        for g in self.groups:
            g.texture.release()


def _same_boxes(boxes) -> bool:
    lo0, hi0 = boxes[0]
    scale = float(np.max(np.abs(np.subtract(hi0, lo0)))) or 1.0
    return all(np.allclose(lo, lo0, rtol=0, atol=1e-9 * scale) and np.allclose(hi, hi0, rtol=0, atol=1e-9 * scale)
               for lo, hi in boxes)


def field_defines(group, channel, roles, share_box: bool = False) -> dict:
    """``FIELDS``, ``NUM_FIELDS`` (members), ``NUM_FIELD_GROUPS`` (textures) and the members' texture,
    channel and role (:data:`ROLE_CODES`) as constant lists (``FIELD_GROUP_OF``, ``FIELD_CHANNEL_OF``,
    ``FIELD_ROLE_OF``: compile-time, so samplers are indexed by constants as GLSL 3.30 requires), and
    ``FIELD_EACH(M)``, the members' loop written out (``M(0) M(1) ...``: common/fields.glsl); with
    ``FIELD_LABELS`` and ``FIELD_RGB`` where a member has that role.  An rgb member's channel is 3, its
    ``x`` (the value its transfer function reads); its colour is the texture's r, g, b.  ``FIELDS_SHARE_BOX``
    where every group's box is the same (channels of one file): the samples, in the union box, are in every
    member's, and the shaders test no box."""
    out = {"FIELDS": True, "NUM_FIELDS": len(group), "NUM_FIELD_GROUPS": max(group) + 1,
           "FIELD_GROUP_OF": ", ".join(str(g) for g in group),
           "FIELD_CHANNEL_OF": ", ".join(str(c) for c in channel),
           "FIELD_ROLE_OF": ", ".join(str(ROLE_CODES[r]) for r in roles),
           "FIELD_EACH(M)": " ".join(f"M({i})" for i in range(len(group)))}
    if "label" in roles:
        out["FIELD_LABELS"] = True
    if "rgb" in roles:
        out["FIELD_RGB"] = True
    if share_box:
        out["FIELDS_SHARE_BOX"] = True
    return out


def fieldset_defines(fieldset, per_texture: int = 4) -> dict:
    """:func:`field_defines` of a FieldSet as :func:`upload_fields` would upload it (nothing uploaded)."""
    group, channel = [0] * len(fieldset), [0] * len(fieldset)
    for g, indices in enumerate(fieldset.groups(per_texture)):
        for c, i in enumerate(indices):
            group[i], channel[i] = g, 3 if fieldset.members[i].role == "rgb" else c
    oriented = any(t is not None for t in getattr(fieldset, "transforms", ()))
    out = field_defines(group, channel, [m.role for m in fieldset.members],
                        not oriented and _same_boxes([tuple(np.asarray(b, dtype=np.float64) for b in m.field.box)
                                                      for m in fieldset.members]))
    return {**out, "FIELDS_ORIENTED": True} if oriented else out


def upload_fields(ctx, fieldset, per_texture: int = 4) -> FieldTextures:
    """The FieldSet's members as textures, grouped by :meth:`FieldSet.groups` (``per_texture`` channels at
    most; an RGB member is one RGBA texture of its own: :mod:`dvr_gl.fields.color`)."""
    groups = fieldset.groups(per_texture)
    if len(groups) > MAX_GROUPS:
        raise SceneError(f"{len(fieldset)} fields travel in {len(groups)} textures, more than the {MAX_GROUPS} a "
                         f"frame samples; put fields on a shared grid (channels of one array travel four to a "
                         f"texture) or render fewer")
    n = len(fieldset.members)
    group, channel = [0] * n, [0] * n
    scale, offset = [1.0] * n, [0.0] * n
    out = []
    for g, indices in enumerate(groups):
        fields = [fieldset.members[i].field for i in indices]
        texture, nbytes, value_scale, value_offset = _group_texture(ctx, fields)
        for c, i in enumerate(indices):
            rgb = fieldset.members[i].role == "rgb"
            group[i], channel[i], scale[i], offset[i] = g, 3 if rgb else c, value_scale, value_offset
        first = fields[0]
        spacing = np.asarray(first.spacing, dtype=np.float64)
        lo, hi = first.box
        turn = fieldset.transforms[indices[0]] if hasattr(fieldset, "transforms") else None
        out.append(FieldGroup(tuple(indices), texture, tuple(int(x) for x in first.dims), 1.0 / spacing,
                              -np.asarray(first.origin, dtype=np.float64) / spacing, spacing,
                              (np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)), nbytes,
                              turn, None if turn is None else fieldset.member_bounds(indices[0])))
    return FieldTextures(out, tuple(group), tuple(channel), tuple(scale), tuple(offset),
                         tuple(m.role for m in fieldset.members))


def _group_texture(ctx, fields: list):
    """One texture of ``fields`` (same grid and dtype) as channels, and (nbytes, value scale, offset).
    A colour volume (4 components, ``data`` of shape (nz, ny, nx, 4)) is one RGBA32F texture."""
    data = [np.asarray(f.data) for f in fields]
    if data[0].ndim == 4:  # a colour volume: linear components, already float (dvr_gl.fields.color)
        stacked = np.ascontiguousarray(data[0], dtype=np.float32)
        return _texture(ctx, stacked, stacked.shape[3], "f4"), stacked.nbytes, 1.0, 0.0
    dtype = data[0].dtype
    if dtype not in FORMATS:
        raise SceneError(f"{fields[0].name}: data type {dtype} has no texture format; convert it to uint8, uint16, "
                         f"int16 or float32")
    kind, value_scale, value_offset, size = FORMATS[dtype]
    stacked = np.ascontiguousarray(texels(np.stack(data, axis=-1) if len(data) > 1 else data[0][..., None]))
    return _texture(ctx, stacked, stacked.shape[3], kind), stacked.size * size, value_scale, value_offset


def _texture(ctx, data: np.ndarray, components: int, kind: str) -> moderngl.Texture3D:
    nz, ny, nx = data.shape[:3]
    tex = ctx.texture3d((nx, ny, nz), components, data, dtype=kind)
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = tex.repeat_z = False
    return tex


class TableAtlas:
    """The members' transfer-function tables (``luts``: :meth:`TransferFunction.tabulate` of each), one row
    of N texels each (RGBA32F, fetched, not filtered): ``(r, g, b, sigma)`` at N evenly spaced values of the
    row's domain."""

    def __init__(self, ctx, luts: list, unit_distances: list):
        self.luts, self.unit_distances = luts, unit_distances
        table = np.stack([np.asarray(lut.table, dtype=np.float32) for lut in luts])  # (members, N, 4)
        self.size = table.shape[1]
        self.texture = ctx.texture((self.size, len(luts)), 4, np.ascontiguousarray(table).tobytes(), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False

    def uniforms(self) -> dict:
        """Per member: the row's value of texel 0 (``u_field_lut_lo``), texels per data unit
        (``u_field_lut_scale``) and the transfer function's unit distance (world units); the row length."""
        lo = [float(lut.domain[0]) for lut in self.luts]
        scale = [(self.size - 1) / float(lut.domain[1] - lut.domain[0]) for lut in self.luts]
        return {"u_field_lut_lo": lo, "u_field_lut_scale": scale, "u_field_lut_size": self.size,
                "u_field_unit_distance": [float(u) for u in self.unit_distances]}


class _NoTable:
    """A label member's row of the table atlas: zeros (its colour table is :class:`LabelAtlas`'s)."""

    def __init__(self, size: int):
        self.table, self.domain = np.zeros((size, 4)), (0.0, 1.0)


def table_atlas(ctx, transfer_functions, lut_size: int) -> TableAtlas:
    """The members' tables (one transfer function per member, in order), ``lut_size`` texels a row; a label
    member's (a :class:`dvr_gl.labels.LabelTable`) row is zeros."""
    labels = [getattr(tf, "kind", None) == "labels" for tf in transfer_functions]
    return TableAtlas(ctx, [_NoTable(lut_size) if label else tf.tabulate(lut_size)
                            for tf, label in zip(transfer_functions, labels)],
                      [tf.unit_distance for tf in transfer_functions])


class LabelAtlas:
    """The label members' colour tables (:meth:`dvr_gl.labels.LabelTable.texture_table`: ``(r, g, b, sigma)``
    of label ``L`` at texel ``L - first``), each laid out in rows of one common width and stacked: member
    ``i``'s texel ``k`` at column ``k % width``, row ``row[i] + k // width``.  A scalar member has no rows."""

    def __init__(self, ctx, transfer_functions):
        tables = [tf if getattr(tf, "kind", None) == "labels" else None for tf in transfer_functions]
        self.width = max(t.texture_table().shape[1] for t in tables if t is not None)
        blocks, self.first, self.count, self.row = [], [], [], []
        rows = 0
        for t in tables:
            flat = t.texture_table().reshape(-1, 4)[:t.count] if t is not None else np.zeros((0, 4), np.float32)
            n = -(-len(flat) // self.width)
            blocks.append(np.concatenate([flat, np.zeros((n * self.width - len(flat), 4), np.float32)]))
            self.first.append(float(t.first) if t is not None else 0.0)
            self.count.append(float(t.count) if t is not None else 0.0)
            self.row.append(float(rows))
            rows += n
        data = np.concatenate(blocks).reshape(rows, self.width, 4).astype(np.float32)
        self.texture = ctx.texture((self.width, rows), 4, np.ascontiguousarray(data).tobytes(), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False

    def uniforms(self) -> dict:
        """Per member: its first label, texel count and first row (floats: labels within +-2^24 are exact);
        the common row width."""
        return {"u_field_label_first": self.first, "u_field_label_count": self.count,
                "u_field_label_row": self.row, "u_field_label_width": self.width}


class PreintegrationAtlas:
    """The members' pre-integration tables (:func:`dvr_gl.preintegration.preintegrate`, N x N each: x the
    front value, y the back value), member ``i`` in rows ``i N`` to ``(i + 1) N - 1`` of one RGBA32F texture."""

    def __init__(self, ctx, tables: list):
        self.tables = tables
        self.size = tables[0].size
        data = np.concatenate([np.asarray(t.table, dtype=np.float32).transpose(1, 0, 2) for t in tables])
        self.texture = ctx.texture((self.size, self.size * len(tables)), 4, np.ascontiguousarray(data).tobytes(),
                                   dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False

    def uniforms(self) -> dict:
        """Per member: the value of node 0 (``u_field_preint_lo``) and nodes per data unit
        (``u_field_preint_scale``); the table's size."""
        return {"u_field_preint_size": self.size,
                "u_field_preint_lo": [float(t.domain[0]) for t in self.tables],
                "u_field_preint_scale": [(self.size - 1) / float(t.domain[1] - t.domain[0]) for t in self.tables]}


def preintegration_atlas(ctx, transfer_functions, slab_length: float, size: int, method: str,
                         lut_size: int) -> PreintegrationAtlas:
    """The members' pre-integration tables for segments ``slab_length`` long (world units)."""
    # a label member's rows: transparent (its segments are classified at their middle: fields.glsl)
    transparent = TransferFunction([[0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 0.0]])
    return PreintegrationAtlas(ctx, [preintegrate(transparent if getattr(tf, "kind", None) == "labels" else tf,
                                                  slab_length, size, method, lut_size)
                                     for tf in transfer_functions])


# --- what a frame of several fields binds (the ray caster's and the slicer's) -----------------------------------

def frame_field_textures(frame, scene, defines: dict, slab_length: float) -> tuple[dict, FieldTextures]:
    """The frame's textures of several fields, kept in ``frame``'s cache (a :class:`~dvr_gl.gl.frame.GLFrame`):
    the table atlas ``u_field_lut``, the label atlas ``u_field_labels`` (a label member), the pre-integration
    atlas ``u_field_preint`` of segments ``slab_length`` long (CLASSIFY_PREINTEGRATED); and the members' group
    textures (:class:`FieldTextures`, bound by its own :meth:`FieldTextures.bind`)."""
    r, fieldset = scene.renderer, scene.field
    tfs = tuple(layer.transfer_function for layer in scene.layers)
    fields = frame._cached("field textures", (fieldset,), lambda: upload_fields(frame.ctx, fieldset))
    out = {"u_field_lut": frame._cached("field lut", (tfs, r.lut_size), lambda: table_atlas(frame.ctx, tfs,
                                                                                            r.lut_size))}
    if any(layer.role == "label" for layer in scene.layers):
        out["u_field_labels"] = frame._cached("field labels", tfs, lambda: LabelAtlas(frame.ctx, tfs))
    if "CLASSIFY_PREINTEGRATED" in defines:
        out["u_field_preint"] = frame._cached(
            "field preintegration", (tfs, slab_length, r.preintegration_size, r.preintegration, r.lut_size),
            lambda: preintegration_atlas(frame.ctx, tfs, slab_length, r.preintegration_size, r.preintegration,
                                         r.lut_size))
    return out, fields


def epsilon_scales(scene) -> list:
    """Per member: the scene's gradient epsilon (the first member's, ``u_gradient_epsilon``) over the member's
    own (:func:`dvr_gl.fields.gradient_epsilon`; a label's indicator runs from 0 to 1: 1e-5 per voxel, as
    :class:`dvr_gl.reference.members.LabelOptics` has it): fields.glsl scales a member's gradient by it for
    shading (``u_field_epsilon_scale``), so each member meets its own threshold."""
    first = gradient_epsilon(scene.field)
    return [first / (1e-5 / layer.field.sample_spacing if layer.role == "label" else gradient_epsilon(layer.field))
            for layer in scene.layers]
