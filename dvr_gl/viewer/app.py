"""The viewer's window and loop: input to scene changes, the refinement controller's plan to
frames, frames to the screen.

The window holds the *render area* (top left) and, with imgui-bundle installed, a side panel
(right) and a status bar (the HUD, bottom), never over the image (:mod:`.layout`).  For the demo,
a volume file or ``--size``, the render area's size in framebuffer pixels is the scene's image
size and follows the window; a scene file's image keeps the file's size and is drawn scaled to
fit (``ViewerOptions.fit``).  Either way a screenshot's saved scene has the size it was rendered
at.  Every renderer draws
into the window's own OpenGL context (the CPU references render on the host).  Images are
premultiplied and linear; the background is composited once, before display or writing, as in
``dvr render``.

A frame log (``--frame-log FILE``) records one JSON object per line: every rendered frame (its
refinement level, times, state) and the events (window ready with its layout, screenshots,
messages), for profiling and for driving the viewer from tests.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import DvrError, install_hint
from ..image import composite_over
from ..renderers import create_renderer, registry
from ..transfer_function_2d import is_2d
from . import navigation, settings
from .display import ImageDisplay
from .hud import FrameClock, FrameStats, hud_lines, nominal_samples
from .imgui_backend import load_imgui
from .inspect import VIEWER_ANNOTATIONS, KeyframeRecorder, PickProbe, annotated_display, cursor_pixel, pick_text
from .keys import help_lines, key_table
from .layout import Layout, layout, window_size
from .refinement import FramePlan, RefinementController, plan_scene
from .screenshots import write_screenshot
from .tf_editor import TransferFunctionEditor
from .tf_editor_2d import BoxEditor2D, BoxTransferFunction2D, renders_2d
from .timeline import Player, at_step, editable, next_editable, with_transfer_function

imgui = load_imgui()  # before glfw: imgui-bundle points pyGLFW at the GLFW library it ships
import glfw  # noqa: E402

TIMED_GESTURE_SECONDS = 0.3  # wheel and window resizing count as interaction until this long after
MESSAGE_SECONDS = 8.0
NO_DISPLAY = ("cannot open a window: no display (DISPLAY is unset); run under a desktop session or Xvfb, "
              "or use `dvr render` for headless images")


@dataclass
class ViewerOptions:
    """How the viewer runs (the scene says what it shows).

    budget_ms: frame-time budget while interacting, milliseconds.
    passes: jittered passes averaged when idle (with jitter on).
    screenshot_dir, screenshot_format: where screenshots go, and their suffix (.png, .exr, .tif).
    frame_log: a JSON-lines file of frames and events (None: none).
    gui: panels and HUD through imgui-bundle when installed.
    rescale_intercept: for the CT presets in the transfer-function panel (HU = data + intercept).
    benchmark: seconds of a simulated orbit drag, then refinement to full quality, a summary of
        the frame times on stdout, and exit (None: interactive).
    fit: keep the scene's image size (a scene file's) and draw the image scaled to fit the render
        area, which is at least :data:`.layout.MIN_AREA` pixels high at start; False: the image
        size follows the render area (the demo, a volume file, ``--size``).
    time_steps, read_step, time_step: a time series: its number of steps, ``read_step(k)``, the scene at step
        ``k`` (:mod:`.timeline`), and the step the scene shows at start; one step: no time.
    """

    budget_ms: float = 100.0
    passes: int = 8
    screenshot_dir: Path = Path(".")
    screenshot_format: str = ".png"
    frame_log: Path | None = None
    gui: bool = True
    rescale_intercept: float = 0.0
    benchmark: float | None = None
    fit: bool = False
    time_steps: int = 1
    read_step: Callable[[int], object] | None = None
    time_step: int = 0
    frames: list = field(default_factory=list)  # filled with the frame records (benchmarks, tests)


def check_display():
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise DvrError(NO_DISPLAY)


def _work_area() -> tuple[int, int] | None:
    """The primary monitor's work area (width, height), window pixels; None if unknown."""
    monitor = glfw.get_primary_monitor()
    if not monitor:
        return None
    _, _, w, h = glfw.get_monitor_workarea(monitor)
    return (w, h) if w > 0 and h > 0 else None


def open_window(image: tuple[int, int], gui: bool, fit: bool, title: str):
    """A GLFW window with an OpenGL 3.3 core context, current; DvrError with the reason if none."""
    check_display()
    errors: list[str] = []
    glfw.ERROR_REPORTING = "ignore"
    glfw.set_error_callback(lambda code, text: errors.append(text.decode() if isinstance(text, bytes) else text))
    if not glfw.init():
        why = errors[-1] if errors else "unknown reason"
        raise DvrError(f"cannot open a window: GLFW could not start ({why}); run under a desktop session or "
                       f"Xvfb, or use `dvr render` for headless images")
    for hint, value in ((glfw.CONTEXT_VERSION_MAJOR, 3), (glfw.CONTEXT_VERSION_MINOR, 3),
                        (glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE), (glfw.OPENGL_FORWARD_COMPAT, True)):
        glfw.window_hint(hint, value)
    width, height = window_size(image, panel=gui, status=gui, fit_image=fit, limit=_work_area() if fit else None)
    window = glfw.create_window(width, height, title, None, None)
    if not window:
        why = errors[-1] if errors else "unknown reason"
        glfw.terminate()
        raise DvrError(f"cannot open a window: no OpenGL 3.3 window could be created ({why}); update the "
                       f"graphics driver (Debian: apt install libgl1-mesa-dri), or use `dvr render`")
    glfw.make_context_current(window)
    glfw.swap_interval(0)
    return window


