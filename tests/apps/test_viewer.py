"""dvr view without a window: navigation, progressive refinement, transfer-function editing,
settings, HUD numbers, screenshots, and the command's errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import small_scene
from dvr_gl.camera import Camera
from dvr_gl.errors import DvrError, SceneError
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from dvr_gl.transfer_function import TransferFunction
from dvr_gl.viewer import navigation, settings
from dvr_gl.viewer.hud import FrameClock, FrameStats, hud_lines, nominal_samples
from dvr_gl.viewer.keys import help_lines, key_table
from dvr_gl.viewer.layout import (
    PANEL_WIDTH,
    STATUS_HEIGHT,
    fit,
    layout,
    overlaps,
    window_size,
)
from dvr_gl.viewer.refinement import (
    FIRST_GUESS,
    FULL,
    LADDER,
    FramePlan,
    Level,
    RefinementController,
)
from dvr_gl.viewer.screenshots import next_paths, write_screenshot
from dvr_gl.viewer.tf_editor import (
    CanvasMapping,
    TransferFunctionEditor,
    load_points,
    nice_opacity_max,
)
from judges import renderers as declaring


def project(camera: Camera, point, height: int = 200) -> tuple[float, float]:
    """Pixel offset of a world point from the image centre (x right, y down), perspective."""
    f, r, u = camera.basis()
    d = np.asarray(point) - np.asarray(camera.eye)
    scale = height / 2 / math.tan(math.radians(camera.fov) / 2)
    return float(d @ r / (d @ f) * scale), float(-(d @ u) / (d @ f) * scale)


CAMERA = Camera.from_orbit((1.0, 2.0, 3.0), (0.0, 0.0, 1.0), 30.0, 20.0, 10.0)


# --- navigation ---

def test_orbit_grabs_the_volume():
    """Dragging right turns the volume right: the point nearest the viewer moves right on screen."""
    turned = navigation.orbit(CAMERA, 10.0, 0.0)
    assert turned.orbit == pytest.approx((30.0 - 4.0, 20.0, 10.0))
    near = np.asarray(CAMERA.target) + 2.0 * (np.asarray(CAMERA.eye) - CAMERA.target) / 10.0
    x, y = project(turned, near)
    assert x > 1.0 and abs(y) < 1.0
    down = navigation.orbit(CAMERA, 0.0, 10.0)   # dragging down: the near point moves down
    assert down.orbit[1] == pytest.approx(24.0) and project(down, near)[1] > 1.0


def test_orbit_stops_short_of_the_poles():
    assert navigation.orbit(CAMERA, 0.0, 1e4).orbit[1] == navigation.MAX_ELEVATION
    assert navigation.orbit(CAMERA, 0.0, -1e4).orbit[1] == -navigation.MAX_ELEVATION


def test_pan_keeps_the_target_plane_under_the_cursor():
    """The world point at the image centre before a pan is under the cursor's new position after it
    (perspective, 200-pixel-high image), to rounding."""
    moved = navigation.pan(CAMERA, 12.0, -7.0, 200)
    x, y = project(moved, CAMERA.target)
    assert (x, y) == pytest.approx((12.0, -7.0), abs=1e-9)
    assert moved.orbit == pytest.approx(CAMERA.orbit)
    ortho = CAMERA.with_(projection="orthographic", view_height=4.0)
    shifted = np.subtract(navigation.pan(ortho, 50.0, 0.0, 200).target, ortho.target)
    assert np.linalg.norm(shifted) == pytest.approx(50.0 * 4.0 / 200)


def test_zoom_and_projection_toggle():
    assert navigation.zoom(CAMERA, 2).orbit[2] == pytest.approx(10.0 * 0.81)
    assert navigation.zoom(CAMERA, -1).orbit[2] == pytest.approx(10.0 / 0.9)
    ortho = navigation.toggle_projection(CAMERA)
    assert ortho.projection == "orthographic"
    assert ortho.view_height == pytest.approx(2 * 10.0 * math.tan(math.radians(15.0)))
    assert navigation.zoom(ortho, 1).view_height == pytest.approx(ortho.view_height * 0.9)
    back = navigation.toggle_projection(ortho)
    assert back.projection == "perspective" and back.orbit == pytest.approx(CAMERA.orbit)


# --- progressive refinement ---

def test_levels_and_ladder():
    assert FULL.work == 1.0 and Level(2, 2.0).work == 0.125
    assert Level(3, 1.0).image_size(100, 50) == (34, 17)
    works = [lv.work for lv in LADDER]
    assert works == sorted(works, reverse=True) and LADDER[0] == FULL
    assert all(a / b <= 2.25 + 1e-12 for a, b in zip(works, works[1:]))   # no step much beyond halving


def test_interaction_holds_the_budget_from_measured_times():
    c = RefinementController(budget=0.1)
    c.changed(interactive=True)
    plan = c.next_frame()
    assert plan == FramePlan(FIRST_GUESS, 0, interactive=True)   # nothing measured yet
    c.measured(FramePlan(FULL), 1.0, other_seconds=0.02)          # a full frame took 1 s (+ 20 ms)
    c.measured(FramePlan(FULL), 1.0, other_seconds=0.02)
    level = c.interactive_level()
    assert c.predict(level) <= 0.1
    better = LADDER[LADDER.index(level) - 1]
    assert c.predict(better) > 0.1                                # the best level that fits
    c.shown(FramePlan(level, 0, interactive=True))
    assert c.next_frame() is None                                 # held still: nothing new to draw
    c.changed(interactive=True)
    assert c.next_frame().level == level and c.state == "interactive"


def test_fixed_costs_are_interpolated_not_scaled():
    """Measured: full quality 1 s, 1/8 resolution at twice the sample distance (1/128 of the work)
    50 ms, most of it fixed cost.  A level between them is predicted on the line through both (not
    1 s x its work, which would be too optimistic), and one beyond the cheapest proportionally."""
    c = RefinementController(budget=0.1)
    c.measured(FramePlan(FULL), 1.0)
    c.measured(FramePlan(Level(8, 2.0)), 0.05)
    w = Level(4, 2.0).work
    assert c.predict_render(Level(4, 2.0)) == pytest.approx(0.05 + 0.95 * (w - 1 / 128) / (1 - 1 / 128))
    assert c.predict_render(Level(16, 4.0)) == pytest.approx(0.05 * Level(16, 4.0).work * 128)
    assert c.interactive_level() == Level(3, 2.0)   # predicted 96 ms; (2, 2) would take 162 ms
    c.forget_costs()
    assert c.predict(FULL) is None


def test_idle_refines_to_full_quality_and_accumulates_jittered_passes():
    c = RefinementController(budget=0.05, passes=4)
    c.measured(FramePlan(FULL), 0.2)
    c.changed(interactive=True)
    c.shown(c.next_frame())
    c.idle()
    assert c.state == "refining"
    seen = []
    while (plan := c.next_frame()) is not None:
        assert plan.level == FULL and not plan.interactive
        seen.append(plan.jitter_pass)
        c.shown(plan)
        assert c.state == ("full" if len(seen) == 4 else "accumulating")
    assert seen == [0, 1, 2, 3]
    c.changed(interactive=False)                                  # any change starts over
    assert c.next_frame() == FramePlan(FULL, 0) and c.passes_done == 0


def test_slow_renderers_refine_one_level_at_a_time():
    """A full frame predicted at 20 s (a CPU reference): idle frames climb the ladder, each within the
    idle step until the last, and end at full quality."""
    c = RefinementController(budget=0.1, idle_step=1.5)
    c.measured(FramePlan(FULL), 20.0)
    c.changed(interactive=True)
    c.shown(c.next_frame())
    c.idle()
    levels = []
    while (plan := c.next_frame()) is not None and len(levels) < 20:
        levels.append(plan.level)
        c.shown(plan)
    assert levels[-1] == FULL
    ranks = [LADDER.index(lv) for lv in levels]
    assert ranks == sorted(ranks, reverse=True) and len(set(ranks)) == len(ranks)
    assert 20.0 * levels[0].work <= 1.5


def test_first_frame_of_an_unmeasured_renderer_is_cheap():
    c = RefinementController()
    c.changed(interactive=False)
    assert c.next_frame().level == FIRST_GUESS
    c.measured(c.next_frame(), 0.01)
    c.shown(FramePlan(FIRST_GUESS))
    assert c.next_frame().level == FULL


# --- transfer-function editing ---

def editor():
    return TransferFunctionEditor(TransferFunction(np.array([[0.0, 0, 0, 0, 0.0], [1.0, 1, 0.5, 0, 0.4]])))


MAPPING = CanvasMapping(10.0, 20.0, 200.0, 100.0, (0.0, 1.0), 0.5)


def test_canvas_mapping_round_trip():
    assert MAPPING.to_pixel(0.25, 0.5) == (60.0, 20.0)
    assert MAPPING.from_pixel(60.0, 70.0) == pytest.approx((0.25, 0.25))
    assert MAPPING.from_pixel(-100.0, 500.0) == (0.0, 0.0)        # clamped to the canvas


def test_add_move_delete_points():
    e = editor()
    i = e.add(0.5, 0.2)
    assert i == 1 and e.points[1].tolist() == pytest.approx([0.5, 0.5, 0.25, 0.0, 0.2])  # colour interpolated
    assert e.move(1, 2.0, 0.3) == 1 and e.points[1, 0] < 1.0        # clamped below its right neighbour
    assert e.points[1, 0] == pytest.approx(1.0 - 1e-4)
    e.move(1, 0.6, 7.0)
    assert e.points[1, 4] == 1.0                                     # alpha at most 1
    e.move(0, -3.0, 0.0)                                             # the first point moves outward freely
    assert e.points[0, 0] == -3.0
    assert e.pick(MAPPING, *MAPPING.to_pixel(1.0, 0.4)) == 2
    assert e.pick(MAPPING, 300.0, 300.0) is None
    version = e.version
    assert e.delete(1) and len(e.points) == 2 and e.version > version
    assert not e.delete(0)                                           # two points remain
    tf = e.transfer_function()
    assert np.all(np.diff(tf.points[:, 0]) > 0)


def test_recolour_and_add_on_an_existing_value():
    e = editor()
    e.set_color(1, (2.0, 0.3, -1.0))
    assert e.points[1, 1:4].tolist() == [1.0, 0.3, 0.0]
    assert e.add(1.0, 0.1) == 1 and len(e.points) == 2 and e.points[1, 4] == 0.1


def test_save_and_load(tmp_path):
    e = editor()
    e.add(0.3, 0.05)
    path = e.save(tmp_path / "tf.toml")
    loaded = load_points(path)
    assert np.array_equal(loaded.points, e.points)
    with pytest.raises(DvrError, match="exists"):
        e.save(path)                                                  # never replaced
    (tmp_path / "empty.toml").write_text("[camera]\nfov = 20.0\n")
    with pytest.raises(SceneError, match="no \\[transfer_function\\] table"):
        load_points(tmp_path / "empty.toml")
    with pytest.raises(SceneError, match="not found"):
        load_points(tmp_path / "missing.toml")
    (tmp_path / "deep.toml").write_text("[transfer_function]\npoints = " + "[" * 2000 + "]" * 2000 + "\n")
    with pytest.raises(SceneError, match="deep.toml: arrays or tables nested too deeply"):
        load_points(tmp_path / "deep.toml")


def test_nice_opacity_axis():
    assert nice_opacity_max([0.0, 0.12]) == 0.2
    assert nice_opacity_max([0.95]) == 1.0
    assert nice_opacity_max([30.0], "extinction") == 100.0



#: the GL grid renderers, in the registry's order (the viewer's keys)
GRID_GL = declaring(kind="grid", gl=True)


def next_rendering(scene, step: int) -> str:
    """The renderer after (``step`` 1) or before (-1) the scene's, in the registry's order, that can
    render the scene: the one the viewer's renderer key cycles to."""
    names = settings.renderer_names()
    i = names.index(scene.renderer.name)
    around = [names[(i + step * k) % len(names)] for k in range(1, len(names))]
    return next(n for n in around if settings.refusal(scene, name=n) is None)

