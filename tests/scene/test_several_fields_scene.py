"""The scene model of several fields (dvr_gl/fields/layers.py, [[volume]] tables, the API's channel_axis, lists
of fields and time_axis): what is resolved, saved and refused, independent of any renderer."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dvr_gl
from dvr_gl.errors import DvrError, SceneError
from dvr_gl.fields import SphereField
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import FieldSet, Member, as_data, members_of
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene


def _volumes(n=2, shape=(6, 7, 8)):
    rng = np.random.default_rng(3)
    return [Volume(rng.random(shape).astype(np.float32), name=f"v{k}") for k in range(n)]


def test_one_scalar_member_stays_a_plain_volume():
    """A scene of one field takes the single-field path unchanged: no FieldSet."""
    (v,) = _volumes(1)
    assert as_data([Member(v, "scalar")]) is v
    assert isinstance(as_data([Member(v, "label")]), FieldSet)  # any other role needs the fields path


def test_union_box_and_groups():
    """The ray's extent is the union of the boxes; channels on one grid and dtype share a texture, up to four."""
    a, b = _volumes(2)
    c = Volume(np.zeros((3, 3, 3), np.float32), spacing=(2.0, 2.0, 2.0), origin=(-5.0, 1.0, 0.0), name="c")
    fs = FieldSet([a, b, c, a, a, a])
    lo, hi = fs.bounds
    np.testing.assert_array_equal(lo, [-5.0, 0.0, 0.0])
    np.testing.assert_array_equal(hi, [7.0, 6.0, 5.0])
    assert fs.groups(4) == [[0, 1, 3, 4], [2], [5]]
    assert fs.sample_spacing == 1.0


def test_members_must_be_grids_each_in_its_own_frame():
    """A member's own orientation is kept: the union spans its box turned into the first member's frame."""
    a, b = _volumes(2)
    turned = Volume(np.zeros((4, 4, 4), np.float32), direction=((0, -1, 0), (1, 0, 0), (0, 0, 1)), name="turned")
    fs = FieldSet([a, turned])
    assert fs.oriented and fs.transforms[0] is None
    lo, hi = fs.member_bounds(1)  # x' along +y, y' along -x: the box [0, 3]^3 turned to x in [-3, 0]
    np.testing.assert_allclose(lo, [-3.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(hi, [0.0, 3.0, 3.0], atol=1e-12)
    with pytest.raises(SceneError, match="must each be a regular grid"):
        FieldSet([a, SphereField((0.0, 0.0, 0.0), 1.0)])


def test_volume_tables_resolve_each_with_its_transfer_function(tmp_path):
    """[[volume]] tables: every field with its own transfer function; a field naming none gets a channel colour;
    the effective scene writes the tables back and loads to the same scene."""
    a, b = _volumes(2)
    np.save(tmp_path / "a.npy", a.data)
    np.save(tmp_path / "b.npy", b.data)
    (tmp_path / "s.toml").write_text(
        '[[volume]]\npath = "a.npy"\n[volume.transfer_function]\npoints = [[0, 1, 0, 0, 0], [1, 1, 0, 0, 0.5]]\n'
        '[[volume]]\npath = "b.npy"\niso_value = 0.25\n'
        '[image]\nwidth = 8\nheight = 8\n')
    scene = load_scene(tmp_path / "s.toml")
    assert isinstance(scene.field, FieldSet) and len(scene.layers) == 2
    first, second = scene.layers
    np.testing.assert_array_equal(first.transfer_function.points[:, :5], [[0, 1, 0, 0, 0], [1, 1, 0, 0, 0.5]])
    assert second.transfer_function.points[-1, 1:4].tolist() == [0.0, 1.0, 0.0]  # the second channel colour
    assert second.iso_value == 0.25
    saved = tmp_path / "effective.toml"
    saved.write_text(scene.to_toml(relative_to=tmp_path))
    again = load_scene(saved)
    for x, y in zip(scene.layers, again.layers):
        np.testing.assert_array_equal(x.transfer_function.points, y.transfer_function.points)
        np.testing.assert_array_equal(x.field.data, y.field.data)
        assert x.iso_value == y.iso_value
    assert again.camera.eye == pytest.approx(scene.camera.eye)


def test_volume_tables_refuse_two_first_transfer_functions():
    raw = {"volume": [{"demo": "blobs", "size": 8, "transfer_function": {"preset": "viridis"}}],
           "transfer_function": {"preset": "grayscale"}}
    with pytest.raises(SceneError, match="both given"):
        load_scene(None, base=raw)
    with pytest.raises(SceneError, match="array of tables"):
        load_scene(None, base={"volume": [1, 2]})


def test_api_channel_axis_list_and_time_axis():
    rng = np.random.default_rng(0)
    data = rng.random((2, 5, 6, 7)).astype(np.float32)
    scene = dvr_gl.scene_of(data, channel_axis=0, transfer_function=["grayscale", [[0, 0, 1, 0, 0], [1, 0, 1, 0, 1]]],
                            size=8)
    assert [m.name for m in scene.field.members] == ["channel 0", "channel 1"]
    np.testing.assert_array_equal(scene.layers[1].field.data, data[1])
    np.testing.assert_array_equal(scene.layers[1].transfer_function.points[:, :5], [[0, 0, 1, 0, 0], [1, 0, 1, 0, 1]])
    listed = dvr_gl.scene_of([data[0], data[1][:3]], spacing=[(1, 1, 1), (2, 2, 2)], size=8)
    assert listed.field.members[1].field.spacing == (2.0, 2.0, 2.0)
    series = rng.random((3, 4, 5, 6)).astype(np.float32)
    step = dvr_gl.scene_of(series, time_axis=0, time=2, size=8)
    alone = dvr_gl.scene_of(series[2], size=8)
    np.testing.assert_array_equal(step.field.data, alone.field.data)
    assert step.camera == alone.camera


@pytest.mark.parametrize("call, message", [
    (lambda d: dvr_gl.scene_of(d, channel_axis=0, transfer_function=["grayscale"]), "1 given for 2 fields"),
    (lambda d: dvr_gl.scene_of(d[0], channel_axis=0), "expected a 4D array"),
    (lambda d: dvr_gl.scene_of(d, time=1), "give time_axis too"),
    (lambda d: dvr_gl.scene_of(d, time_axis=0, time=5), "has 2 time steps"),
    (lambda d: dvr_gl.scene_of([]), "empty list"),
    (lambda d: dvr_gl.scene_of([d[0], d[1]], spacing=[(1, 1, 1)] * 3), "one per field"),
])
def test_api_refusals_are_one_line(call, message):
    data = np.zeros((2, 4, 4, 4), np.float32)
    with pytest.raises(DvrError, match=message) as info:
        call(data)
    assert "\n" not in str(info.value)


def test_renderers_that_do_not_declare_fields_refuse_in_one_line():
    """The registry refuses a scene of several fields for a renderer whose data kinds lack "fields", naming the
    ones that take it (a declared trait, never a name)."""
    scene = dvr_gl.scene_of(_volumes(2), size=8)
    takers = [n for n, p in registry.plugins().items() if p.data_kinds is None or "fields" in p.data_kinds]
    others = [n for n, p in registry.plugins().items() if n not in takers]
    assert takers and others
    for name in others:
        with pytest.raises(SceneError) as info:
            registry.check(dataclasses.replace(scene, renderer=dataclasses.replace(scene.renderer, name=name)))
        assert "fields" in str(info.value) and "\n" not in str(info.value)


def test_members_of_a_plain_field_is_itself():
    (v,) = _volumes(1)
    (m,) = members_of(v)
    assert m.field is v and m.role == "scalar"
