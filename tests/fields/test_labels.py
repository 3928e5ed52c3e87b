"""Label maps (dvr_gl/labels): the categorical table, the sampling rule that never invents a label (float64
and GLSL), the default colours, the scene keys."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dvr_gl.errors import SceneError, VolumeError
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import FieldSet, Member
from dvr_gl.labels import (
    LabelTable,
    check_label_data,
    default_table,
    indicator,
    label_sample,
    labels_present,
)
from dvr_gl.labels.table import TABLE_ROW
from dvr_gl.transfer_function import MAX_OPTICAL_DEPTH

SHADERS = Path(__file__).with_name("shaders")
FROG = Path(__file__).resolve().parents[3] / "shared" / "data" / "large" / "frogtissue.mhd"


def _label_volume(dtype=np.uint8, shape=(9, 10, 11), labels=(0, 3, 5, 7), seed=0, **kw) -> Volume:
    """Blocks of a few labels (so the 8 taps often hold two to four labels, and ties happen on the lattice)."""
    rng = np.random.default_rng(seed)
    coarse = rng.choice(np.array(labels), size=tuple(-(-s // 2) for s in shape))
    data = coarse.repeat(2, 0).repeat(2, 1).repeat(2, 2)[:shape[0], :shape[1], :shape[2]]
    return Volume(np.ascontiguousarray(data.astype(dtype)), **kw)


def _points(volume, n, seed=1, margin=1.0) -> np.ndarray:
    """Random world points over the box and ``margin`` voxels beyond it (where the taps clamp), and lattice
    half-points (exact ties of two, four or eight taps)."""
    rng = np.random.default_rng(seed)
    lo, hi = volume.box
    pad = margin * np.array(volume.spacing)
    rand = rng.uniform(lo - pad, hi + pad, (n, 3))
    half = (rng.integers(0, np.array(volume.dims) - 1, (n // 4, 3)) + rng.choice([0.0, 0.5], (n // 4, 3)))
    return np.concatenate([rand, volume.origin + half * np.array(volume.spacing)])


# --- the table ----------------------------------------------------------------------------------


def test_table_lookup_alpha_model_and_transparent_labels():
    """alpha per unit_distance -> sigma = -log1p(-alpha)/unit; alpha 1 is the largest finite depth per unit;
    unlisted labels and label 0 (unlisted) are black and transparent."""
    t = LabelTable([5, 2, 9], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [0.5, 1.0, 0.0], unit_distance=2.0)
    assert t.labels.tolist() == [2, 5, 9]  # sorted with their rows
    colour, sigma = t.lookup([0, 2, 5, 9, 4, 100, -3])
    np.testing.assert_array_equal(colour[:4], [[0, 0, 0], [1, 0, 0], [0, 0, 1], [0, 1, 0]])
    assert sigma[1] == pytest.approx(MAX_OPTICAL_DEPTH / 2.0, rel=1e-15)
    assert sigma[2] == pytest.approx(-np.log1p(-0.5) / 2.0, rel=1e-15)
    assert sigma[0] == sigma[3] == 0.0 and not colour[4:].any() and not sigma[4:].any()
    assert t.visible([2, 9, 0]).tolist() == [True, False, False]
    ext = LabelTable([1], [[1, 1, 1]], [3.5], opacity_model="extinction")
    assert ext.lookup([1])[1][0] == 3.5


def test_table_says_where_blocks_are_empty():
    """A range of labels is empty when no label with opacity lies in it (0 here is unlisted, 9 transparent)."""
    t = LabelTable([2, 5, 9], [[1, 0, 0]] * 3, [0.5, 1.0, 0.0])
    lo, hi = np.array([0, 0, 3, 6, 5, -4]), np.array([1, 2, 4, 9, 5, 0])
    assert t.opaque_somewhere(lo, hi).tolist() == [False, True, False, False, True, False]
    assert t.opaque_somewhere([3], [4], margin=1.0).tolist() == [True]
    assert t.domain == (2.0, 9.0)


def test_table_round_trips_its_scene_table():
    t = LabelTable([1, 4], [[0.25, 0.5, 1.0], [1, 0, 0]], [0.3, 0.9], unit_distance=0.5)
    again = LabelTable.from_rows(t.to_table()["labels"], t.to_table()["unit_distance"])
    for name in ("labels", "colors", "opacity"):
        np.testing.assert_array_equal(getattr(t, name), getattr(again, name))


@pytest.mark.parametrize("rows, match", [
    ([[1, 0, 0, 0]], "rows"), ([[1.5, 0, 0, 0, 1]], "whole number"), ([[1, 2, 0, 0, 1]], "colour"),
    ([[1, 0, 0, 0, 1.5]], "alpha"), ([[1, 0, 0, 0, 1], [1, 1, 1, 1, 1]], "twice"),
    ([[0, 0, 0, 0, 1], [2e6, 0, 0, 0, 1]], "span"), ([[1e300, 0, 0, 0, 1]], "2\\^24"),
    ([[1, float("nan"), 0, 0, 1]], "finite"), ("banana", "rows")])
def test_table_refuses_bad_rows_in_one_line(rows, match):
    with pytest.raises(SceneError, match=match) as info:
        LabelTable.from_rows(rows)
    assert "\n" not in str(info.value)


def test_texture_table_wraps_rows():
    """Label L at texel L - first, row-major in rows of TABLE_ROW; unlisted labels zero."""
    t = LabelTable([-3, 5000, 9000], [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [1.0, 0.5, 0.25])
    table = t.texture_table()
    assert table.shape == (3, TABLE_ROW, 4) and t.count == 9004 and t.first == -3
    flat = table.reshape(-1, 4)
    for label, row in zip(t.labels, range(3)):
        np.testing.assert_allclose(flat[label + 3], np.r_[t.colors[row], t.extinction[row]], rtol=1e-7)
    assert np.count_nonzero(flat.any(axis=1)) == 3
    assert t.uniforms("u_seg") == {"u_seg_layout": (-3, 9004, TABLE_ROW)}


def test_default_table_gives_each_label_present_a_colour():
    data = np.zeros((4, 5, 6), np.int16)
    data[1, 1:3, 2] = -7
    data[2, :, :3] = 300
    data[3, 0, 0] = 12
    t = default_table(data, unit_distance=2.0)
    assert t.labels.tolist() == [-7, 12, 300] and np.all(t.opacity == 0.5) and t.unit_distance == 2.0
    assert len({tuple(c) for c in np.round(t.colors, 6)}) == 3
    assert labels_present(data).tolist() == [-7, 0, 12, 300]
    assert default_table(data).colors[1].tolist() == default_table(data[2:]).colors[0].tolist()  # by value


def test_label_data_must_hold_whole_numbers():
    check_label_data(np.array([[[1.0, 2.0]]], np.float32))
    for bad in (np.array([[[0.5]]], np.float32), np.array([[[np.nan]]], np.float32)):
        with pytest.raises(VolumeError, match="whole numbers"):
            check_label_data(bad)


@pytest.mark.skipif(not FROG.exists(), reason="the shared data (frogtissue) is not here")
def test_frogtissue_reads_with_a_default_colour_per_tissue():
    """The frog's map (labels 0..29, VTK's 29 tissues) holds 25 of them (18, 19, 22 and 28 are absent): 25
    distinct colours, the background transparent."""
    from dvr_gl.io import load_volume

    volume = load_volume(FROG)
    t = default_table(volume.data)
    assert t.labels.tolist() == sorted(set(range(1, 30)) - {18, 19, 22, 28})
    assert len({tuple(c) for c in np.round(t.colors, 6)}) == 25


# --- the sampling rule (float64) ------------------------------------------------------------------


@pytest.mark.parametrize("filter", ["linear", "nearest"])
def test_never_a_label_outside_the_taps(filter):
    """Random points in and around the box: every sample's label is one the map holds, and its colour one the
    table lists (or transparent); with linear interpolation of the values, 3 beside 5 would read 4."""
    volume = _label_volume(labels=(0, 3, 5), spacing=(0.5, 1.0, 2.0), origin=(-1.0, 2.0, 0.5))
    labels, _ = label_sample(volume, _points(volume, 4000), filter)
    assert set(np.unique(labels)) <= {0, 3, 5}
    table = default_table(volume.data)
    colour, _ = table.lookup(labels)
    allowed = {tuple(c) for c in table.colors} | {(0.0, 0.0, 0.0)}
    assert {tuple(c) for c in colour} <= allowed
    values = volume.reconstruct("linear").sample(_points(volume, 4000))
    assert np.any(np.abs(values - 4.0) < 0.25)  # what interpolating the values would show: a label 4


def test_ties_go_to_the_smaller_label_and_the_argmax_wins():
    data = np.zeros((2, 2, 2), np.uint8)
    data[:, :, 0], data[:, :, 1] = 5, 3
    volume = Volume(data)
    labels, grad = label_sample(volume, [[0.5, 0.5, 0.5], [0.4, 0.5, 0.5], [0.6, 0.2, 0.9]])
    assert labels.tolist() == [3, 5, 3]
    np.testing.assert_allclose(grad[1], [-1.0, 0.0, 0.0], atol=1e-15)  # I_5 = 1 - x: into label 5 is -x
    np.testing.assert_allclose(grad[2], [1.0, 0.0, 0.0], atol=1e-15)


def test_indicator_gradient_is_the_derivative():
    """The gradient label_sample returns is the chosen label's indicator differentiated (central differences
    of 1e-6 world units away from the voxel planes, where it is smooth: agreement to 1e-8)."""
    volume = _label_volume(spacing=(0.7, 1.0, 1.3))
    rng = np.random.default_rng(4)
    u = rng.integers(0, np.array(volume.dims) - 1, (300, 3)) + rng.uniform(0.05, 0.95, (300, 3))
    points = volume.origin + u * np.array(volume.spacing)
    labels, grad = label_sample(volume, points)
    h = 1e-6
    for p, label, g in zip(points, labels, grad):
        fd = [(indicator(volume, p + h * e, label) - indicator(volume, p - h * e, label))[0] / (2 * h)
              for e in np.eye(3)]
        np.testing.assert_allclose(g, fd, atol=1e-8)


def test_sphere_boundary_is_smoother_than_nearest():
    """A ball of label 1 (radius 5.3 voxels): the indicator's 0.5 level stands for the sphere better than the
    nearest voxel's staircase.  Measured at 40000 random points: 884 misclassified against 1537 (the volume
    between the two surfaces, 0.58x), their RMS distance from the sphere 0.136 voxel against 0.213, the
    farthest 0.48 against 0.70 (radii 5.0 and 6.1 alike); the bounds leave 10-20% of margin."""
    n, radius = 16, 5.3
    z, y, x = np.mgrid[:n, :n, :n]
    centre = np.array([7.6, 7.3, 7.45])
    inside = (x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2 <= radius ** 2
    volume = Volume(inside.astype(np.uint8))
    points = np.random.default_rng(5).uniform(1.0, n - 2.0, (40000, 3))
    distance = np.linalg.norm(points - centre, axis=1) - radius
    truth = distance <= 0
    wrong = {}
    for filter in ("linear", "nearest"):
        labels, _ = label_sample(volume, points, filter)
        wrong[filter] = distance[(labels == 1) != truth]
    linear, nearest = wrong["linear"], wrong["nearest"]
    assert len(linear) < 0.7 * len(nearest)
    assert np.sqrt(np.mean(linear ** 2)) < 0.75 * np.sqrt(np.mean(nearest ** 2))
    assert np.abs(linear).max() < 0.55 < 0.6 < np.abs(nearest).max()


# --- the GLSL rule --------------------------------------------------------------------------------


def _probe(ctx, volume, points, filter, texture, channel, value_scale, value_offset, table=None):
    """labels.glsl at ``points`` on the GPU: (labels, gradients), or with ``table`` the (r, g, b, sigma)."""
    import moderngl

    from dvr_gl.gl.shaders import create_program

    defines = {"FILTER_NEAREST": filter == "nearest", "FILTER_LINEAR": filter != "nearest",
               "PROBE_CLASS": table is not None}
    program = create_program(ctx, "fullscreen.vert", "label_probe.frag", defines, roots=(SHADERS,))
    width = 64
    height = -(-len(points) // width)
    grid = np.zeros((height * width, 4), np.float32)
    grid[:len(points), :3] = points
    pts = ctx.texture((width, height), 4, grid.tobytes(), dtype="f4")
    pts.filter = (moderngl.NEAREST, moderngl.NEAREST)
    target = ctx.texture((width, height), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    table_tex = table.upload(ctx) if table is not None else ctx.texture((1, 1), 4, dtype="f4")
    scale = 1.0 / np.array(volume.spacing)
    values = {"u_channel": channel, "u_value_scale": value_scale, "u_value_offset": value_offset,
              "u_dims": tuple(volume.dims), "u_scale": tuple(scale),
              "u_offset": tuple(-np.array(volume.origin) * scale),
              "u_label_layout": table.uniforms()["u_label_layout"] if table is not None else (0, 1, 1)}
    for name, value in values.items():
        if name in program:
            program[name].value = value
    for unit, (name, tex) in enumerate((("u_labels", texture), ("u_points", pts), ("u_label_table", table_tex))):
        if name in program:
            program[name].value = unit
            tex.use(unit)
    vao = ctx.vertex_array(program, [])
    try:
        fbo.use()
        ctx.viewport = (0, 0, width, height)
        vao.render(mode=moderngl.TRIANGLES, vertices=3)
        out = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(-1, 4)[:len(points)]
    finally:
        for obj in (vao, fbo, target, pts, table_tex):
            obj.release()
    return out


def _near_tie(volume, points, filter) -> np.ndarray:
    """Points where float32 may rightly choose otherwise: the top two indicators within 1e-5 (linear), or a
    coordinate within 1e-5 voxel of a half-integer (nearest)."""
    from dvr_gl.labels.sampling import _taps

    if filter == "nearest":
        u = volume.world_to_index(points)
        return np.any(np.abs(u - np.floor(u) - 0.5) < 1e-5, axis=1)
    labels, weights, _ = _taps(volume, points)
    sums = np.stack([np.where(labels == labels[j], weights, 0.0).sum(axis=0) for j in range(8)])
    distinct = np.where(np.array([[np.any(labels[:j, i] == labels[j, i]) for i in range(labels.shape[1])]
                                  for j in range(8)]), -1.0, sums)
    top = np.sort(distinct, axis=0)
    return top[-1] - top[-2] < 1e-5


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32])
@pytest.mark.parametrize("filter", ["linear", "nearest"])
def test_glsl_equals_the_float64_rule(gl_context, dtype, filter):
    """labels.glsl against label_sample at random points and lattice ties, in each upload precision: the same
    label everywhere but within float32 rounding of a tie (none measured on these points: the ties here are
    exact in float32; measured on 25000 points, none differ), the gradient within 4e-6 per world unit
    (float32 weights: measured 1.9e-6, gradients up to 2 per world unit here)."""
    from dvr_gl.renderers.grid.textures import upload_volume

    labels = (0, 3, 5, 7) if dtype != np.int16 else (-300, 0, 3, 1200)
    if dtype == np.uint16:
        labels = (0, 3, 40000, 65535)
    volume = _label_volume(dtype, labels=labels, spacing=(0.5, 1.0, 2.0), origin=(-1.0, 2.0, 0.5))
    points = _points(volume, 2000)
    tex = upload_volume(gl_context, volume)
    try:
        out = _probe(gl_context, volume, points, filter, tex.texture, 0, tex.value_scale, tex.value_offset)
    finally:
        tex.texture.release()
    want, grad = label_sample(volume, points, filter)
    got = out[:, 0].astype(np.int64)
    differ = got != want
    assert not np.any(differ & ~_near_tie(volume, points, filter))
    assert differ.sum() <= 2
    same = ~differ
    np.testing.assert_allclose(out[same, 1:], grad[same], atol=4e-6)


def test_glsl_reads_its_channel_of_a_shared_texture_and_its_table(gl_context):
    """A label map sharing a texture with a scalar field (the grid kit's upload of several fields, channel 1),
    classified through its table's GPU form, wrapped over rows: the float64 lookup within float32."""
    from dvr_gl.renderers.grid.field_textures import upload_fields

    seg = _label_volume(np.uint16, labels=(0, 2, 4097, 9000))
    image = Volume(np.random.default_rng(2).random(seg.data.shape).astype(np.float32).astype(np.uint16))
    fields = upload_fields(gl_context, FieldSet([Member(image), Member(seg, "label")]))
    assert fields.channel[1] == 1 and fields.group[1] == 0
    table = LabelTable([2, 4097, 9000], [[1, 0, 0], [0, 1, 0], [0.2, 0.4, 0.6]], [1.0, 0.5, 0.25])
    points = _points(seg, 800)
    try:
        tex = fields.groups[0].texture
        scale, offset = fields.value_scale[1], fields.value_offset[1]
        got = _probe(gl_context, seg, points, "linear", tex, 1, scale, offset)
        classes = _probe(gl_context, seg, points, "linear", tex, 1, scale, offset, table)
    finally:
        fields.release()
    want, _ = label_sample(seg, points)
    assert np.array_equal(got[:, 0].astype(np.int64), want)
    colour, sigma = table.lookup(want)
    np.testing.assert_allclose(classes, np.concatenate([colour, sigma[:, None]], axis=1), rtol=1e-7, atol=0)


def test_the_api_takes_a_label_table_per_label_map(tmp_path):
    """render([ct, Member(seg, "label")], transfer_function=[tf, rows or a file]): the label map's is a
    LabelTable; a preset's name for it is one line."""
    from dvr_gl.api import scene_of
    from dvr_gl.errors import DvrError

    seg = _label_volume()
    ct = Volume(np.zeros(seg.data.shape, np.float32))
    rows = [[3, 1, 0, 0, 1], [5, 0, 1, 0, 0.5]]
    scene = scene_of([ct, Member(seg, "label")], transfer_function=[None, rows])
    assert isinstance(scene.transfer_functions[1], LabelTable) and scene.transfer_functions[1].labels.tolist() == [3, 5]
    (tmp_path / "t.ctbl").write_text("3 a 255 0 0 255\n")
    scene = scene_of([ct, Member(seg, "label")], transfer_function=[None, str(tmp_path / "t.ctbl")])
    assert scene.transfer_functions[1].labels.tolist() == [3]
    default = scene_of([ct, Member(seg, "label")]).transfer_functions[1]
    assert default.labels.tolist() == [3, 5, 7]
    with pytest.raises(DvrError, match="a label map takes"):
        scene_of([ct, Member(seg, "label")], transfer_function=[None, "viridis"])