# --- settings, HUD, keys ---

def test_settings_switch_and_refuse():
    scene = small_scene()
    assert settings.cycle(scene, "compositing").renderer.compositing == "isosurface"
    assert settings.cycle(scene, "name", -1).renderer.name == next_rendering(scene, -1)
    jittered = settings.toggle_jitter(scene)
    with pytest.raises(SceneError, match="jitter"):
        settings.change(jittered, classification="preintegrated")  # the scene file's own check
    fine = settings.set_sample_distance_voxels(scene, 1e-9)
    assert settings.sample_distance_voxels(fine) == settings.MIN_SAMPLE_VOXELS
    assert settings.toggle_shading(scene).renderer.shading.enabled != scene.renderer.shading.enabled
    lit = settings.toggle_scattering(settings.toggle_shading(scene))
    assert lit.renderer.scattering.enabled and not lit.renderer.shading.enabled
    assert not settings.toggle_scattering(lit).renderer.scattering.enabled
    assert "scattering (shadow rays)" in settings.describe(lit)
    turned = settings.turn_light(settings.turn_light(lit, about_up=15.0), about_up=-15.0)
    assert np.allclose(turned.renderer.scattering.lights[0].direction, lit.renderer.scattering.lights[0].direction)
    tilted = settings.turn_light(lit, tilt=90.0).renderer.scattering.lights[0].direction
    up = np.asarray(scene.camera.basis()[2])
    before = np.asarray(lit.renderer.scattering.lights[0].direction)
    assert np.dot(tilted, up) != pytest.approx(np.dot(before, up))
    assert np.linalg.norm(tilted) == pytest.approx(np.linalg.norm(before))
    unlit = next(n for n in GRID_GL if registry.plugin(n).declared("scattering") is None)
    with pytest.raises(SceneError, match=f"{unlit} does not support renderer.scattering"):
        settings.change(lit, name=unlit)
    for name in GRID_GL:  # the fixed planes' text; a sample distance's renderers in their folders
        if registry.plugin(name).fixed_planes:
            assert "voxel plane" in settings.sampling_text(settings.change(scene, name=name))


