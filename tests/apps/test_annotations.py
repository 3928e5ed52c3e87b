"""Annotations (issue 43, item 5): an 8-bit overlay in its boxes only, the float image untouched, the scale
bar's closed-form length, the colour bar's colours, the orientation letters turning with the camera, and the
command line's refusals."""

import math

import numpy as np
import pytest

import dvr_gl
from conftest import run_cli
from dvr_gl.annotations import (
    Annotations,
    annotate,
    axis_labels,
    axis_tips,
    colorbar_geometry,
    font_size,
    layout,
    opacity_geometry,
    parse_annotate,
    scale_bar,
)
from dvr_gl.image import read_image

ALL = Annotations(colorbar=True, scalebar=True, axes=True, caption="a caption")


def _scene(projection="perspective", direction=None, size=(120, 96), **keys):
    data = np.linspace(0, 1, 6 * 7 * 8, dtype=np.float32).reshape(6, 7, 8)
    volume = dvr_gl.Volume(data, spacing=(0.5, 0.5, 0.5), **({"direction": direction} if direction else {}))
    return dvr_gl.scene_of(volume, size=size, projection=projection, **keys)


def _noise(scene, seed=1):
    return np.random.default_rng(seed).integers(0, 256, (scene.image.height, scene.image.width, 4), dtype=np.uint8)


def test_overlay_changes_only_pixels_inside_its_boxes():
    scene = _scene()
    pixels = _noise(scene)
    out = annotate(pixels, scene, ALL)
    inside = np.zeros(pixels.shape[:2], bool)
    boxes = layout(scene, ALL)
    assert set(boxes) == {"colorbar", "scalebar", "axes", "caption"}
    for x0, y0, x1, y1 in boxes.values():
        inside[y0:y1, x0:x1] = True
    changed = (out != pixels).any(axis=2)
    assert not changed[~inside].any()
    assert changed[inside].mean() > 0.9  # the panels darken everything inside
    assert not inside.all()


def test_the_float_image_is_unchanged():
    image = dvr_gl.render(_scene(size=(96, 96)))
    before = image.rgba.copy()
    annotated = image.annotated(colorbar=True, scalebar=True, axes=True, caption="x")
    assert annotated.dtype == np.uint8 and annotated.shape == (96, 96, 4)
    assert np.array_equal(image.rgba, before)
    assert not np.array_equal(annotated, image.srgb8())


