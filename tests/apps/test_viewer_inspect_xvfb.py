"""Picking, annotations and camera-path recording in a real dvr view window under Xvfb, driven by X input
(XTEST; see test_viewer_xvfb.py).  Skips, saying why, without Xvfb or libXtst."""

from __future__ import annotations

import time

import numpy as np
from test_viewer_xvfb import SIZE, ViewerProcess

from dvr_gl.picking import pick
from dvr_gl.scene.resolve import load_scene
from dvr_gl.viewer.inspect import pick_text


def _shifted(x, name: str):
    """Press ``name`` with the left shift key held."""
    shift = x.x11.XKeysymToKeycode(x.display, x.x11.XStringToKeysym(b"Shift_L"))
    x.xtst.XTestFakeKeyEvent(x.display, shift, 1, 0)
    x._sync()
    x.key(name)
    x.xtst.XTestFakeKeyEvent(x.display, shift, 0, 0)
    x._sync()


def _events(v, name: str) -> list[dict]:
    return [r for r in v.records() if r.get("event") == name]


def test_pick_annotations_and_a_recorded_path(xvfb, tmp_path):
    """A resting cursor is picked once, with exactly dvr_gl.pick's words for the saved scene's pixel; A changes
    the shown picture (the colour bar, scale bar and axes); two keyframes (shift+K) go into the screenshot's
    scene as a path that reads back with the two views."""
    v = ViewerProcess(xvfb, tmp_path, "--budget", "5", "--set", "renderer.compositing=mip")
    try:
        v.wait(lambda rs: any(r.get("event") == "layout" for r in rs), "the window")
        v.wait_full()
        v.x.move(SIZE * 0.45, SIZE * 0.55)
        picked = v.wait(lambda rs: next((r for r in rs if r.get("event") == "pick" and r["x"] > 50), None),
                        "a pick where the cursor rests")
        _, first = v.screenshot()   # moves the cursor to the centre: another pick, of the same scene
        expected = pick(load_scene(first), picked["x"], picked["y"])
        assert expected.hit and picked["text"] == pick_text(expected)

        before = v.x.capture(0, 0, SIZE, SIZE)
        frame = v.last_frame()
        v.x.key("a")
        v.wait(lambda rs: _events(v, "annotations"), "annotations on")
        v.wait_full(frame)
        time.sleep(0.2)
        assert np.any(v.x.capture(0, 0, SIZE, SIZE) != before)

        _shifted(v.x, "k")
        v.wait(lambda rs: len(_events(v, "keyframe")) == 1, "keyframe 1")
        frame = v.last_frame()
        v.x.drag(1, (100, 120), (150, 120))
        v.wait_full(frame)
        _shifted(v.x, "k")
        v.wait(lambda rs: len(_events(v, "keyframe")) == 2, "keyframe 2")
        _, second = v.screenshot()
        path = load_scene(second).camera_path()
        assert path is not None and path.times == (0.0, 1.0)
        assert np.allclose(path.camera_at(0.0).eye, load_scene(first).camera.eye, atol=1e-9)
        assert np.allclose(path.camera_at(1.0).eye, load_scene(second).camera.eye, atol=1e-9)
    finally:
        v.close()
    assert v.proc.returncode == 0, (tmp_path / "viewer.out").read_text()[-2000:]