def test_clip_plane_keys_cut_the_volume_along_the_view():
    """X: a plane facing the eye through the box's centre keeps the far half; Z moves it deeper by 5 %
    of the diagonal (shift+Z back); X again removes it; a renderer without clipping refuses it."""
    from dvr_gl.clipping import ClipRegion

    scene = small_scene()
    cut = settings.toggle_clip_plane(scene)
    (plane,) = cut.renderer.clipping.planes
    forward = np.asarray(scene.camera.basis()[0])
    lo, hi = (np.asarray(b) for b in scene.field.bounds)
    region = ClipRegion.of(cut.renderer)
    centre = (lo + hi) / 2.0
    assert np.allclose(plane[:3], forward)
    assert region.inside(np.array([centre + forward, centre - forward])).tolist() == [True, False]
    deeper = settings.move_clip_plane(cut, 0.05)
    shift = plane[3] - deeper.renderer.clipping.planes[0][3]
    assert shift == pytest.approx(0.05 * np.linalg.norm(hi - lo))
    assert settings.move_clip_plane(deeper, -0.05).renderer.clipping.planes[0][3] == pytest.approx(plane[3])
    assert "clipped by 1 plane" in settings.describe(cut)
    assert not settings.toggle_clip_plane(cut).renderer.clipping.planes
    with pytest.raises(SceneError, match="no plane to move"):
        settings.move_clip_plane(scene, 0.05)
    # a renderer that does not declare clipping refuses the plane (Fourier rendering: a line integral has
    # no per-sample cut); one that declares it takes it, with any filter it declares (the cubic B-spline)
    radiograph = settings.toggle_clip_plane(small_scene({"camera.projection": "orthographic",
                                                         "renderer.compositing": "xray",
                                                         "renderer.classification": "pre"}))
    uncut = [n for n in GRID_GL if registry.plugin(n).declared("clipping") is None]
    assert uncut
    for name in uncut:
        assert f"{name} does not support renderer.clipping" in settings.refusal(radiograph, name=name)
    for name in declaring("clipping", value="cubic_bspline", kind="grid", gl=True):
        if "cubic_bspline" in registry.plugin(name).choices("filter"):
            assert settings.refusal(settings.change(cut, filter="cubic_bspline"), name=name) is None