def test_scale_bar_length_is_the_world_length_over_the_pixel_size():
    """Orthographic: one pixel is view_height / height world units in every plane (closed form)."""
    scene = _scene("orthographic", size=(160, 100))
    scene = scene.replace(camera=scene.camera.with_(view_height=7.3))
    world, pixels = scale_bar(scene)
    size = 7.3 / 100
    assert pixels == pytest.approx(world / size, rel=1e-12)
    mantissa = world / 10 ** math.floor(math.log10(world))
    assert any(abs(mantissa - m) < 1e-9 for m in (1, 2, 5))
    assert 0.5 < pixels / (160 / 5) < 2.0  # about a fifth of the width
    out = annotate(np.zeros((100, 160, 4), np.uint8), scene, Annotations(scalebar=True))
    x0, y0, x1, y1 = layout(scene, Annotations(scalebar=True))["scalebar"]
    row = out[y1 - max(2, font_size(100) // 3) - 1, x0:x1, :3]  # the bar's bottom row: white, nothing else
    assert (row == 255).all(axis=1).sum() == round(world / size)


def _srgb8(linear):
    c = np.clip(np.asarray(linear, np.float64), 0, 1)
    return np.round(255 * np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055))


def test_colour_bar_shows_the_transfer_function():
    points = [[0.0, 1.0, 0.0, 0.0, 0.1], [0.5, 0.0, 1.0, 0.2, 0.5], [1.0, 0.1, 0.3, 1.0, 0.9]]
    scene = _scene(size=(120, 200), transfer_function=points)
    spec = Annotations(colorbar=True)
    out = annotate(np.zeros((200, 120, 4), np.uint8), scene, spec)
    x0, y0, x1, y1 = colorbar_geometry(layout(scene, spec)["colorbar"], font_size(200))
    rows = np.arange(y0, y1, 7)
    values = 1.0 - (rows - y0 + 0.5) / (y1 - y0)  # top row: the highest value; rows at their centres
    expected = _srgb8(scene.transfer_function.color(values))
    # OpenImageIO's sRGB encoding against the formula: within one 8-bit step
    assert np.abs(out[rows, (x0 + x1) // 2, :3] - expected).max() <= 1


def test_colour_bar_shows_the_opacity():
    """The opacity column beside the strip: each row white over the square root of its opacity over the largest
    (0.9 at the top) of the column's width; measured on rows 7 apart against the points' interpolated opacity,
    within one pixel of rounding, and the column's rows rise with the opacity (0.1 at the bottom: a third)."""
    points = [[0.0, 1.0, 0.0, 0.0, 0.1], [0.5, 0.0, 1.0, 0.2, 0.5], [1.0, 0.1, 0.3, 1.0, 0.9]]
    scene = _scene(size=(120, 200), transfer_function=points)
    spec = Annotations(colorbar=True)
    out = annotate(np.zeros((200, 120, 4), np.uint8), scene, spec)
    box = layout(scene, spec)["colorbar"]
    x0, y0, x1, y1 = opacity_geometry(box, font_size(200))
    assert colorbar_geometry(box, font_size(200))[2] < x0 and x1 <= box[2]
    rows = np.arange(y0, y1, 7)
    values = 1.0 - (rows - y0 + 0.5) / (y1 - y0)
    expected = np.sqrt(scene.transfer_function.opacity(values) / 0.9) * (x1 - x0)
    white = (out[rows, x0:x1, :3] == 255).all(axis=2).sum(axis=1)
    assert np.abs(white - expected).max() <= 1
    assert white[0] == x1 - x0 and white[-1] < 0.45 * (x1 - x0)


def test_orientation_letters_follow_the_camera():
    flip = ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))  # an oriented file (RAS stored)
    front = _scene(direction=flip, view="anterior")
    back = _scene(direction=flip, view="posterior")
    assert axis_labels(front) == ("L", "P", "S")
    assert axis_labels(_scene()) == ("x", "y", "z")
    # anterior: the patient's left (L, the +x arm) on the image's right; from behind it is on the left
    assert axis_tips(front.camera)[0, 0] == pytest.approx(1.0)
    assert axis_tips(back.camera)[0, 0] == pytest.approx(-1.0)
    assert axis_tips(front.camera)[2, 1] == pytest.approx(-1.0)  # superior up (row 0 is the top) in both
    assert axis_tips(back.camera)[2, 1] == pytest.approx(-1.0)
    turned = front.replace(camera=front.camera.orbited(azimuth=front.camera.orbit[0] + 180.0))
    assert np.allclose(axis_tips(turned.camera), axis_tips(back.camera), atol=1e-12)


def test_parse_annotate():
    assert parse_annotate("all") == Annotations(True, True, True)
    assert parse_annotate("axes,caption=Head, CT").caption == "Head, CT"
    assert parse_annotate("scalebar,unit=um").length_unit == "um"
    for bad in ("", "colour", "axes=1", "unit=mm"):
        with pytest.raises(ValueError):
            parse_annotate(bad)


def test_cli_annotates_the_png_and_refuses_float_outputs(tmp_path, capsys):
    small = ["--demo", "--size", "100x96", "--set", "volume.size=16"]
    code, _, _ = run_cli(capsys, "render", *small, "-o", tmp_path / "plain.png", "--save-scene", tmp_path / "s.toml")
    assert code == 0
    code, _, _ = run_cli(capsys, "render", *small, "-o", tmp_path / "a.png", "--annotate", "all,caption=hi")
    assert code == 0
    plain, marked = read_image(tmp_path / "plain.png"), read_image(tmp_path / "a.png")
    inside = np.zeros(plain.shape[:2], bool)
    for x0, y0, x1, y1 in layout(dvr_gl.load_scene(tmp_path / "s.toml"), parse_annotate("all,caption=hi")).values():
        inside[y0:y1, x0:x1] = True
    changed = (plain != marked).any(axis=2)
    assert changed.any() and not changed[~inside].any()
    for argv, words in ((["-o", tmp_path / "a.exr", "--annotate", "axes"], "8-bit"),
                        (["-o", tmp_path / "b.png", "--annotate", "axes,compass"], "'compass' is not one of")):
        code, _, err = run_cli(capsys, "render", *small, *argv)
        assert code != 0 and len(err.strip().splitlines()) == 1 and words in err, err
    assert not (tmp_path / "a.exr").exists() and not (tmp_path / "b.png").exists()
