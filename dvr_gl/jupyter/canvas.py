"""The widget's frame buffer: a ``jupyter_rfb.RemoteFrameBuffer`` whose frames the kernel renders.

Events (jupyter_rfb's, in CSS pixels, image y down) move the camera with the viewer's navigation
(:mod:`dvr_gl.viewer.navigation`): a left drag orbits, a right, middle or shift-left drag pans, the wheel zooms
(:data:`WHEEL_PIXELS_PER_STEP` pixels of wheel per zoom step).  Frames follow the viewer's progressive
refinement (:mod:`dvr_gl.viewer.refinement`): while a gesture goes on, each frame is rendered at the best
level (fewer pixels, a longer sample distance) predicted to fit ``budget`` seconds; when it ends (the pointer
released, or :data:`WHEEL_SETTLE` seconds after the last wheel event) the next frames refine to full quality,
and the last frame drawn after any change is always a full-quality one.  A coarse frame is enlarged to the
widget's size by repeating pixels.

A pointer moving with no button down is picked (:func:`dvr_gl.pick`, one ray) once it rests :data:`PICK_REST`
seconds, for the status line; annotations (:mod:`dvr_gl.annotations`) are drawn on the 8-bit full-quality
frames only, never into the float image; recorded keyframes (one a second) make ``camera_path``, which
``scene`` carries as ``[[camera.keyframe]]`` tables.

One renderer per renderer name, and one GL context, live as long as the widget (closed with it), so a frame
costs one render, not a context and a volume upload.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import dataclasses
import io
import math
import time

import numpy as np
from jupyter_rfb import RemoteFrameBuffer

from ..annotations import Annotations, annotate
from ..api import Image, scene_of
from ..camera_path import CameraPath
from ..errors import DvrError
from ..fields.series import TimeSeries
from ..image import composite_over, encode_8bit
from ..picking import Pick, pick
from ..renderers import create_renderer, registry
from ..viewer import navigation
from ..viewer.refinement import FULL, FramePlan, RefinementController, plan_scene
from ..viewer.timeline import at_step

WHEEL_PIXELS_PER_STEP = 100.0  # a wheel notch in a browser, CSS pixels (jupyter_rfb turns lines and pages to pixels)
WHEEL_SETTLE = 0.25            # seconds after the last wheel event that end a wheel gesture
PICK_REST = 0.15               # seconds the pointer rests (moving with no button down) before it is picked
MAX_PIXEL_RATIO = 2.0          # the default cap on physical pixels per CSS pixel the image is rendered at


class VolumeWidget(RemoteFrameBuffer):
    """An interactive view of a scene (made by :func:`dvr_gl.widget`; see the module doc).

    ``scene``: the current :class:`~dvr_gl.Scene` (settable); ``snapshot()``: its full-quality image;
    ``controls``: the ipywidgets panel, shown beside the picture; ``last_plan``: the level of the last frame.
    """

    def __init__(self, scene, read_step=None, steps: int = 1, budget: float = 0.1, rescale_intercept: float = 0.0,
                 max_pixel_ratio: float = MAX_PIXEL_RATIO, **kwargs):
        with contextlib.redirect_stdout(io.StringIO()):  # outside IPython jupyter_rfb prints its output area
            super().__init__(**kwargs)
        self._scene = self._good_scene = scene
        self.controller = RefinementController(budget, passes=1)
        self.renderers: dict = {}
        self.ctx = None
        self.version = 0                 # counts scene changes
        self.gesture: str | None = None  # "orbit" or "pan" while a pointer is down
        self._cursor = self._hover = (0.0, 0.0)  # the pointer (CSS pixels): last pressed or moved; resting
        self._settle_handle = None
        self._full: tuple[int, np.ndarray] | None = None  # (version, full-quality premultiplied rgba)
        self._frame: np.ndarray | None = None              # the last frame returned, uint8 (H, W, 3)
        self.last_plan: FramePlan | None = None
        self.render_seconds = 0.0
        self.message = ""
        self._stalled = -1               # the version whose rendering failed with no way back
        self.read_step, self.steps, self.time = read_step, steps, 0
        self.home = scene.camera
        self.rescale_intercept = rescale_intercept  # for the CT presets the controls offer (HU = data + this)
        self.css_width, self.css_height = f"{scene.image.width}px", f"{scene.image.height}px"
        self._css_size = (float(scene.image.width), float(scene.image.height))  # the last resize event's
        if not (isinstance(max_pixel_ratio, int | float) and math.isfinite(max_pixel_ratio) and max_pixel_ratio >= 1):
            raise DvrError(f"max_pixel_ratio must be a number of at least 1 (physical pixels per CSS pixel), got "
                           f"{max_pixel_ratio!r}")
        self.max_pixel_ratio = float(max_pixel_ratio)
        self.pixel_ratio = 1.0  # physical pixels per CSS pixel the image is rendered at (the last resize event's)
        self._pick_handle = None
        self.picked: Pick | None = None  # the last pick under the resting pointer
        self.pick_text = ""              # what the status line says of it
        self.annotations = Annotations()  # drawn on full-quality frames (set_annotations)
        self.keyframes: list = []         # cameras recorded at times 0, 1, 2, ... seconds (add_keyframe)
        self.keyframe_steps: list = []    # the time step shown at each (a time series' path gives them)
        self._with_path: tuple | None = None  # (scene, keyframe count, the scene with the path): a cache
        self._draw(FramePlan(FULL))  # the first picture now: a scene that cannot render fails in the cell
        from .controls import Controls

        self.controls = Controls(self)
        self.request_draw()  # sent once a browser shows the widget

    @classmethod
    def of(cls, data, time_axis: int | None = None, budget: float = 0.1, max_pixel_ratio: float = MAX_PIXEL_RATIO,
           **options) -> "VolumeWidget":
        """The widget on ``data`` with :func:`dvr_gl.render`'s options (see :func:`dvr_gl.widget`)."""
        read_step, steps = None, 1
        if isinstance(data, TimeSeries):
            read_step, steps = (lambda k: scene_of(data.step(k), **options)), data.steps
        elif time_axis is not None:
            read_step = lambda k: scene_of(data, time_axis=time_axis, time=k, **options)  # noqa: E731
            steps = int(np.shape(data)[time_axis])
        scene = read_step(0) if read_step is not None else scene_of(data, **options)
        registry.check(scene)
        return cls(scene, read_step, steps, budget, options.get("rescale_intercept") or 0.0, max_pixel_ratio)

    # --- the scene ---

    @property
    def scene(self):
        """The scene shown now (camera, transfer functions and settings as the controls left them), with the
        recorded camera path as its ``[[camera.keyframe]]`` tables once two keyframes exist."""
        path = self.camera_path
        if path is None:
            return self._scene
        cached = self._with_path
        if cached is None or cached[0] is not self._scene or cached[1] != len(self.keyframes):
            self._with_path = (self._scene, len(self.keyframes), self._scene.with_camera_path(path))
        return self._with_path[2]

    @scene.setter
    def scene(self, scene):
        registry.check(scene)
        self.set_scene(scene, costs=True)

    def set_scene(self, scene, interactive: bool = False, costs: bool = False):
        """Show ``scene`` from now on; ``interactive``: part of a gesture; ``costs``: its frames cost
        differently (measure again)."""
        self._scene = scene
        self.version += 1
        self.controller.changed(interactive)
        if costs:
            self.controller.forget_costs()
        self.request_draw()

    def apply(self, change, interactive: bool = False, costs: bool = True) -> bool:
        """``change(scene) -> scene``; a DvrError (a setting refused) is shown and changes nothing.
        ``interactive``: one of a stream of changes (a slider moving): coarse frames until it rests;
        ``costs``: the change may change what a frame costs (a renderer setting, not a transfer function)."""
        try:
            scene = change(self._scene)
        except DvrError as exc:
            self.notify(str(exc))
            return False
        self.message = ""
        self.set_scene(scene, interactive=interactive, costs=costs and not interactive)
        if interactive:
            self.settle_later()
        return True

    def go_to_time(self, k: int):
        """Show time step ``k`` with the current camera, settings and transfer functions."""
        if self.read_step is None or k == self.time:
            return
        self.apply(lambda scene: at_step(scene, self.read_step(k)), costs=False)
        self.time = k

    def notify(self, text: str):
        self.message = text
        controls = getattr(self, "controls", None)
        if controls is not None:
            controls.show_status()

    # --- events ---

    def handle_event(self, event: dict):
        kind = event.get("type") or event.get("event_type")
        handler = {"pointer_down": self._press, "pointer_move": self._move, "pointer_up": self._release,
                   "wheel": self._wheel, "resize": self._resize, "close": lambda _: self.release()}.get(kind)
        if handler is None:
            return
        try:
            handler(event)
        except (DvrError, TypeError, ValueError) as exc:  # an event no browser sends: said, and nothing changes
            self.notify(f"event {kind!r} ignored: {exc}")

    def _press(self, event):
        button, shift = event.get("button"), "Shift" in event.get("modifiers", ())
        self.gesture = "orbit" if button == 1 and not shift else "pan" if button in (1, 2, 3) else None
        self._cursor = self._position(event)
        if self._pick_handle is not None:   # a press: no pick until the pointer rests again
            self._pick_handle.cancel()
            self._pick_handle = None

    def _position(self, event) -> tuple[float, float]:
        """The pointer's position in CSS pixels (the last one where an event lacks it)."""
        x, y = float(event.get("x", self._cursor[0])), float(event.get("y", self._cursor[1]))
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"the pointer's position must be finite, got ({x}, {y})")
        return x, y

    def _move(self, event):
        if self.gesture is None:
            if not event.get("buttons"):  # the pointer moving with no button down: pick where it rests
                self._hover = self._position(event)
                self.pick_later()
            return
        (x, y), (x0, y0) = self._position(event), self._cursor
        self._cursor = (x, y)
        camera = self._scene.camera
        if self.gesture == "orbit":
            camera = navigation.orbit(camera, x - x0, y - y0)
        else:
            camera = navigation.pan(camera, x - x0, y - y0, self._css_size[1])  # CSS pixels, as the moves
        self.set_scene(self._scene.replace(camera=camera), interactive=True)

    def _release(self, event):
        if self.gesture is not None:
            self.gesture = None
            self.settle()

    def _wheel(self, event):
        steps = -float(event.get("dy", 0.0)) / WHEEL_PIXELS_PER_STEP
        if steps == 0 or not math.isfinite(steps):
            return
        self.set_scene(self._scene.replace(camera=navigation.zoom(self._scene.camera, steps)), interactive=True)
        self.settle_later()

    def settle_later(self):
        """End the gesture :data:`WHEEL_SETTLE` seconds after the last change unless another comes (at once
        without an event loop)."""
        if self._settle_handle is not None:
            self._settle_handle.cancel()
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # no event loop (a script): the gesture ends with the change
            self.settle()
            return
        self._settle_handle = loop.call_later(WHEEL_SETTLE, self.settle)

    def settle(self):
        """The gesture ended: refine to full quality from the next frame on."""
        self._settle_handle = None
        self.controller.idle()
        self.request_draw()

    def _resize(self, event):
        """The widget's box changed (CSS pixels) or the screen's pixel ratio did: the image is rendered at the
        physical pixels, the CSS size times the ratio (``pixel_ratio`` in jupyter_rfb's old events, ``ratio`` in
        its new ones), the ratio capped at ``max_pixel_ratio`` (a HiDPI screen's 2 costs four times the pixels)."""
        ratio = float(event.get("pixel_ratio", event.get("ratio", self.pixel_ratio)))
        if not (math.isfinite(ratio) and ratio > 0):
            raise ValueError(f"the pixel ratio must be a positive number, got {ratio}")
        self.pixel_ratio = min(ratio, self.max_pixel_ratio)
        css_w, css_h = float(event.get("width", 0)), float(event.get("height", 0))
        width, height = int(round(css_w * self.pixel_ratio)), int(round(css_h * self.pixel_ratio))
        if width > 0 and height > 0:
            self._css_size = (css_w, css_h)
        image = self._scene.image
        if width > 0 and height > 0 and (width, height) != (image.width, image.height):
            self.set_scene(self._scene.replace(image=dataclasses.replace(image, width=width, height=height)),
                           costs=True)

    def reset_view(self):
        self.set_scene(self._scene.replace(camera=self.home))

    # --- picking ---

    def image_pixel(self, x: float, y: float) -> tuple[float, float]:
        """The image pixel coordinates (column, row from the top) of CSS pixel ``(x, y)`` of the widget (the
        image is rendered at the widget's CSS size times the pixel ratio: :meth:`_resize`)."""
        width, height = self._css_size
        return x * self._scene.image.width / width, y * self._scene.image.height / height

    def pick(self, x: float, y: float) -> Pick:
        """What lies under CSS pixel ``(x, y)`` (from the left, from the top) of the current scene's full-quality
        image: :func:`dvr_gl.pick` at :meth:`image_pixel` (one float64 ray, milliseconds)."""
        return pick(self._scene, *self.image_pixel(x, y))

    def pick_later(self):
        """Pick under the pointer :data:`PICK_REST` seconds after it last moved, unless it moves again or a
        gesture starts (at once without an event loop): a drag never waits for a pick."""
        if self._pick_handle is not None:
            self._pick_handle.cancel()
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            self.show_pick()
            return
        self._pick_handle = loop.call_later(PICK_REST, self.show_pick)

    def show_pick(self):
        """Pick under the resting pointer and say what lies there in the status line."""
        self._pick_handle = None
        if self.gesture is not None:
            return
        try:
            self.picked = self.pick(*self._hover)
            self.pick_text = describe_pick(self.picked)
        except DvrError as exc:   # a mode without a depth (average), a pixel outside the image
            self.picked, self.pick_text = None, f"pick: {exc}"
        self.notify(self.message)

    # --- annotations ---

    def set_annotations(self, annotations: Annotations):
        """Draw ``annotations`` on the full-quality frames from now on (the last one at once, not rendered
        again); one that does not fit the image is refused in the status line and drawn without it."""
        self.annotations = annotations
        if self._full is not None and self._full[0] == self.version and self.last_plan.level.full:
            self._frame = self._picture(self._full[1], self.last_plan)
            self.request_draw()

    def annotated(self) -> np.ndarray:
        """The full-quality picture with the widget's annotations: 8-bit sRGB ``(H, W, 4)``, what
        ``snapshot().save("view.png", annotations=...)`` writes (the float image has none)."""
        return annotate(self.snapshot().srgb8(), self._scene, self.annotations)

    # --- the camera path ---

    def add_keyframe(self):
        """Record the current camera (and time step) as a keyframe at time = the number of keyframes before it
        (seconds)."""
        self.keyframes.append(self._scene.camera)
        self.keyframe_steps.append(self.time)
        self.notify(self.message)

    def clear_keyframes(self):
        self.keyframes.clear()
        self.keyframe_steps.clear()
        self.notify(self.message)

    @property
    def camera_path(self) -> CameraPath | None:
        """The recorded keyframes as a :class:`~dvr_gl.camera_path.CameraPath` (keyframe ``k`` at ``k``
        seconds; with a time series, the step shown at each), or None before two exist."""
        if len(self.keyframes) < 2:
            return None
        steps = tuple(self.keyframe_steps) if self.read_step is not None else None
        return CameraPath(tuple(self.keyframes), tuple(range(len(self.keyframes))), steps)

    # --- frames ---

    def get_frame(self):
        """The next frame (jupyter_rfb calls this when the browser can take one): the controller's next level,
        or the last frame again when the picture is final."""
        plan = self.controller.next_frame() if self._stalled != self.version else None
        if plan is not None:
            try:
                self._draw(plan)
            except DvrError as exc:
                self._refused(exc)
            if self.controller.next_frame() is not None:
                self.request_draw()   # refinement goes on
        return self._frame

    def _draw(self, plan: FramePlan):
        rgba, seconds = self._render(plan)
        start = time.perf_counter()
        frame = self._picture(rgba, plan)
        other = time.perf_counter() - start + self.get_stats()["img_encoding"]
        self.controller.measured(plan, seconds, other)
        self.controller.shown(plan)
        self._good_scene, self._frame, self.last_plan, self.render_seconds = self._scene, frame, plan, seconds
        if plan.level.full:
            self._full = (self.version, rgba)
        controls = getattr(self, "controls", None)
        if controls is not None:
            controls.show_status()

    def frame_scene(self, plan: FramePlan):
        """The scene a frame of ``plan`` renders: the viewer's rule (fewer pixels, a longer sample distance)."""
        return plan_scene(self._scene, plan)

    def _render(self, plan: FramePlan) -> tuple[np.ndarray, float]:
        """Premultiplied rgba of ``plan``'s frame, and the seconds the renderer took."""
        scene = self.frame_scene(plan)
        renderer = self._renderer(scene.renderer.name)
        start = time.perf_counter()
        rgba = renderer.render(scene)
        return rgba, time.perf_counter() - start

    def _renderer(self, name: str):
        if name not in self.renderers:
            if registry.plugin(name).needs_gl and self.ctx is None:
                from ..gl.context import create_context

                self.ctx = create_context()
            self.renderers[name] = create_renderer(name, ctx=self.ctx)
        return self.renderers[name]

    def _picture(self, rgba: np.ndarray, plan: FramePlan) -> np.ndarray:
        """8-bit sRGB over the background, ``(H, W, 3)`` at the widget's size (a coarse frame's pixels repeated)."""
        pixels = encode_8bit(composite_over(rgba, self._scene.image.background))[..., :3]
        block = plan.level.block
        if block > 1:
            pixels = pixels.repeat(block, axis=0).repeat(block, axis=1)
        pixels = np.ascontiguousarray(pixels[:self._scene.image.height, :self._scene.image.width])
        if plan.level.full and self.annotations:
            try:
                pixels = annotate(pixels, self._scene, self.annotations)
            except DvrError as exc:   # no room in this image: said, and the picture shown without them
                self.message = str(exc)
        return pixels

    def _refused(self, exc: DvrError):
        """The renderer refused the scene: say why and go back to the last scene that rendered (if that one
        fails too, wait for the next change)."""
        self.notify(f"{exc}; keeping the previous settings")
        if self._scene is self._good_scene:
            self._stalled = self.version
            return
        self.set_scene(self._good_scene, costs=True)
        controls = getattr(self, "controls", None)
        if controls is not None:
            controls.sync()

    @property
    def refined(self) -> bool:
        """Whether the picture shown is the full-quality image of the current scene."""
        return self._full is not None and self._full[0] == self.version and self.controller.state == "full"

    def snapshot(self) -> Image:
        """The full-quality :class:`~dvr_gl.Image` of the current scene (the picture shown once refined)."""
        if self._full is not None and self._full[0] == self.version:
            rgba = self._full[1]
        else:
            rgba, _ = self._render(FramePlan(FULL))
        renderer = self._renderer(self._scene.renderer.name)
        return Image(rgba, self._scene, dict(renderer.stats))

    # --- display and closing ---

    def _repr_mimebundle_(self, **kwargs):
        """The picture with its controls; a PNG of the last frame for readers without widgets (GitHub)."""
        from ipywidgets import HBox
        from jupyter_rfb._utils import array2compressed

        result = HBox([self, self.controls.panel])._repr_mimebundle_(**kwargs)
        data = result[0] if isinstance(result, tuple) else result
        if data is not None and self._frame is not None:
            _, png = array2compressed(self._frame, 100)
            data["image/png"] = base64.b64encode(png).decode("ascii")
        return result

    def release(self):
        """Release the renderers and the GL context (the widget shows no more frames)."""
        for renderer in self.renderers.values():
            renderer.close()
        self.renderers.clear()
        if self.ctx is not None:
            self.ctx.release()
            self.ctx = None

    def close(self, *args, **kwargs):
        controls = getattr(self, "controls", None)
        if controls is not None:
            controls.editor.close()
            controls.panel.close()
        super().close(*args, **kwargs)   # sends the close event: release()


def describe_pick(p: Pick) -> str:
    """The status line's words for a pick: the value, the voxel ``(z, y, x)`` and the world point ``(x, y, z)``."""
    if not p.hit:
        return f"pixel ({p.x}, {p.y}): nothing there"
    where = f"voxel {tuple(int(i) for i in p.index)}, " if p.index is not None else ""
    value = f"{p.value:.5g}" if p.value is not None else ", ".join(f"{k} {v:.5g}" for k, v in (p.values or {}).items())
    position = ", ".join(f"{c:.4g}" for c in p.position)
    return f"value {value} at {where}world ({position})"