def test_hud_lines_and_nominal_samples():
    """An orthographic view straight down the y axis of a 32^3 volume (box side 31), view height
    twice the box: the 16 x 16 central pixels of a 32 x 32 image each cross 31 units."""
    scene = small_scene({"camera.projection": "orthographic", "camera.view_height": 62.0, "camera.azimuth": 0.0,
                         "camera.elevation": 0.0, "renderer.sample_distance": 0.5})
    assert nominal_samples(scene) == pytest.approx(16 * 16 * 31 / 0.5)
    stats = FrameStats(render_seconds=0.5, frame_seconds=0.6, samples=1e6, size=(32, 32), state="full",
                       level_text="full resolution")
    lines = hud_lines(scene, stats)
    assert len(lines) == 2 and lines[0].startswith("raycast | ")
    assert lines[1].startswith("full | 32x32 full resolution | frame 600.0 ms = render 500.0 + display 100.0 ms")
    assert "2.0 M samples/s (nominal)" in lines[1]
    assert hud_lines(scene, stats, "a message")[0] == "a message"   # the message takes the settings' line


def test_frame_times_are_one_clock_and_render_within_frame():
    """The frame clock times the render inside the frame, with one clock: render <= frame, and the
    difference is what the frame spent outside the renderer (a fake clock: exact)."""
    ticks = iter([0.0, 10.0, 10.25, 10.75, 11.0])     # made, begin, render from .. to, end
    clock = FrameClock(clock=lambda: next(ticks))
    clock.begin()
    assert clock.render(lambda: "image") == "image"
    render, frame = clock.end()
    assert (render, frame) == (0.5, 1.0)
    stats = FrameStats(render_seconds=render, frame_seconds=frame)
    assert stats.other_seconds == 0.5 and stats.render_seconds <= stats.frame_seconds


