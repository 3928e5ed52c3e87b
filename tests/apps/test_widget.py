"""The notebook widget (``dvr_gl.widget``, dvr_gl/jupyter): a picture, pointer and wheel navigation with
progressive refinement, the controls, the scene and snapshot, and the same in a real Jupyter kernel.

Events are jupyter_rfb's own dicts, given to ``handle_event`` (in-process) or to the widget's comm handler (in
the kernel), as a browser would send them.  After a gesture the frame shown is compared with
``dvr_gl.render`` of the widget's scene: bit-identical, as measured (the same renderer on the same scene and
GL; a coarse frame is never left on screen).  The extra ``widget`` (jupyter_rfb, ipywidgets) is needed; the
kernel test also needs the extra ``notebook`` (nbclient, ipykernel); each is skipped, saying why, without them.
"""

from __future__ import annotations

import asyncio
import json
import sys

import numpy as np
import pytest

import dvr_gl

pytest.importorskip("jupyter_rfb", reason="jupyter_rfb: pip install -e '.[widget]'")
pytest.importorskip("ipywidgets", reason="ipywidgets: pip install -e '.[widget]'")
pytestmark = pytest.mark.usefixtures("gl_context")

SIZE = 48


def blob(n=20):
    z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    return (np.exp(-4 * ((x - 0.35) ** 2 + y ** 2 + z ** 2)) + 0.6 * np.exp(-12 * (x ** 2 + (y - 0.4) ** 2 + z ** 2))
            ).astype(np.float32)


def event(kind, x=SIZE / 2, y=SIZE / 2, button=1, modifiers=(), **more):
    return {"type": kind, "x": x, "y": y, "button": button, "buttons": [button], "modifiers": list(modifiers),
            "timestamp": 0.0, **more}


def drag(view, dx, dy=0, steps=4, **press):
    """Press, move in ``steps`` and release; the frames drawn while moving (their plans)."""
    view.handle_event(event("pointer_down", **press))
    plans = []
    for k in range(1, steps + 1):
        view.handle_event(event("pointer_move", SIZE / 2 + dx * k / steps, SIZE / 2 + dy * k / steps, **press))
        view.get_frame()
        plans.append(view.last_plan)
    view.handle_event(event("pointer_up", SIZE / 2 + dx, SIZE / 2 + dy, **press))
    return plans


def full(view):
    """The frames after a gesture, until the picture is final (the last one)."""
    for _ in range(20):
        frame = view.get_frame()
        if view.refined:
            return frame
    raise AssertionError("the widget never refined to full quality")


def rendered(scene):
    return dvr_gl.render(scene).srgb8()[..., :3]


@pytest.fixture
def view():
    # a budget no frame fits, so that dragging is coarse however quiet the machine (a tiny full frame fits 0.1 s)
    w = dvr_gl.widget(blob(), size=SIZE, budget=0.002)
    yield w
    w.close()


def test_a_picture_that_turns_and_refines_to_the_rendered_image(view):
    first = view.get_frame()
    assert first.shape == (SIZE, SIZE, 3) and first.dtype == np.uint8
    background = np.round(255 * np.asarray(view.scene.image.background[:3]) ** (1 / 2.2))
    assert (np.abs(first.astype(int) - background).max(axis=-1) > 8).mean() > 0.05  # the blob covers the middle
    np.testing.assert_array_equal(first, rendered(view.scene))
    azimuth = view.scene.camera.orbit[0]
    plans = drag(view, dx=30)
    assert all(p.interactive for p in plans) and not plans[0].level.full  # coarse while dragging
    assert view.scene.camera.orbit[0] == pytest.approx(azimuth - 30 * 0.4)  # the viewer's 0.4 degree a pixel
    final = full(view)
    assert view.last_plan.level.full and not np.array_equal(final, first)
    np.testing.assert_array_equal(final, rendered(view.scene))  # measured: identical
    np.testing.assert_array_equal(view.snapshot().srgb8()[..., :3], final)


def test_pan_and_wheel(view):
    target = np.array(view.scene.camera.target)
    drag(view, dx=10, button=2)
    assert np.linalg.norm(np.array(view.scene.camera.target) - target) > 0
    distance = view.scene.camera.orbit[2]
    view.handle_event(event("wheel", dx=0, dy=-100))  # one notch away from the user: nearer, as the viewer
    assert view.scene.camera.orbit[2] == pytest.approx(0.9 * distance)
    np.testing.assert_array_equal(full(view), rendered(view.scene))  # no event loop: the wheel gesture ends at once


