"""Colour tables of label maps (dvr_gl/labels/readers.py): Slicer's .ctbl/.txt, ITK-SNAP's label descriptions,
Slicer's .seg.nrrd segment metadata; strict (one line naming the line), sandboxed; and the scene keys that name
them (a [[volume]] of role "label")."""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.errors import DvrError, SceneError
from dvr_gl.labels import read_color_table
from dvr_gl.presets.colour import srgb_to_linear
from dvr_gl.sandbox import Sandbox, SandboxError, active
from dvr_gl.scene.resolve import load_scene
from fuzz_inputs import COLOR_TABLES


def _write(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(COLOR_TABLES[name])
    return path


def test_slicer_color_table(tmp_path):
    """label name R G B A, 0..255 sRGB: colours decoded to linear, A / 255 the alpha."""
    t = read_color_table(_write(tmp_path, "labels.ctbl"), unit_distance=2.0)
    assert t.labels.tolist() == [0, 1, 2, 7] and t.names == ("Background", "tissue", "bone", "vessel")
    np.testing.assert_allclose(t.colors[1], srgb_to_linear(np.array([128, 174, 128]) / 255), rtol=1e-15)
    np.testing.assert_allclose(t.opacity, [0, 1, 1, 128 / 255], rtol=1e-15)
    assert t.unit_distance == 2.0
    again = read_color_table(_write(tmp_path, "slicer.txt"))  # the same format as .txt
    np.testing.assert_array_equal(again.colors, read_color_table(tmp_path / "labels.ctbl").colors)


def test_itksnap_label_description(tmp_path):
    """IDX R G B A VIS MSH "LABEL": A is the opacity 0..1, VIS 0 hides the label."""
    t = read_color_table(_write(tmp_path, "itksnap.txt"))
    assert t.labels.tolist() == [0, 1, 2, 3] and t.names[1] == "Label 1 (liver)"
    np.testing.assert_allclose(t.opacity, [0.0, 1.0, 0.5, 0.0])
    np.testing.assert_allclose(t.colors[1], [1.0, 0.0, 0.0])


def test_slicer_segmentation_header(tmp_path):
    """SegmentN_LabelValue, _Color (0..1 sRGB), _Name from the header only; the default opacity."""
    t = read_color_table(_write(tmp_path, "seg.seg.nrrd"))
    assert t.labels.tolist() == [1, 4] and t.names == ("kidney", "tumour")
    np.testing.assert_allclose(t.colors[1], srgb_to_linear([0.9, 0.5, 0.1]), rtol=1e-15)
    assert np.all(t.opacity == 0.5)


@pytest.mark.parametrize("name, text, match", [
    ("a.ctbl", b"0 Background 0 0 0 0\n1 two words 1 2 3 255\n", "line 2 is not 'label name R G B A'"),
    ("a.ctbl", b"1 tissue 300 0 0 255\n", "0..255, got 300"),
    ("a.ctbl", b"1 a 0 0 0 255\n1 b 0 0 0 255\n", "label 1 is listed twice"),
    ("a.ctbl", b"99999999999999999999 a 0 0 0 255\n", "beyond"),
    ("a.ctbl", b"# only a comment\n", "lists no label"),
    ("FreeSurferColorLUT.txt", b"0 Unknown 0 0 0 0\n2 Left-Cerebral-White-Matter 245 245 245 0\n", "transparent"),
    ("a.txt", b"# Color procedural file /x\n0 0 0 0\n", "procedural"),
    ("a.txt", b'1 255 0 0 1.5 1 1 "x"\n', "opacity A"),
    ("a.label", b"1 255 0 0 1 1 1 x\n", "ITK-SNAP label line"),
    ("a.ctbl", b"1 a 0 0 0 255\n\0\0", "binary"),
    ("a.csv", b"1,a,0,0,0,255\n", "suffix"),
    ("a.nrrd", b"NRRD0004\ntype: uchar\n\n", "names no segment"),
    ("a.nrrd", b"NRRD0004\nSegment0_Color:=1 0 0\n\n", "Segment0_LabelValue is missing"),
    ("a.nrrd", b"NRRD0004\nSegment0_LabelValue:=1\nSegment0_Color:=1 0\n\n", "three numbers"),
    ("a.nrrd", b"NRRD0004\nSegment0_LabelValue:=1\nSegment0_Color:=1 0 0\nSegment0_Layer:=0\n"
               b"Segment1_LabelValue:=1\nSegment1_Color:=0 1 0\nSegment1_Layer:=1\n\n", "overlap in 2 layers"),
    ("a.nrrd", b"P5 not a nrrd", "not an NRRD"),
])
def test_bad_tables_are_one_line(tmp_path, name, text, match):
    (tmp_path / name).write_bytes(text)
    with pytest.raises(SceneError, match=match) as info:
        read_color_table(tmp_path / name)
    assert "\n" not in str(info.value) and name in str(info.value)


def test_tables_are_read_only_inside_the_sandbox(tmp_path):
    inside, outside = tmp_path / "in", tmp_path / "out"
    inside.mkdir()
    outside.mkdir()
    path = _write(outside, "labels.ctbl")
    with active(Sandbox((inside,))), pytest.raises(SandboxError, match="outside"):
        read_color_table(path)


def _label_scene(tmp_path, tf: str) -> str:
    seg = np.zeros((4, 5, 6), np.uint8)
    seg[1:3, 1:4, 2:5] = 1
    seg[2, 2, 2] = 7
    np.save(tmp_path / "seg.npy", seg)
    np.save(tmp_path / "ct.npy", np.linspace(0, 1, seg.size, dtype=np.float32).reshape(seg.shape))
    (tmp_path / "s.toml").write_text('[[volume]]\npath = "ct.npy"\n[[volume]]\npath = "seg.npy"\nrole = "label"\n'
                                     f'[volume.transfer_function]\n{tf}\n[image]\nwidth = 8\nheight = 8\n')
    return tmp_path / "s.toml"


def test_a_label_volume_takes_a_colour_table_file_and_saves_it_explicit(tmp_path):
    _write(tmp_path, "labels.ctbl")
    scene = load_scene(_label_scene(tmp_path, 'file = "labels.ctbl"\nunit_distance = 0.5'))
    table = scene.layers[1].transfer_function
    assert scene.layers[1].role == "label" and table.labels.tolist() == [0, 1, 2, 7] and table.unit_distance == 0.5
    saved = tmp_path / "effective.toml"
    saved.write_text(scene.to_toml(relative_to=tmp_path))
    assert "labels = [" in saved.read_text()
    again = load_scene(saved).layers[1].transfer_function
    for name in ("labels", "colors", "opacity"):
        np.testing.assert_array_equal(getattr(table, name), getattr(again, name))


def test_a_label_volume_by_default_and_by_rows(tmp_path):
    default = load_scene(_label_scene(tmp_path, "")).layers[1].transfer_function
    assert default.labels.tolist() == [1, 7] and np.all(default.opacity == 0.5)
    rows = load_scene(_label_scene(tmp_path, "labels = [[7, 1, 0, 0, 2.0]]\nopacity_model = \"extinction\""))
    colour, sigma = rows.layers[1].transfer_function.lookup([0, 1, 7])
    assert sigma.tolist() == [0.0, 0.0, 2.0]


@pytest.mark.parametrize("tf, match", [
    ('points = [[0, 0, 0, 0, 0], [1, 1, 1, 1, 1]]', "does not apply to a label map"),
    ('preset = "viridis"', "does not apply to a label map"),
    ('labels = [[1, 0, 0, 0, 1]]\nfile = "x.ctbl"', "labels"),
    ('file = "labels.ctbl"\nopacity_model = "extinction"', "extinction"),
])
def test_a_label_volume_refuses_a_scalar_transfer_function(tmp_path, tf, match):
    _write(tmp_path, "labels.ctbl")
    with pytest.raises(DvrError, match=match) as info:
        load_scene(_label_scene(tmp_path, tf))
    assert "\n" not in str(info.value)


def test_a_scalar_field_refuses_labels(tmp_path):
    np.save(tmp_path / "ct.npy", np.zeros((3, 3, 3), np.float32))
    (tmp_path / "s.toml").write_text('[volume]\npath = "ct.npy"\n[transfer_function]\nlabels = [[1, 0, 0, 0, 1]]\n')
    with pytest.raises(SceneError, match="applies to a label map"):
        load_scene(tmp_path / "s.toml")


def test_a_label_volume_of_fractions_is_refused(tmp_path):
    np.save(tmp_path / "seg.npy", np.full((3, 3, 3), 0.5, np.float32))
    (tmp_path / "s.toml").write_text('[volume]\npath = "seg.npy"\nrole = "label"\n')
    with pytest.raises(DvrError, match="whole numbers"):
        load_scene(tmp_path / "s.toml")


def test_a_segmentation_as_the_label_map_brings_its_colours(tmp_path):
    """A single-layer .seg.nrrd is a 3D label map; given as a volume of role label with no table of its own,
    its header's segments colour it."""
    _write(tmp_path, "seg.seg.nrrd")
    (tmp_path / "s.toml").write_text('[volume]\npath = "seg.seg.nrrd"\nrole = "label"\n[image]\nwidth = 8\n'
                                     'height = 8\n')
    layer = load_scene(tmp_path / "s.toml").layers[0]
    assert layer.field.data.tolist() == [[[0, 1], [1, 4]], [[0, 0], [4, 1]]]
    assert layer.transfer_function.labels.tolist() == [1, 4]
    np.testing.assert_allclose(layer.transfer_function.colors[0], srgb_to_linear([0.2, 0.6, 0.3]), rtol=1e-15)
    (tmp_path / "s.toml").write_text('[volume]\npath = "seg.seg.nrrd"\nrole = "label"\n[transfer_function]\n'
                                     'labels = [[4, 1, 1, 1, 1]]\n')
    assert load_scene(tmp_path / "s.toml").layers[0].transfer_function.labels.tolist() == [4]