# --- the window's layout ---

@pytest.mark.parametrize("fit_image", [None, (512, 512), (384, 384), (1920, 1080), (100, 700)])
@pytest.mark.parametrize("panel, status", [(True, True), (False, True), (True, False), (False, False)])
def test_the_status_bar_and_panel_never_cover_the_image(fit_image, panel, status):
    """At every window size (from 1 x 1 to 2000 x 1500), the status bar, the panel and the image
    are inside the window and do not overlap; the status bar is at most two lines high; a scene
    file's image (fit_image) keeps its aspect (to 1e-9) and is centred in the render area."""
    for w in (1, 100, 359, 361, 600, 872, 2000):
        for h in (1, 39, 41, 300, 552, 1500):
            parts = layout((w, h), panel, status, fit_image)
            rects = [r for r in (parts.image, parts.panel, parts.status) if r is not None]
            for r in rects:
                assert r[0] >= 0 and r[1] >= 0 and r[0] + r[2] <= w and r[1] + r[3] <= h and min(r[2:]) >= 0
            for i, a in enumerate(rects):
                for b in rects[i + 1:]:
                    assert not overlaps(a, b), (w, h, a, b)
            assert (parts.status is not None) == status and (parts.panel is not None) == panel
            if status:
                assert parts.status[3] <= STATUS_HEIGHT and parts.status[1] + parts.status[3] == h
            if fit_image and parts.image[3] > 0:
                x, y, iw, ih = parts.image
                assert iw / ih == pytest.approx(fit_image[0] / fit_image[1], rel=1e-9)
                ax, ay, aw, ah = parts.area
                assert (x - ax) == pytest.approx(ax + aw - x - iw) and (y - ay) == pytest.approx(ay + ah - y - ih)
            elif not fit_image:
                assert parts.image == parts.area


def test_window_sizes_at_start():
    """The image follows the window: its render area is the size asked.  A scene file's image: a render
    area of its aspect at least 512 high, never more than it needs, and within the monitor."""
    assert window_size((512, 512), panel=True, status=True, fit_image=False) == (512 + PANEL_WIDTH, 512 + STATUS_HEIGHT)
    assert window_size((240, 240), panel=False, status=False, fit_image=False) == (240, 240)
    assert window_size((256, 128), True, True, fit_image=True) == (1024 + PANEL_WIDTH, 512 + STATUS_HEIGHT)
    assert window_size((700, 600), True, True, fit_image=True) == (700 + PANEL_WIDTH, 600 + STATUS_HEIGHT)
    w, h = window_size((4000, 3000), True, True, fit_image=True, limit=(1920, 1080))
    assert w <= 1920 and h <= 1080 and (w - PANEL_WIDTH) / (h - STATUS_HEIGHT) == pytest.approx(4 / 3, rel=1e-2)
    assert fit((256, 128), (0, 0, 512, 512)) == (0, 128, 512, 256)