def run_viewer(scene, options: ViewerOptions | None = None) -> int:
    """Open the window on ``scene`` and run until it is closed."""
    viewer = Viewer(scene, options or ViewerOptions())
    try:
        viewer.run()
    finally:
        viewer.close()
    return 0


class FrameLog:
    """JSON lines (see the module doc); nothing when no path is given."""

    def __init__(self, path: Path | None):
        self.file = open(path, "w", encoding="utf-8") if path else None
        self.start = time.perf_counter()

    def write(self, **record):
        if self.file:
            record["t"] = round(time.perf_counter() - self.start, 4)
            self.file.write(json.dumps(record) + "\n")
            self.file.flush()

    def close(self):
        if self.file:
            self.file.close()


def _key_table() -> dict:
    table = {}
    for name, action, _ in key_table():
        shift, _, key = name.rpartition("+")
        table[(getattr(glfw, f"KEY_{key}"), bool(shift))] = action
    return table


class Viewer:
    """One window on one scene (see the module doc)."""

    def __init__(self, scene, options: ViewerOptions):
        self.options = options
        self.gui_module = imgui if options.gui else None
        self.window = open_window((scene.image.width, scene.image.height), self.gui_module is not None,
                                  options.fit, "dvr view")
        try:
            self._start(scene, options)
        except BaseException:
            glfw.destroy_window(self.window)
            glfw.terminate()
            raise

    def _start(self, scene, options: ViewerOptions):
        from ..gl.context import create_context

        self.ctx = create_context("window")
        self.display = ImageDisplay(self.ctx)
        self.scene = self.good_scene = scene
        self.initial_camera = scene.camera
        # the field whose transfer function the editor edits: the first that has a curve (None: only label maps)
        fields = editable(scene.layers)
        self.field_index = fields[0] if fields else 0
        self.editor = TransferFunctionEditor(scene.layers[self.field_index].transfer_function) if fields else None
        self.tf_version = self.editor.version if self.editor is not None else 0
        self.tf_unchosen = False  # the scene's transfer function was set while dragging (settings not chosen for it)
        self.tf_mode, self.editor_2d, self.tf2d_version = "1d", None, 0   # the 2D editor: opened when asked for
        self.player = (Player(options.time_steps, options.read_step, step=options.time_step)
                       if options.time_steps > 1 else None)
        self.controller = RefinementController(options.budget_ms / 1e3, self._passes(scene))
        self.renderers: dict = {}
        self.stats = FrameStats()             # the last frame presented, complete: what the HUD shows
        self.clock = FrameClock()
        self._frame_info: dict = {}
        self.version = 0                      # counts scene changes
        self.full_image: tuple[int, np.ndarray] | None = None   # (version, pass-0 full-quality image)
        self.accum: np.ndarray | None = None  # running mean of the jittered passes shown
        self.gesture: str | None = None
        self.cursor = (0.0, 0.0)
        self.gesture_until = 0.0
        self.last_event = time.perf_counter()
        self.message, self.message_error, self.message_until = "", False, 0.0
        self.show_hud, self.show_help, self.show_panel = True, False, self.gui_module is not None
        self.probe, self.recorder = PickProbe(), KeyframeRecorder()   # I: picking; shift+K: keyframes
        self.annotations_on = False           # A: annotations over the picture and 8-bit screenshots
        self.running = True
        self.stalled = -1                     # the version whose rendering failed with no way back
        self.frame_count = 0
        self.log = FrameLog(options.frame_log)
        if fields and is_2d(scene.layers[self.field_index].transfer_function):
            self._open_2d()   # a scene with a 2D function opens in the 2D editor (its boxes, where it has them)
        self.keys = _key_table()
        self.benchmark = OrbitBenchmark(options.benchmark) if options.benchmark else None
        self.gui = None
        if self.gui_module is not None:
            from .gui import ViewerGui

            self.gui = ViewerGui(self.gui_module, glfw, self.ctx, self)
        self._install_callbacks()
        self._sync_size()
        if self.gui is None:
            print(f"dvr view: keys ({install_hint('viewer')} for the panels and the transfer-function editor):")
            print("\n".join("  " + line for line in help_lines()))

    # --- scene changes ---

    def _passes(self, scene) -> int:
        return self.options.passes if scene.renderer.jitter else 1

    def set_scene(self, scene, interactive: bool = False, costs: bool = False):
        """Show ``scene`` from now on; ``costs``: its frames cost differently (measure again)."""
        self.scene = scene
        self.version += 1
        self.accum = None
        self.controller.changed(interactive)
        self.controller.set_passes(self._passes(scene))
        if costs:
            self.controller.forget_costs()

    def apply(self, change, interactive: bool = False) -> bool:
        """Apply ``change(scene) -> scene`` to the renderer settings; on a DvrError (a value out of range,
        or a setting the renderer refuses: :mod:`.settings` asks the registry before anything renders)
        show it and keep the settings as they were."""
        try:
            scene = change(self.scene)
        except DvrError as exc:
            self.notify(f"{exc}; keeping {self.scene.renderer.name} with the previous settings", error=True)
            return False
        self.set_scene(scene, interactive, costs=True)
        return True

    def move_camera(self, camera, interactive: bool = True):
        self.set_scene(self.scene.replace(camera=camera), interactive)

    def end_gesture(self):
        self.controller.idle()

    def notify(self, text: str, error: bool = False):
        self.message, self.message_error = text, error
        self.message_until = time.perf_counter() + MESSAGE_SECONDS
        print(f"dvr view: {'error: ' if error else ''}{text}", file=sys.stderr if error else sys.stdout, flush=True)
        self.log.write(event="message", error=error, text=text)

    def _sync_editor(self):
        if self.tf_mode == "2d":
            self._sync_editor_2d()
            return
        dragging = self.gui is not None and self.gui.busy
        if self.editor is None or (self.editor.version == self.tf_version and (dragging or not self.tf_unchosen)):
            return
        self.tf_version = self.editor.version
        try:
            tf = self.editor.transfer_function()
        except DvrError as exc:
            self.notify(str(exc), error=True)
            return
        # while dragging, the settings chosen for the transfer function before stay (choosing costs 0.1-0.3 s);
        # they are chosen for the one let go of
        self.tf_unchosen = dragging
        self.set_scene(with_transfer_function(self.scene, self.field_index, tf, choose_again=not dragging),
                       interactive=dragging)

    # --- the 2D transfer function (value x gradient magnitude) ---

    def offers_2d(self) -> bool:
        """Whether the current renderer declares a 2D transfer function for the scene's kind of data (its
        trait ``transfer_function_2d``) and the edited field is a grid in memory (its histogram is drawn)."""
        field = self.edited_field if self.editor is not None else None
        return (field is not None and not getattr(field, "out_of_core", False) and hasattr(field, "data")
                and renders_2d(self.scene.renderer.name, getattr(self.scene.field, "kind", "grid")))

    def _saved_boxes(self, tf):
        """``tf`` as a :class:`BoxTransferFunction2D` where the scene file gave it as boxes (one field)."""
        spec = getattr(getattr(self.scene, "spec", None), "transfer_function", None)
        boxes = getattr(spec, "boxes_2d", None)
        if getattr(tf, "boxes", ()) or not boxes or len(self.scene.layers) > 1:
            return tf
        return BoxTransferFunction2D.of(boxes, tf.value_range, tf.gradient_range, tf.shape, tf.unit_distance)

    def _open_2d(self) -> bool:
        """The 2D editor on the edited field (its boxes where its function was drawn from boxes)."""
        layer = self.scene.layers[self.field_index]
        tf = layer.transfer_function
        try:
            self.editor_2d = BoxEditor2D.for_field(layer.field, self._saved_boxes(tf) if is_2d(tf) else None)
        except (DvrError, ValueError, MemoryError) as exc:
            self.notify(f"no 2D transfer function editor for {layer.field.name}: {exc}", error=True)
            return False
        self.tf_mode, self.tf2d_version = "2d", self.editor_2d.version
        return True

    def set_tf_mode(self, mode: str):
        """Edit a 1D (value) or 2D (value x gradient magnitude) transfer function; the field's function becomes
        the chosen editor's (a new 2D editor's: none, until a box is added).  Refused, in the status bar, where
        the renderer does not declare the trait or the settings rule a 2D function out."""
        if mode == self.tf_mode:
            return
        if mode == "2d":
            if not self.offers_2d():
                self.notify(f"{self.scene.renderer.name} does not classify this data with a 2D transfer function; "
                            f"the 1D editor stays", error=True)
                return
            if self.editor_2d is None and not self._open_2d():
                return
            tf = self.editor_2d.transfer_function
        else:
            tf = self.editor.transfer_function()
        if self._use_transfer_function(tf):
            self.tf_mode = mode
            self.log.write(event="tf_mode", mode=mode)

    def _use_transfer_function(self, tf, interactive: bool = False) -> bool:
        """Show the edited field with ``tf``, unless the registry refuses the scene (said in the status bar)."""
        scene = with_transfer_function(self.scene, self.field_index, tf)
        reason = registry.refusal(scene)
        if reason is not None:
            self.notify(f"{reason}; keeping the transfer function as it was", error=True)
            return False
        self.set_scene(scene, interactive=interactive, costs=is_2d(tf) != is_2d(self.scene.layers[
            self.field_index].transfer_function))
        return True

    def _sync_editor_2d(self):
        if self.editor_2d is None or self.editor_2d.version == self.tf2d_version:
            return
        self.tf2d_version = self.editor_2d.version
        self._use_transfer_function(self.editor_2d.transfer_function,
                                    interactive=self.gui is not None and self.gui.busy)

    @property
    def edited_field(self):
        """The field whose transfer function the editor edits (its values: the histogram, the presets' range)."""
        return self.scene.layers[self.field_index].field

    def next_field(self):
        """Edit the next field's transfer function (several fields; a label map's table is not a curve)."""
        layers = self.scene.layers
        i = next_editable(layers, self.field_index)
        if i == self.field_index:
            self.notify("no other field's transfer function to edit" if len(layers) > 1 else
                        "one field: its transfer function is the one edited", error=len(layers) > 1)
            return
        self._sync_editor()  # the edits made so far go to the field they were made for
        self.field_index = i
        self.editor = TransferFunctionEditor(layers[i].transfer_function)
        self.tf_version = self.editor.version
        self.tf_mode, self.editor_2d = "1d", None
        if is_2d(layers[i].transfer_function):
            self._open_2d()
        self.notify(f"editing field {i + 1} of {len(layers)}: {layers[i].name or layers[i].field.name} "
                    f"({layers[i].role})")

    # --- time ---

    def time_step(self, delta: int):
        """Show the step ``delta`` steps on (wrapping), read now; a step that cannot be read is shown as an
        error and the step shown stays."""
        if self.player is None:
            self.notify("no time steps: the data is one 3D field", error=True)
            return
        before = self.player.step
        try:
            stepped = self.options.read_step(self.player.go(delta))
        except DvrError as exc:
            self.notify(f"time step {self.player.step}: {exc}; showing step {before}", error=True)
            self.player.step, self.player.presented, self.player.playing = before, True, False
            return
        self.set_scene(at_step(self.scene, stepped), interactive=self.player.playing)
        self.log.write(event="time_step", step=self.player.step, steps=self.player.steps)

    def toggle_play(self):
        if self.player is None:
            self.notify("no time steps: the data is one 3D field", error=True)
            return
        playing = self.player.toggle(time.perf_counter())
        self.log.write(event="play" if playing else "pause", step=self.player.step)

    def _sync_time(self, now: float):
        if self.player is not None and self.player.tick(now):
            self.time_step(1)

    def status(self) -> str:
        """The HUD's time step and edited field, where there are several."""
        parts = [self.player.describe()] if self.player is not None else []
        parts += [p for p in (self.recorder.describe(), self.probe.text) if p]
        layers = self.scene.layers
        if len(layers) > 1:
            layer = layers[self.field_index]
            parts.append(f"editing {layer.name or layer.field.name} (N: next field)")
        return " | ".join(parts)

    # --- window geometry ---

    def window_layout(self) -> Layout:
        """The window's parts now (:func:`.layout.layout`), window pixels."""
        gui = self.gui is not None
        image = (self.scene.image.width, self.scene.image.height) if self.options.fit else None
        return layout(glfw.get_window_size(self.window), panel=gui and self.show_panel,
                      status=gui and self.show_hud, image=image)

    def framebuffer_scale(self) -> tuple[float, float]:
        """Framebuffer pixels per window pixel, x and y (HiDPI)."""
        win_w, win_h = glfw.get_window_size(self.window)
        fb_w, fb_h = glfw.get_framebuffer_size(self.window)
        return (fb_w / win_w if win_w else 1.0), (fb_h / win_h if win_h else 1.0)

    def render_area(self) -> tuple[int, int, int, int]:
        """``(width, height)`` of the render area in window pixels, then in framebuffer pixels."""
        _, _, w, h = self.window_layout().area
        sx, sy = self.framebuffer_scale()
        return int(w), int(h), max(1, round(w * sx)), max(1, round(h * sy))

    def _sync_size(self):
        if self.options.fit:   # the scene's own size, drawn scaled to fit
            return
        _, _, w, h = self.render_area()
        image = self.scene.image
        if h > 0 and (w, h) != (image.width, image.height):
            resized = self.scene.replace(image=dataclasses.replace(image, width=w, height=h))
            self.set_scene(resized, interactive=self.frame_count > 0, costs=True)
            self.good_scene = self.good_scene.replace(image=resized.image)
            self.gesture_until = time.perf_counter() + TIMED_GESTURE_SECONDS

    def in_render_area(self, x: float, y: float) -> bool:
        """Whether a window point is on the image."""
        ix, iy, iw, ih = self.window_layout().image
        return ix <= x < ix + iw and iy <= y < iy + ih

    # --- input ---

    def _install_callbacks(self):
        w = self.window
        glfw.set_cursor_pos_callback(w, self._on_cursor)
        glfw.set_cursor_enter_callback(w, self._on_cursor_enter)
        glfw.set_mouse_button_callback(w, self._on_button)
        glfw.set_scroll_callback(w, self._on_scroll)
        glfw.set_key_callback(w, self._on_key)
        glfw.set_char_callback(w, self._on_char)

    def _on_cursor(self, window, x, y):
        self.last_event = time.perf_counter()
        if self.gui:
            self.gui.input.cursor(x, y)
        dx, dy = x - self.cursor[0], y - self.cursor[1]
        self.cursor = (x, y)
        self.probe.moved(self.last_event)
        if self.gesture and (dx or dy):
            self.navigate(self.gesture, dx, dy)

    def _on_cursor_enter(self, window, entered):
        """The cursor left the window (or came back): the panel forgets (or finds) it, so that nothing stays
        hovered (the status bar's tooltip used to stay over the image after the cursor left by the bottom)."""
        self.last_event = time.perf_counter()
        if self.gui:
            if entered:
                self.gui.input.cursor(*glfw.get_cursor_pos(window))
            else:
                self.gui.input.leave()

    def navigate(self, gesture: str, dx: float, dy: float):
        """A drag of ``(dx, dy)`` window pixels: ``orbit``, ``pan`` or ``zoom``."""
        cam = self.scene.camera
        if gesture == "orbit":
            cam = navigation.orbit(cam, dx, dy)
        elif gesture == "pan":   # the image's height on screen: the cursor's point stays under it
            cam = navigation.pan(cam, dx, dy, self.window_layout().image[3])
        else:
            cam = navigation.zoom(cam, -dy / 20.0)   # 20 pixels up: one wheel step in
        self.move_camera(cam)

    def _on_button(self, window, button, action, mods):
        self.last_event = time.perf_counter()
        if self.gui:
            self.gui.input.button(button, action == glfw.PRESS)
        if action == glfw.PRESS and self.gesture is None and self.in_render_area(*self.cursor):
            shift = bool(mods & glfw.MOD_SHIFT)
            self.gesture = {glfw.MOUSE_BUTTON_LEFT: "pan" if shift else "orbit", glfw.MOUSE_BUTTON_MIDDLE: "pan",
                            glfw.MOUSE_BUTTON_RIGHT: "zoom"}.get(button)
            self.gesture_button = button
        elif action == glfw.RELEASE and self.gesture and button == self.gesture_button:
            self.gesture = None
            self.end_gesture()

    def _on_scroll(self, window, dx, dy):
        self.last_event = time.perf_counter()
        if self.gui:
            self.gui.input.scroll(dx, dy)
        if dy and self.in_render_area(*self.cursor):
            self.move_camera(navigation.zoom(self.scene.camera, dy))
            self.gesture_until = time.perf_counter() + TIMED_GESTURE_SECONDS

    def _on_key(self, window, key, scancode, action, mods):
        self.last_event = time.perf_counter()
        if self.gui:
            self.gui.input.key(key, action)
            if self.gui.input.wants_text:
                return
        if action == glfw.RELEASE:
            return
        shift = bool(mods & glfw.MOD_SHIFT)
        name = self.keys.get((key, shift)) or self.keys.get((key, False))
        repeatable = ("finer", "coarser", "next_step", "previous_step")
        if name and (action == glfw.PRESS or name in repeatable):
            self.action(name)

    def _on_char(self, window, codepoint):
        if self.gui:
            self.gui.input.char(codepoint)

    # --- actions (keys and buttons) ---

    def action(self, name: str):
        if name.startswith("renderer_"):
            self.apply(lambda s: settings.change(s, name=name.removeprefix("renderer_")))
            return
        simple = {
            "next_compositing": lambda: self.apply(lambda s: settings.cycle(s, "compositing")),
            "next_classification": lambda: self.apply(lambda s: settings.cycle(s, "classification")),
            "next_filter": lambda: self.apply(lambda s: settings.cycle(s, "filter")),
            "toggle_shading": lambda: self.apply(settings.toggle_shading),
            "toggle_scattering": lambda: self.apply(settings.toggle_scattering),
            "light_left": lambda: self.apply(lambda s: settings.turn_light(s, about_up=-15.0)),
            "light_right": lambda: self.apply(lambda s: settings.turn_light(s, about_up=15.0)),
            "light_down": lambda: self.apply(lambda s: settings.turn_light(s, tilt=-15.0)),
            "light_up": lambda: self.apply(lambda s: settings.turn_light(s, tilt=15.0)),
            "toggle_clip_plane": lambda: self.apply(settings.toggle_clip_plane),
            "clip_deeper": lambda: self.apply(lambda s: settings.move_clip_plane(s, 0.05)),
            "clip_back": lambda: self.apply(lambda s: settings.move_clip_plane(s, -0.05)),
            "toggle_jitter": lambda: self.apply(settings.toggle_jitter),
            "finer": lambda: self.apply(lambda s: settings.scale_sample_distance(s, 1 / 1.5)),
            "coarser": lambda: self.apply(lambda s: settings.scale_sample_distance(s, 1.5)),
            "toggle_projection": lambda: self.move_camera(navigation.toggle_projection(self.scene.camera), False),
            "toggle_play": self.toggle_play,
            "next_step": lambda: self.time_step(1),
            "previous_step": lambda: self.time_step(-1),
            "next_field": self.next_field,
            "reset_view": lambda: self.move_camera(self.initial_camera, False),
            "screenshot": self.screenshot,
            "toggle_pick": self.toggle_pick,
            "toggle_annotations": self.toggle_annotations,
            "add_keyframe": self.add_keyframe,
            "clear_keyframes": lambda: self.notify(self.recorder.clear()),
            "toggle_hud": lambda: setattr(self, "show_hud", not self.show_hud),
            "toggle_panel": self._toggle_panel,
            "toggle_help": lambda: setattr(self, "show_help", not self.show_help),
            "quit": self.quit,
        }
        simple[name]()

    def _toggle_panel(self):
        if self.gui is not None:
            self.show_panel = not self.show_panel

    def quit(self):
        self.running = False

    def screenshot(self) -> tuple[Path, Path] | None:
        """Write the full-quality image of the current scene and the scene (see :mod:`.screenshots`)."""
        scene = self.scene
        if self.full_image is not None and self.full_image[0] == self.version:
            rgba = self.full_image[1]
        else:
            try:
                rgba = self._renderer(scene.renderer.name).render(scene)
            except DvrError as exc:
                self.notify(f"screenshot not taken: {exc}", error=True)
                return None
        try:
            annotations = VIEWER_ANNOTATIONS if self.annotations_on else None
            paths = write_screenshot(self.saved_scene(), rgba, Path(self.options.screenshot_dir),
                                     self.options.screenshot_format, annotations)
        except DvrError as exc:
            self.notify(f"screenshot not written: {exc}", error=True)
            return None
        self.log.write(event="screenshot", image=str(paths[0]), scene=str(paths[1]))
        self.notify(f"wrote {paths[0]} and {paths[1].name}")
        return paths

    # --- rendering ---

    def _renderer(self, name: str):
        if name not in self.renderers:
            self.renderers[name] = create_renderer(name, ctx=self.ctx)  # GL renderers draw in the window's context
        return self.renderers[name]

    def frame_scene(self, plan: FramePlan):
        """The scene a frame of ``plan`` renders (:func:`~dvr_gl.viewer.refinement.plan_scene`)."""
        return plan_scene(self.scene, plan)

    def render(self, plan: FramePlan) -> float | None:
        """Render and show a frame of ``plan``; the seconds it took in the renderer (None if refused)."""
        scene = self.frame_scene(plan)
        try:
            renderer = self._renderer(scene.renderer.name)
            rgba = self.clock.render(lambda: renderer.render(scene))   # read back: the GPU has finished
            seconds = self.clock.render_seconds
        except DvrError as exc:
            self._refused(exc)
            return None
        self.good_scene = self.scene
        if self.player is not None:
            self.player.presented = True
        if plan.level.full and plan.jitter_pass and self.accum is not None:
            self.accum += (rgba - self.accum) / (plan.jitter_pass + 1)
        else:
            self.accum = rgba.copy() if plan.level.full else None
        if plan.level.full and plan.jitter_pass == 0:
            self.full_image = (self.version, rgba)
        shown = composite_over(self.accum if self.accum is not None else rgba, self.scene.image.background)
        # annotations on full-resolution frames only (about 0.1 s at 512x512 here): a drag never waits for them
        self.display.upload(self._annotated(shown, scene) if plan.level.full else shown)
        samples = renderer.stats.get("samples")
        self._frame_info = {"measured_samples": samples is not None,
                            "samples": float(samples) if samples is not None else nominal_samples(scene),
                            "size": (scene.image.width, scene.image.height)}
        return seconds

    def _annotated(self, shown: np.ndarray, scene) -> np.ndarray:
        """The displayed picture, annotated when A is on (an image too small for them: said, and A off)."""
        if not self.annotations_on:
            return shown
        try:
            return annotated_display(shown, scene)
        except DvrError as exc:
            self.annotations_on = False
            self.notify(f"annotations off: {exc}", error=True)
            return shown

    def toggle_annotations(self):
        self.annotations_on = not self.annotations_on
        self.set_scene(self.scene)   # redrawn with (or without) them
        self.log.write(event="annotations", on=self.annotations_on)

    def toggle_pick(self):
        self.probe.enabled = not self.probe.enabled
        self.notify(f"picking under the cursor {'on' if self.probe.enabled else 'off'} (I)")

    def add_keyframe(self):
        step = self.player.step if self.player is not None else None
        self.notify(self.recorder.add(self.scene.camera, step))
        self.log.write(event="keyframe", keyframes=len(self.recorder.cameras))

    def saved_scene(self):
        """The scene a screenshot saves: the current one, with the recorded camera path when it has two
        keyframes or more (``dvr render FILE.toml --frames N`` plays it)."""
        path = self.recorder.path()
        return self.scene if path is None else self.scene.with_camera_path(path)

    def _pick(self, now: float):
        """Pick under a resting cursor (:class:`.inspect.PickProbe`): one float64 ray of the full-size scene."""
        scene = self.scene
        pixel = cursor_pixel(self.cursor, self.window_layout().image, (scene.image.width, scene.image.height))
        dragging = (self.gesture is not None or self.controller.state == "interactive"
                    or (self.gui is not None and self.gui.busy))
        if not self.probe.due(now, pixel, self.version, dragging):
            return
        from ..picking import pick

        try:
            text = pick_text(pick(scene, *pixel))
        except (DvrError, ValueError, NotImplementedError, MemoryError) as exc:   # a hover never ends the viewer
            text = f"no pick: {exc}"
        self.probe.show(pixel, self.version, text)
        self.log.write(event="pick", x=pixel[0], y=pixel[1], text=text)

    def _refused(self, exc: DvrError):
        """A renderer refused the settings: say why, and go back to the last settings that rendered."""
        if self.scene.renderer != self.good_scene.renderer:
            self.notify(f"{exc}; keeping {self.good_scene.renderer.name} with the previous settings", error=True)
            self.set_scene(self.scene.replace(renderer=self.good_scene.renderer), costs=True)
        elif self.full_image is None:  # the scene as given never rendered: refuse it, as dvr render does
            raise exc
        else:  # nothing to go back to: wait for the next change
            self.notify(str(exc), error=True)
            self.stalled = self.version

    def _level_text(self, plan: FramePlan) -> str:
        lv = plan.level
        parts = [f"1/{lv.block} resolution" if lv.block > 1 else "full resolution"]
        if lv.distance_factor != 1:
            parts.append(f"{lv.distance_factor:g}x sample distance")
        if self.controller.passes > 1:
            parts.append(f"pass {plan.jitter_pass + 1}/{self.controller.passes}")
        return ", ".join(parts)

    # --- the loop ---

    def run(self):
        self.log.write(event="ready", **self.layout())
        while self.running and not glfw.window_should_close(self.window):
            self.step()

    def layout(self) -> dict:
        """The window's parts for the frame log: window pixels, and the image's size in pixels."""
        parts = self.window_layout()
        out = {"window": list(parts.window), "render_area": [round(v, 1) for v in parts.area],
               "image_rect": [round(v, 1) for v in parts.image],
               "image": [self.scene.image.width, self.scene.image.height]}
        for name in ("panel", "status"):
            rect = getattr(parts, name)
            if rect is not None:
                out[name] = [round(v, 1) for v in rect]
        if self.gui is not None and self.gui.tf_canvas is not None and self.show_panel:
            out["tf_canvas"] = [round(v, 1) for v in self.gui.tf_canvas]
        if self.gui is not None and self.show_panel:
            out["panel_scroll"] = self.gui.panel_scroll
            out["tf_mode"] = self.tf_mode
            out["preset"] = self.gui.preset_shown
            if self.gui.switch_2d is not None:
                out["tf_switch_2d"] = [round(v, 1) for v in self.gui.switch_2d]
            if self.gui.help_box is not None:
                out["help"] = [round(v, 1) for v in self.gui.help_box]
            if self.tf_mode == "2d" and self.editor_2d is not None:
                out["tf_ranges_2d"] = [*self.editor_2d.value_range, *self.editor_2d.gradient_range]
        return out

    def step(self):
        """One pass of the loop: events, at most one rendered frame, the window redrawn."""
        start = time.perf_counter()
        busy = ((self.controller.next_frame() is not None and self.stalled != self.version) or self.gesture is not None
                or self.benchmark is not None or (self.player is not None and self.player.playing))
        if busy or start - self.last_event < 1.0:
            glfw.poll_events()
        else:
            glfw.wait_events_timeout(0.25)
        self.clock.begin()
        start = self.clock.started
        if self.benchmark:
            self.benchmark.step(self)
        if self.gesture is None and start > self.gesture_until and self.controller.state == "interactive" \
                and not (self.gui is not None and self.gui.busy):
            self.end_gesture()
        self._sync_size()
        self._sync_editor()
        self._sync_time(start)
        plan = self.controller.next_frame() if self.stalled != self.version else None
        seconds = self.render(plan) if plan is not None else None
        self._pick(start)
        self.draw()   # the HUD shows self.stats: the last frame presented before this one
        if plan is not None and seconds is not None:
            seconds, total = self.clock.end()
            self.controller.measured(plan, seconds, total - seconds)
            self.controller.shown(plan)
            shown = self.stats
            self.stats = FrameStats(render_seconds=seconds, frame_seconds=total, state=self.controller.state,
                                    level_text=self._level_text(plan), **self._frame_info)
            self._record(plan, seconds, total, shown)
        self._update_title()

    def _record(self, plan: FramePlan, seconds: float, total: float, shown: FrameStats):
        """Log the frame, and the times the HUD showed while drawing it (the frame before)."""
        self.frame_count += 1
        record = {"frame": self.frame_count, "state": self.controller.state, "interactive": plan.interactive,
                  "block": plan.level.block, "distance_factor": plan.level.distance_factor,
                  "jitter_pass": plan.jitter_pass, "passes": self.controller.passes,
                  "width": self.stats.size[0], "height": self.stats.size[1], "renderer": self.scene.renderer.name,
                  "render_ms": round(seconds * 1e3, 3), "frame_ms": round(total * 1e3, 3),
                  "hud_render_ms": round(shown.render_seconds * 1e3, 3),
                  "hud_frame_ms": round(shown.frame_seconds * 1e3, 3)}
        self.options.frames.append(record)
        self.log.write(**record)

    def draw(self):
        fb_w, fb_h = glfw.get_framebuffer_size(self.window)
        if fb_w <= 0 or fb_h <= 0:
            return
        x, y, w, h = self.window_layout().image
        sx, sy = self.framebuffer_scale()
        win_h = glfw.get_window_size(self.window)[1]
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, fb_w, fb_h)
        self.ctx.clear(0.08, 0.08, 0.09, 1.0)
        # GL's viewport counts from the bottom left, in framebuffer pixels
        self.display.draw((round(x * sx), round((win_h - y - h) * sy), max(1, round(w * sx)), max(1, round(h * sy))))
        if self.gui is not None:
            self.gui.frame()
        glfw.swap_buffers(self.window)

    def hud_lines(self) -> list[str]:
        message = self.current_message()
        return hud_lines(self.scene, self.stats, message[0] if message else None, self.status())

    def current_message(self) -> tuple[str, bool] | None:
        if self.message and time.perf_counter() < self.message_until:
            return self.message, self.message_error
        return None

    def _update_title(self):
        state = self.controller.state
        if state == "accumulating":
            state = f"accumulating {self.controller.passes_done}/{self.controller.passes}"
        title = f"dvr view: {self.scene.field.name} | {self.scene.renderer.name} | {state}"
        if self.player is not None:
            title += f" | {self.player.describe()}"
        if self.gui is None:   # no status bar: the title has the frame time and the pick
            title += f" | {self.stats.frame_seconds * 1e3:.0f} ms"
            title += f" | {self.probe.text}" if self.probe.text else ""
        if title != getattr(self, "_title", None):
            glfw.set_window_title(self.window, title)
            self._title = title

    def close(self):
        for renderer in self.renderers.values():
            renderer.close()
        self.renderers.clear()
        if self.gui is not None:
            self.gui.close()
        self.display.release()
        self.log.close()
        glfw.destroy_window(self.window)
        glfw.terminate()