def test_odd_events_change_nothing(view):
    before = view.scene
    for odd in ({"type": "pointer_down", "button": 1, "x": float("nan"), "y": 0}, {"type": "pointer_move", "x": "a"},
                {"type": "wheel", "dy": float("inf")}, {"type": "wheel", "dy": "x"}, {"type": "resize", "width": -3},
                {"type": "key_down", "key": "a"}, {"type": "pointer_up"}):
        view.handle_event(odd)
    assert view.scene is before and view.get_frame() is not None
    editor = view.controls.editor
    for odd in ({"type": "pointer_down", "button": 1, "x": float("nan"), "y": 0}, {"type": "pointer_down", "x": "a"},
                {"type": "double_click"}, {"type": "resize", "width": -3}, {"type": "pointer_up"}):
        editor.handle_event(odd)
    assert view.scene is before and editor.get_frame() is not None


def test_the_controls_change_the_scene(view):
    c = view.controls
    tf = view.scene.transfer_function
    c.opacity.value = 2.0
    np.testing.assert_allclose(view.scene.transfer_function.points[:, 4], np.minimum(2 * tf.points[:, 4], 1))
    c.opacity.value = 1.0
    c.level.value = c.level.value + 0.1
    np.testing.assert_allclose(view.scene.transfer_function.points[:, 0], tf.points[:, 0] + 0.1)
    c.preset.value = "viridis"
    assert len(view.scene.transfer_function.points) > 10
    others = [n for n in c.renderer.options if n != view.scene.renderer.name]
    kinds = {n: dvr_gl.registry.plugin(n).data_kinds for n in dvr_gl.registry.names()}
    assert list(c.renderer.options) == [n for n, k in kinds.items() if k is None or "grid" in k]  # those taking grids
    c.renderer.value = others[0]
    assert view.scene.renderer.name == others[0]
    c.sample.value = 1.0
    assert view.scene.renderer.sample_distance == pytest.approx(view.scene.field.sample_spacing)
    if c.clip in c.panel.children:
        c.clip.value = True
        assert len(view.scene.renderer.clipping.planes) == 1
        d = view.scene.renderer.clipping.planes[0][3]
        c.clip_at.value = 0.2
        assert view.scene.renderer.clipping.planes[0][3] < d
    np.testing.assert_array_equal(full(view), rendered(view.scene))


def test_a_refused_setting_keeps_the_scene_and_says_why(view):
    def refuse(scene):
        raise dvr_gl.SceneError("renderer.x: refused")

    before = view.scene
    assert not view.apply(refuse)
    assert view.scene is before and "refused" in view.message and "refused" in view.controls.status.value


def test_time_and_channels():
    series = np.stack([blob(), blob()[:, ::-1].copy()])
    w = dvr_gl.widget(series, time_axis=0, size=24)
    w.add_keyframe()
    w.controls.time.value = 1
    np.testing.assert_array_equal(w.scene.field.data, series[1])
    w.add_keyframe()
    assert w.camera_path.steps == (0, 1)  # a recorded path goes through the steps shown
    w.close()
    channels = np.stack([blob(), blob()[::-1].copy()], axis=-1)
    w = dvr_gl.widget(channels, channel_axis=3, size=24)
    assert w.controls.field in w.controls.panel.children
    w.controls.field.value = 1
    w.controls.opacity.value = 3.0
    tfs = w.scene.transfer_functions
    assert tfs[1].points[:, 4].max() > tfs[0].points[:, 4].max()
    editor = w.controls.editor   # the drawn editor follows the chosen field, and edits its function only
    np.testing.assert_array_equal(editor.editor.points, tfs[1].points)
    editor.handle_event(event("pointer_down", 30, 20))
    assert len(w.scene.transfer_functions[1].points) == len(tfs[1].points) + 1
    np.testing.assert_array_equal(w.scene.transfer_functions[0].points, tfs[0].points)
    w.close()


def test_the_scene_is_savable(tmp_path):
    scene = dvr_gl.load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 24, "image.width": 24,
                                     "image.height": 24})
    w = dvr_gl.widget(scene)
    w.handle_event(event("wheel", dx=0, dy=-200))
    path = tmp_path / "view.toml"
    path.write_text(w.scene.to_toml())
    np.testing.assert_array_equal(rendered(dvr_gl.load_scene(path)), full(w))
    w.close()


