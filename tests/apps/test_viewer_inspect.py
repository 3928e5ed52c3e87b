"""The viewer's picking, annotations and camera-path recording, without a window (dvr_gl/viewer/inspect.py)."""

from __future__ import annotations

import types

import numpy as np
import pytest

from conftest import small_scene
from dvr_gl.annotations import annotate
from dvr_gl.image import composite_over, encode_8bit
from dvr_gl.picking import pick
from dvr_gl.scene.resolve import load_scene
from dvr_gl.viewer import navigation
from dvr_gl.viewer.inspect import (
    VIEWER_ANNOTATIONS,
    KeyframeRecorder,
    PickProbe,
    annotated_display,
    cursor_pixel,
    pick_text,
)
from dvr_gl.viewer.screenshots import write_screenshot

# --- picking ---


def test_cursor_maps_to_the_full_scene_pixel_whatever_resolution_is_shown():
    """The image rectangle spans the full scene; a reduced frame (1/4) is stretched over the same rectangle,
    so its pixel under the cursor is the full one's over 4: picking the full scene picks what is shown."""
    rect = (10.0, 20.0, 200.0, 100.0)          # window pixels; a 400x200 scene drawn at half size
    assert cursor_pixel((10.0, 20.0), rect, (400, 200)) == (0.0, 0.0)
    assert cursor_pixel((110.0, 70.0), rect, (400, 200)) == (200.0, 100.0)
    assert cursor_pixel((209.99, 119.99), rect, (400, 200))[0] < 400
    assert cursor_pixel((9.0, 50.0), rect, (400, 200)) is None and cursor_pixel((50.0, 120.0), rect, (400, 200)) is None
    for cursor in ((37.3, 41.9), (150.0, 99.5)):
        full, reduced = cursor_pixel(cursor, rect, (400, 200)), cursor_pixel(cursor, rect, (100, 50))
        assert np.allclose(np.multiply(reduced, 4), full)


def test_probe_waits_for_a_resting_cursor_and_picks_once():
    probe = PickProbe(rest=0.2)
    probe.moved(1.0)
    assert not probe.due(1.1, (3.2, 4.0), 0, dragging=False)     # still moving
    assert not probe.due(1.5, (3.2, 4.0), 0, dragging=True)      # dragging: never
    assert probe.due(1.25, (3.2, 4.0), 0, dragging=False)
    probe.show((3.2, 4.0), 0, "x")
    assert not probe.due(2.0, (3.9, 4.5), 0, dragging=False)     # the same pixel, the same scene
    assert probe.due(2.0, (3.9, 4.5), 1, dragging=False)         # the scene changed
    probe.enabled = False
    assert not probe.due(3.0, (5.0, 5.0), 2, dragging=False) and probe.text == ""


def test_viewer_picks_the_full_scene_at_the_cursor_and_shows_picks_values(monkeypatch):
    """Viewer._pick on a stand-in viewer: dvr_gl.pick gets the full scene and the mapped pixel, and the status
    text is pick_text of exactly that pick (its value, voxel and position)."""
    app = pytest.importorskip("dvr_gl.viewer.app")
    scene = small_scene({"camera.azimuth": 30.0, "renderer.compositing": "mip"})
    calls = []

    def spy(s, x, y):
        calls.append((s, x, y))
        return pick(s, x, y)

    monkeypatch.setattr("dvr_gl.picking.pick", spy)
    layout = types.SimpleNamespace(image=(0.0, 0.0, 64.0, 64.0))   # 32x32 scene drawn 2x
    viewer = types.SimpleNamespace(scene=scene, cursor=(33.0, 31.0), window_layout=lambda: layout, gesture=None,
                                   controller=types.SimpleNamespace(state="full"), gui=None, probe=PickProbe(),
                                   version=3, log=types.SimpleNamespace(write=lambda **k: None))
    app.Viewer._pick(viewer, now=10.0)
    assert [(c[0] is scene, c[1], c[2]) for c in calls] == [(True, 16.5, 15.5)]
    expected = pick(scene, 16.5, 15.5)
    assert expected.hit and viewer.probe.text == pick_text(expected)
    text = viewer.probe.text
    assert f"{expected.value:.6g}" in text and str(tuple(expected.index)) in text
    assert all(f"{c:.4g}" in text for c in expected.position)
    app.Viewer._pick(viewer, now=11.0)   # resting on the same pixel: no second pick
    assert len(calls) == 1