class OrbitBenchmark:
    """``--benchmark SECONDS``: wait for the first full-quality frame, then orbit as a steady left
    drag would (:data:`STEP_PIXELS` per frame) for the given seconds, release, wait for full quality,
    print the frame times and exit."""

    STEP_PIXELS = 6.0

    def __init__(self, seconds: float):
        self.seconds = seconds
        self.phase = "warmup"
        self.first = self.settle = 0     # indices of the first orbit and the first settling frame
        self.until = 0.0

    def step(self, viewer: Viewer):
        state = viewer.controller.state
        if self.phase == "warmup" and state == "full":
            self.phase, self.first = "orbit", len(viewer.options.frames)
            self.until = time.perf_counter() + self.seconds
        if self.phase == "orbit":
            if time.perf_counter() < self.until:
                viewer.gesture = "orbit"   # as if the left button were held
                viewer.navigate("orbit", self.STEP_PIXELS, 0.0)
                return
            self.phase, self.settle = "settle", len(viewer.options.frames)
            viewer.gesture = None
            viewer.end_gesture()
        elif self.phase == "settle" and state == "full":
            print(self.summary(viewer))
            viewer.quit()

    def summary(self, viewer: Viewer) -> str:
        frames = viewer.options.frames
        moving = [f for f in frames[self.first:self.settle] if f["interactive"]]
        still = [f for f in frames[self.settle:] if f["block"] == 1 and f["distance_factor"] == 1]
        s = viewer.scene
        size = ("x".join(map(str, s.field.dims)) if hasattr(s.field, "dims")
                else f"{len(s.field.tets)} tetrahedra" if hasattr(s.field, "tets") else s.field.kind)
        lines = [f"dvr view benchmark: {s.field.name} {size}, {s.renderer.name}, "
                 f"render area {s.image.width}x{s.image.height}, budget {viewer.options.budget_ms:g} ms"]
        if moving:
            ms = np.array([f["frame_ms"] for f in moving[1:] or moving])
            levels: dict = {}
            for f in moving:
                key = f"1/{f['block']} res x{f['distance_factor']:g} d"
                levels[key] = levels.get(key, 0) + 1
            lines.append(f"interactive: {len(moving)} frames in {self.seconds:g} s, frame time median "
                         f"{np.median(ms):.1f} ms, 90th percentile {np.percentile(ms, 90):.1f} ms, "
                         f"max {ms.max():.1f} ms; "
                         f"levels {', '.join(f'{k}: {v}' for k, v in levels.items())}")
        if still:
            f = still[0]
            lines.append(f"full quality: render {f['render_ms']:.1f} ms, frame {f['frame_ms']:.1f} ms "
                         f"({f['width']}x{f['height']})")
        return "\n".join(lines)