def test_without_the_extra_one_line_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "jupyter_rfb", None)
    with pytest.raises(dvr_gl.DvrError, match=r"pip install -e '\.\[widget\]'"):
        dvr_gl.widget(blob())
    import subprocess

    script = "import sys, dvr_gl; print(sorted({'jupyter_rfb', 'ipywidgets'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "[]", out  # import dvr_gl never needs the extra


KERNEL_CELLS = [
    """import asyncio, json, time
import numpy as np
import dvr_gl
z, y, x = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
w = dvr_gl.widget(np.exp(-4 * ((x - 0.35) ** 2 + y ** 2 + z ** 2)).astype(np.float32), size=48,
                  budget=0.002)  # coarse frames while dragging even on a quiet machine (48x48 is cheap)
w""",
    # what a browser does: show a view, send events through the comm, confirm each frame it receives
    """w._has_visible_views = True
def browser(seconds):
    end = time.time() + seconds
    async def run():
        while time.time() < end:
            w._frame_feedback = {"index": w._rfb_frame_index, "timestamp": time.time(), "localtime": time.time()}
            await asyncio.sleep(0.02)
    return run()
def send(kind, x, y, **more):
    w._handle_custom_msg({"type": kind, "x": x, "y": y, "button": 1, "buttons": [1], "modifiers": [],
                          "timestamp": time.time(), **more}, [])
w._handle_custom_msg({"type": "resize", "width": 48, "height": 48, "pwidth": 48, "pheight": 48, "ratio": 1.0,
                      "timestamp": time.time()}, [])
await browser(1.0)
first, azimuth = w._rfb_last_frame.copy(), w.scene.camera.orbit[0]""",
    """send("pointer_down", 24, 24)
levels = []
for k in range(1, 6):
    send("pointer_move", 24 + 5 * k, 24)
    await browser(0.3)
    levels.append(w.last_plan.level.block)
send("pointer_up", 49, 24)
await browser(2.0)
final = w._rfb_last_frame
print(json.dumps({"turned": w.scene.camera.orbit[0] - azimuth, "levels": levels, "refined": w.refined,
                  "changed": bool((final != first).any()),
                  "same_as_render": bool(np.array_equal(final, dvr_gl.render(w.scene).srgb8()[..., :3]))}))""",
]


def test_in_a_real_kernel():
    nbformat = pytest.importorskip("nbformat", reason="nbformat/nbclient/ipykernel: pip install -e '.[notebook]'")
    nbclient = pytest.importorskip("nbclient", reason="nbclient: pip install -e '.[notebook]'")
    pytest.importorskip("ipykernel", reason="ipykernel: pip install -e '.[notebook]'")
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in KERNEL_CELLS])
    nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3").execute()
    outputs = notebook.cells[-1].outputs
    result = json.loads(next(o["text"] for o in outputs if o.get("name") == "stdout"))
    assert result["turned"] == pytest.approx(-25 * 0.4)
    assert result["changed"] and result["refined"] and result["same_as_render"], result
    assert max(result["levels"]) > 1, result  # coarse frames while dragging
    shown = notebook.cells[0].outputs[-1]["data"]
    assert "application/vnd.jupyter.widget-view+json" in shown and "image/png" in shown


def test_the_bench_prints_its_table(capsys):
    """``dvr bench widget`` runs on a tiny scene and prints one row per renderer (timings not asserted)."""
    from dvr_gl.apps.cli import main

    default = dvr_gl.load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 16}).renderer.name
    assert main(["bench", "widget", "--size", "32", "--volume-size", "16", "--moves", "3", "--warm-up", "2",
                 "--renderer", default]) == 0
    row = next(line.split() for line in capsys.readouterr().out.splitlines() if line.startswith(default + " "))
    assert float(row[2]) > 0 and float(row[-1]) >= 0  # frames a second while dragging; release to full image