def test_every_key_has_an_action_and_help():
    """Keys 1 to 9, then 0, choose the first ten registered renderers, from the registry; shifted, the
    next ten."""
    table = key_table()
    names = {k for k, _, _ in table}
    assert {"S", "R", "P", "F1", "1"} <= names
    from dvr_gl.renderers import registry
    chosen = [action.removeprefix("renderer_") for _, action, _ in table if action.startswith("renderer_")]
    assert chosen == registry.names()[:20]
    keys = [k for k, action, _ in table if action.startswith("renderer_")]
    assert keys[:11] == [*"1234567890", "shift+1"][:len(keys[:11])]
    assert any("screenshot" in line for line in help_lines())


# --- screenshots ---

def test_screenshot_paths_are_numbered_and_never_reused(tmp_path):
    assert next_paths(tmp_path)[0].name == "dvr_view_0001.png"
    (tmp_path / "dvr_view_0001.toml").write_text("")
    image, scene = next_paths(tmp_path, ".exr")
    assert (image.name, scene.name) == ("dvr_view_0002.exr", "dvr_view_0002.toml")
    with pytest.raises(DvrError, match="format"):
        next_paths(tmp_path, ".bmp")


def test_screenshot_scene_loads_back(tmp_path):
    scene = small_scene({"camera.azimuth": 77.0})
    rgba = np.zeros((32, 32, 4), dtype=np.float32)
    image, toml = write_screenshot(scene, rgba, tmp_path, ".exr")
    again = load_scene(toml)
    assert again.camera.orbit == pytest.approx(scene.camera.orbit)
    assert (again.image.width, again.image.height) == (32, 32) and image.is_file()


# --- the command's errors (no window needed) ---

def test_no_display_is_one_line(monkeypatch, capsys):
    from dvr_gl.apps.cli import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", "--demo"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == ("dvr view: error: cannot open a window: no display (DISPLAY is unset); run under a desktop "
                   "session or Xvfb, or use `dvr render` for headless images")


def test_bad_volume_gets_the_render_error(monkeypatch, capsys, tmp_path):
    from dvr_gl.apps.cli import main

    monkeypatch.setenv("DISPLAY", ":9999")  # never opened: the volume fails first
    bad = tmp_path / "v.raw"
    bad.write_bytes(b"\0" * 10)
    assert main(["view", "--volume", str(bad), "--dims", "4", "4", "4", "--dtype", "uint8"]) == 1
    view_err = capsys.readouterr().err.strip()
    assert main(["render", "--volume", str(bad), "--dims", "4", "4", "4", "--dtype", "uint8",
                 "-o", str(tmp_path / "x.png")]) == 1
    render_err = capsys.readouterr().err.strip()
    assert view_err.removeprefix("dvr view: ") == render_err.removeprefix("dvr render: ")
    assert "\n" not in view_err and "Traceback" not in view_err


@pytest.fixture
def opened(monkeypatch):
    """``dvr view`` up to the window: the scene and options it would open, no window."""
    from dvr_gl.viewer import app

    seen = []
    monkeypatch.setenv("DISPLAY", ":9999")
    monkeypatch.setattr(app, "check_display", lambda: None)
    monkeypatch.setattr(app, "run_viewer", lambda scene, options: seen.append((scene, options)) or 0)
    return seen


def test_the_render_area_is_512_square_by_default(opened, tmp_path):
    """The demo and a volume file (as --volume or where the scene file goes): a 512 x 512 render area
    that follows the window; --size: the size given; a scene file: its own image size, drawn scaled
    to fit (the window is then at least 512 high: test_window_sizes_at_start)."""
    from dvr_gl.apps.cli import main

    volume = tmp_path / "v.npy"
    np.save(volume, np.zeros((4, 5, 6), np.float32))
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(f'[volume]\npath = "{volume.name}"\n[image]\nwidth = 300\nheight = 200\n')
    cases = [(["--demo", "--set", "volume.size=8"], (512, 512), False),
             (["--volume", str(volume)], (512, 512), False),
             ([str(volume)], (512, 512), False),
             (["--volume", str(volume), "--size", "200x100"], (200, 100), False),
             ([str(scene_file)], (300, 200), True),
             ([str(scene_file), "--size", "64"], (64, 64), False)]
    for args, size, fit_image in cases:
        assert main(["view", *args]) == 0, args
        scene, options = opened.pop()
        assert ((scene.image.width, scene.image.height), options.fit) == (size, fit_image), args