def test_pick_text_without_a_hit():
    p = pick(small_scene(), 0, 0)
    assert not p.hit and "nothing" in pick_text(p)


# --- annotations ---


def test_annotations_change_only_their_pixels_and_display_their_8bit_codes():
    """The displayed picture, encoded as the display encodes it, equals annotate() on the 8-bit picture
    (within one code: the sRGB decode and OpenImageIO's encode round independently; measured 0); elsewhere
    the float values are untouched."""
    scene = small_scene({"image.width": 160, "image.height": 128})
    rng = np.random.default_rng(1)
    shown = np.concatenate([rng.uniform(0, 1, (128, 160, 3)), np.ones((128, 160, 1))], axis=-1).astype(np.float32)
    out = annotated_display(shown, scene)
    drawn = annotate(encode_8bit(shown), scene, VIEWER_ANNOTATIONS)
    changed = np.any(drawn[..., :3] != encode_8bit(shown)[..., :3], axis=-1)
    assert changed.any() and not changed.all()
    assert np.array_equal(out[~changed], shown[~changed])
    assert np.abs(encode_8bit(out).astype(int) - drawn.astype(int)).max() <= 1


def test_annotated_screenshot_is_8bit_only(tmp_path):
    """A PNG screenshot with annotations differs from one without; an EXR is never annotated."""
    import OpenImageIO as oiio

    scene = small_scene({"image.width": 160, "image.height": 128})
    rgba = np.full((128, 160, 4), 0.5, np.float32)
    plain, _ = write_screenshot(scene, rgba, tmp_path, ".png")
    marked, _ = write_screenshot(scene, rgba, tmp_path, ".png", VIEWER_ANNOTATIONS)
    exr, _ = write_screenshot(scene, rgba, tmp_path, ".exr", VIEWER_ANNOTATIONS)
    read = [oiio.ImageBuf(str(p)).get_pixels(oiio.FLOAT) for p in (plain, marked, exr)]
    assert not np.array_equal(read[0], read[1])
    assert np.allclose(read[2], composite_over(rgba, scene.image.background), atol=1e-3)   # half floats


# --- camera-path recording ---


def test_recorded_keyframes_are_saved_with_the_scene_and_read_back(tmp_path):
    """Three recorded views (keyframe k at k s) go into the screenshot's .toml; loaded again, its path has them
    (the eyes to 1e-9) and plays between them (dvr render FILE.toml --frames N)."""
    scene = small_scene()
    recorder = KeyframeRecorder()
    cameras = [scene.camera, navigation.orbit(scene.camera, 60.0, 0.0), navigation.orbit(scene.camera, 60.0, 40.0)]
    assert recorder.path() is None and "keyframe 1 at 0 s" in recorder.add(cameras[0])
    assert "turn or move" in recorder.add(cameras[0])   # the same view twice: not added
    for c in cameras[1:]:
        recorder.add(c)
    path = recorder.path()
    assert path.times == (0.0, 1.0, 2.0)
    _, toml = write_screenshot(scene.with_camera_path(path), np.zeros((32, 32, 4), np.float32), tmp_path, ".exr")
    again = load_scene(toml).camera_path()
    assert again is not None and again.times == (0.0, 1.0, 2.0)
    for k, c in enumerate(cameras):
        assert np.allclose(again.camera_at(float(k)).eye, c.eye, atol=1e-9)
    assert "3 keyframes cleared" in recorder.clear() and recorder.path() is None


def test_a_mode_without_a_depth_says_why_in_the_status_bar():
    """The average has no depth: the status text is pick's one-line refusal, and the viewer goes on."""
    app = pytest.importorskip("dvr_gl.viewer.app")
    scene = small_scene({"renderer.compositing": "average"})
    layout = types.SimpleNamespace(image=(0.0, 0.0, 32.0, 32.0))
    viewer = types.SimpleNamespace(scene=scene, cursor=(16.0, 16.0), window_layout=lambda: layout, gesture=None,
                                   controller=types.SimpleNamespace(state="full"), gui=None, probe=PickProbe(),
                                   version=0, log=types.SimpleNamespace(write=lambda **k: None))
    app.Viewer._pick(viewer, now=10.0)
    assert viewer.probe.text.startswith("no pick: ") and "average" in viewer.probe.text