def test_a_hidpi_screen_gets_physical_pixels(view):
    """A resize event with pixel ratio 2 (a HiDPI screen; jupyter_rfb's old events say ``pixel_ratio``, its new
    ones ``ratio``) renders the image at twice the CSS size, the frame is that size, a pointer's CSS pixel maps
    to the image pixel under it, and a drag turns by CSS pixels (0.4 degree each, as at ratio 1); a ratio above
    ``max_pixel_ratio`` (default 2) is capped, and a ratio of 1 goes back to the CSS size."""
    view.handle_event({"type": "resize", "width": 40, "height": 30, "pixel_ratio": 2.0})
    assert (view.scene.image.width, view.scene.image.height) == (80, 60) and view.pixel_ratio == 2.0
    assert full(view).shape == (60, 80, 3)
    assert view.image_pixel(10.0, 15.0) == pytest.approx((20.0, 30.0))
    assert view.pick(10.0, 15.0) == dvr_gl.pick(view.scene, 20.0, 30.0)
    azimuth = view.scene.camera.orbit[0]
    drag(view, dx=10)
    assert view.scene.camera.orbit[0] == pytest.approx(azimuth - 10 * 0.4)
    view.handle_event({"type": "resize", "width": 40, "height": 30, "ratio": 3.0})
    assert (view.scene.image.width, view.scene.image.height) == (80, 60) and view.pixel_ratio == 2.0
    view.handle_event({"type": "resize", "width": 40, "height": 30, "ratio": 1.0})
    assert (view.scene.image.width, view.scene.image.height) == (40, 30)
    capped = dvr_gl.widget(blob(), size=SIZE, max_pixel_ratio=1.5)
    capped.handle_event({"type": "resize", "width": 40, "height": 30, "pixel_ratio": 2.0})
    assert (capped.scene.image.width, capped.scene.image.height) == (60, 45)
    capped.close()
    with pytest.raises(dvr_gl.DvrError, match="max_pixel_ratio"):
        dvr_gl.widget(blob(), size=SIZE, max_pixel_ratio=0.5)


def test_the_resting_pointer_is_picked(view):
    """A move with no button down picks at once here (no event loop); the status line and ``pick`` say what
    ``dvr_gl.pick`` says at the same image pixel (the widget's CSS pixels are the image's: same size)."""
    # a pixel whose ray is well past half opacity (alpha 0.66; the one at (24.3, 21.4) sat at 0.50, on the edge)
    x, y = SIZE / 2 + 3.3, SIZE / 2 - 0.6
    view.handle_event(event("pointer_move", x, y, buttons=[]))
    expected = dvr_gl.pick(view.scene, x, y)
    assert expected.hit and view.picked == expected == view.pick(x, y)
    assert f"{expected.value:.5g}" in view.controls.status.value and str(expected.index) in view.pick_text
    view.handle_event({"type": "resize", "width": SIZE / 2, "height": SIZE / 2})   # a smaller box, before the frame
    assert view.image_pixel(x / 2, y / 2) == pytest.approx((x / 2 * view.scene.image.width / (SIZE / 2),
                                                            y / 2 * view.scene.image.height / (SIZE / 2)))


def test_the_pick_waits_for_the_pointer_to_rest(view):
    """With an event loop (a kernel) the pick comes ``PICK_REST`` seconds after the last move with no button
    down, and never once a button is pressed: a drag never waits for a pick."""
    from dvr_gl.jupyter.canvas import PICK_REST

    async def hover():
        view.handle_event(event("pointer_move", 20, 20, buttons=[]))
        view.handle_event(event("pointer_move", 24, 25, buttons=[]))
        assert view.picked is None   # the pointer may go on moving
        await asyncio.sleep(PICK_REST + 0.1)
        rested = view.picked
        view.handle_event(event("pointer_move", 30, 30, buttons=[]))
        view.handle_event(event("pointer_down", 30, 30))
        await asyncio.sleep(PICK_REST + 0.1)
        return rested

    rested = asyncio.run(hover())
    assert rested == dvr_gl.pick(view.scene, 24, 25) and view.picked is rested


def test_annotations_only_inside_their_boxes():
    from dvr_gl.annotations import Annotations, layout

    w = dvr_gl.widget(blob(), size=128)
    plain, rgba = w.get_frame().copy(), w.snapshot().rgba.copy()
    marks = Annotations(colorbar=True, scalebar=True, axes=True, caption="blob")
    w.controls.caption.value = "blob"
    for box in w.controls.marks.values():
        box.value = True
    assert w.annotations == marks
    shown = w.get_frame()
    inside = np.zeros(plain.shape[:2], bool)
    for x0, y0, x1, y1 in layout(w.scene, marks).values():
        inside[y0:y1, x0:x1] = True
    changed = (shown != plain).any(axis=-1)
    assert changed.any() and not changed[~inside].any()
    np.testing.assert_array_equal(w.annotated()[..., :3], shown)
    np.testing.assert_array_equal(w.snapshot().rgba, rgba)   # the float image has none
    w.close()