def test_render_only_flags_are_refused(monkeypatch, capsys):
    from dvr_gl.apps.cli import main

    monkeypatch.setenv("DISPLAY", ":9999")
    assert main(["view", "--demo", "-o", "x.png"]) == 1
    assert "--output belongs to dvr render" in capsys.readouterr().err


def test_a_display_that_cannot_be_opened_is_one_line():
    """DISPLAY names no X server: GLFW cannot start; one line, exit status 1, no traceback."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, DISPLAY=":9999")
    env.pop("WAYLAND_DISPLAY", None)
    proc = subprocess.run([sys.executable, "-m", "dvr_gl.apps.cli", "view", "--demo", "--set", "volume.size=8"],
                          capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dvr view: error: cannot open a window: GLFW could not start")
    assert ":9999" in lines[0]


def test_refusals_are_known_before_rendering():
    """The panel greys out what the renderer refuses, asking the registry (no rendering): pre-integration
    where a renderer does not declare it, MIP likewise; cycling skips a refused choice to the next one that
    renders."""
    shaded = small_scene({"renderer.shading.enabled": True, "renderer.classification": "preintegrated"})
    perspective = [n for n in GRID_GL if "perspective" in registry.plugin(n).projections]
    for name in perspective:
        why = settings.refusal(shaded, name=name)
        if "preintegrated" in registry.plugin(name).choices("classification"):
            assert why is None, why
        else:
            assert f"{name} does not support renderer.classification = 'preintegrated'" in why
    assert any(settings.refusal(shaded, name=n) for n in perspective)  # one is skipped below
    no_mip = next(n for n in perspective if "mip" not in registry.plugin(n).choices("compositing")
                  and settings.refusal(shaded, name=n) is None)
    sliced = settings.change(shaded, name=no_mip)
    assert settings.refusal(sliced, compositing="mip").startswith(f"{no_mip} does not support renderer.compositing")
    after = settings.cycle(sliced, "name").renderer.name
    assert after == next_rendering(sliced, 1)
    assert settings.choices("name") == tuple(settings.renderer_names())
    for name in settings.renderer_names():
        assert settings.fixed_planes(name) == registry.plugin(name).fixed_planes


# --- the help overlay and the preset box (what a new user hit) ---

@pytest.mark.parametrize("window", [(1, 1), (40, 30), (300, 200), (600, 280), (872, 552), (2000, 1500)])
@pytest.mark.parametrize("content", [(10.0, 10.0), (700.0, 680.0), (5000.0, 5000.0)])
def test_the_help_lies_inside_the_window(window, content):
    """F1's box is inside the window at any window size (it was centred on the image and ran off the left
    edge, hiding every key name), centred on the render area where it fits, never larger than its content."""
    from dvr_gl.viewer.layout import help_rect

    parts = layout(window, panel=True, status=True)
    x, y, w, h = help_rect(window, parts.image, content)
    assert 0 <= x and 0 <= y and x + w <= window[0] and y + h <= window[1]
    assert 0 <= w <= content[0] and 0 <= h <= content[1]
    if content[0] <= parts.image[2] and content[1] <= parts.image[3]:
        ax, ay, aw, ah = parts.image
        assert (x + w / 2, y + h / 2) == pytest.approx((ax + aw / 2, ay + ah / 2))


def test_the_preset_box_names_the_current_preset_or_custom():
    """The name of the preset a function is (over the field's range, with the CT intercept), or "custom"."""
    from dvr_gl.transfer_function import PRESETS, preset
    from dvr_gl.viewer.tf_editor import preset_name

    for name in list(PRESETS)[:8]:   # dvr-gl's own, then 3D Slicer's (CT: placed with the intercept)
        assert preset_name(preset(name, (0.0, 3000.0), -1024.0), (0.0, 3000.0), -1024.0) == name
    editor = TransferFunctionEditor(preset("viridis", (0.0, 1.0)))
    assert preset_name(editor.transfer_function(), (0.0, 1.0), hint="viridis") == "viridis"
    editor.add(0.5, 0.7)
    assert preset_name(editor.transfer_function(), (0.0, 1.0), hint="viridis") == "custom"
    assert preset_name(preset("viridis", (0.0, 1.0)), (0.0, 2.0)) == "custom"   # another range: not that preset