def test_a_recorded_camera_path_is_saved_with_the_scene(tmp_path):
    scene = dvr_gl.load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 24,
                                     "image.height": 24})
    w = dvr_gl.widget(scene)
    w.controls.keyframe.click()
    assert w.camera_path is None and w.scene.camera_path() is None
    drag(w, dx=20, dy=-8)
    w.handle_event(event("wheel", dx=0, dy=-100))
    w.controls.keyframe.click()
    first, second = w.keyframes
    path = w.camera_path
    assert path.times == (0.0, 1.0) and path.camera_at(0) == first and path.camera_at(1) == second
    saved = tmp_path / "path.toml"
    saved.write_text(w.scene.to_toml())
    back = dvr_gl.load_scene(saved).camera_path()
    for t, camera in ((0, first), (1, second)):
        np.testing.assert_allclose(back.camera_at(t).eye, camera.eye, rtol=0, atol=1e-9)
        np.testing.assert_allclose(back.camera_at(t).target, camera.target, rtol=0, atol=1e-9)
    w.controls.clear.click()
    assert w.camera_path is None and w.scene.camera_path() is None
    w.close()


def test_the_drawn_editor_adds_moves_and_deletes_points(view):
    """The editor's pixels map to (value, opacity) in closed form: value = lo + x / W (hi - lo), opacity =
    (1 - y / h) top (h: the curve's height above the colour strip, top: the opacity axis, held during a drag).
    Each edit is the scene's transfer function at once (and the preset box says "custom"); the picture after it
    is the rendered image of that scene (bit-identical, as the other controls)."""
    c = view.controls
    e = c.editor
    before = view.scene.transfer_function.points.copy()
    m = e.mapping()
    (lo, hi), top = m.value_range, m.opacity_max
    x, y = 0.5 * m.width, 0.2 * m.height
    assert e.editor.pick(m, x, y) is None    # empty space
    e.handle_event(event("pointer_down", x, y))
    points = view.scene.transfer_function.points
    assert len(points) == len(before) + 1 and c.preset.value == "custom"
    i = e.dragging
    np.testing.assert_allclose(points[i, [0, 4]], [lo + 0.5 * (hi - lo), 0.8 * top], rtol=1e-12)
    dx, dy = 18.0, 9.0
    e.handle_event(event("pointer_move", x + dx, y + dy))
    e.handle_event(event("pointer_up", x + dx, y + dy))
    moved = view.scene.transfer_function.points
    np.testing.assert_allclose(moved[i, [0, 4]] - points[i, [0, 4]], [dx / m.width * (hi - lo), -dy / m.height * top],
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(full(view), rendered(view.scene))
    e.handle_event(event("pointer_down", *m.to_pixel(*moved[i, [0, 4]]), button=2))   # right click: delete
    np.testing.assert_array_equal(view.scene.transfer_function.points, before)
    e.handle_event(event("double_click", *m.to_pixel(*before[0, [0, 4]])))            # two points remain
    assert len(view.scene.transfer_function.points) == 2 and "two points" in view.message


def test_the_drawn_editor_shows_the_curve_and_colours(view):
    """At a column between two points the curve's row is where the function's opacity there maps to; the strip
    below has the function's colour there (sRGB, 8 bits)."""
    from dvr_gl.jupyter.tf_canvas import CURVE
    from dvr_gl.transfer_function import linear_to_srgb

    e = view.controls.editor
    frame, m = e.get_frame(), e.mapping()
    points = view.scene.transfer_function.points
    assert frame.shape == (e.size[1], e.size[0], 3)
    (lo, hi), column = m.value_range, e.size[0] // 3
    value = lo + (column + 0.5) / m.width * (hi - lo)
    row = int(round(m.to_pixel(value, np.interp(value, points[:, 0], points[:, 4]))[1] - 0.5))
    assert (frame[row, column] == CURVE).all()
    assert not (frame[:row - 1, column] == CURVE).all(axis=-1).any()   # nothing of the curve above it
    colour = [np.interp(value, points[:, 0], points[:, k]) for k in (1, 2, 3)]
    np.testing.assert_array_equal(frame[-1, column], np.round(255 * linear_to_srgb(np.array(colour))))
