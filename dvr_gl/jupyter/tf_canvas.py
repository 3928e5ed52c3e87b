"""The widget's drawn transfer-function editor: a small ``jupyter_rfb.RemoteFrameBuffer`` in the controls panel,
drawn with numpy, whose pointer events edit the control points with the viewer's editor model
(:class:`dvr_gl.viewer.tf_editor.TransferFunctionEditor`, the same hit test, add, move and delete).

The picture (CSS pixels, origin top-left, y down; the frame is drawn at the widget's logical size): the field's
histogram as grey bars (log(1 + count), :func:`dvr_gl.viewer.gui.histogram`), the opacity curve through the
control points (value across, opacity up to a round axis top, :func:`~dvr_gl.viewer.tf_editor.nice_opacity_max`,
held still while a point is dragged), the points as small squares (the selected one white), and below it a
strip of :data:`STRIP_HEIGHT` pixels with the function's colour at each value (sRGB).  The value axis spans the
field's value range, widened to the function's points.

Events: a left press on a point picks it, elsewhere adds a point there (with the colour the function has
there); a drag moves the picked point (its value kept between its neighbours'); a right press or a double
click on a point deletes it (two points always remain).  Every edit gives the controls a new
:class:`~dvr_gl.TransferFunction` for the chosen field (:meth:`~dvr_gl.jupyter.controls.Controls.edited`), which
the volume widget renders as a slider's change: coarse frames while the point moves, the full image once
released.
"""

from __future__ import annotations

import contextlib
import io
import math

import numpy as np
from jupyter_rfb import RemoteFrameBuffer

from ..fields import value_sample
from ..transfer_function import TransferFunction, linear_to_srgb
from ..viewer.gui import histogram
from ..viewer.tf_editor import CanvasMapping, TransferFunctionEditor, nice_opacity_max

WIDTH, HEIGHT = 360, 110   # CSS pixels of the whole editor
STRIP_HEIGHT = 12          # the colour strip under the curve
POINT_HALF = 2             # a control point is drawn as a (2 * POINT_HALF + 1)-pixel square
BACKGROUND = (26, 26, 31)
BARS = (80, 80, 92)
CURVE = (255, 190, 60)
POINT, SELECTED = (255, 140, 0), (255, 255, 255)


class TransferFunctionCanvas(RemoteFrameBuffer):
    """The editor of one :class:`~dvr_gl.jupyter.controls.Controls` (see the module doc).  ``editor``: the model
    of the function shown; ``mapping()``: its pixels to (value, opacity)."""

    def __init__(self, controls, **kwargs):
        with contextlib.redirect_stdout(io.StringIO()):  # outside IPython jupyter_rfb prints its output area
            super().__init__(**kwargs)
        self.controls = controls
        self.size = (WIDTH, HEIGHT)
        self.css_width, self.css_height = f"{WIDTH}px", f"{HEIGHT}px"
        self.editor: TransferFunctionEditor | None = None
        self.field = None
        self.dragging: int | None = None
        self._axis_top: float | None = None
        self._heights: tuple | None = None   # (field, value range, heights): a cache
        self.show_scene()

    # --- from the scene ---

    def show_scene(self):
        """Show the chosen field's transfer function as the scene has it now (no edit)."""
        controls = self.controls
        if controls.field_index is None:
            return
        layer = controls.view.scene.layers[controls.field_index]
        tf = layer.transfer_function
        if self.editor is None or self.field is not layer.field or not same_function(self.editor, tf):
            self.editor = TransferFunctionEditor(tf)
            self.dragging = None
        self.field = layer.field
        self.request_draw()

    # --- pixels ---

    def value_range(self) -> tuple[float, float]:
        lo, hi = self.field.value_range
        lo, hi = min(lo, self.editor.points[0, 0]), max(hi, self.editor.points[-1, 0])
        return (float(lo), float(hi)) if hi > lo else (float(lo), float(lo) + 1.0)

    def opacity_top(self) -> float:
        if self.dragging is None or self._axis_top is None:   # the axis holds still while a point moves
            self._axis_top = nice_opacity_max(self.editor.points[:, 4], self.editor.opacity_model)
        return self._axis_top

    def mapping(self) -> CanvasMapping:
        """The curve's area: the whole width, the height above the colour strip."""
        width, height = self.size
        return CanvasMapping(0.0, 0.0, float(width), float(height - STRIP_HEIGHT), self.value_range(),
                             self.opacity_top())

    # --- events ---

    def handle_event(self, event: dict):
        kind = event.get("type") or event.get("event_type")
        if self.editor is None:
            return
        try:
            if kind == "resize":
                self._resize(event)
            elif kind == "pointer_down":
                self._press(event)
            elif kind == "pointer_move" and self.dragging is not None:
                self._drag(event)
            elif kind == "pointer_up" and self.dragging is not None:
                self.dragging = None
                self.controls.view.settle()
                self.request_draw()
            elif kind == "double_click":
                self._delete(event)
        except (KeyError, TypeError, ValueError) as exc:   # an event no browser sends: said, nothing changes
            self.controls.view.notify(f"editor event {kind!r} ignored: {exc}")

    def _position(self, event) -> tuple[float, float]:
        x, y = float(event["x"]), float(event["y"])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"the pointer's position must be finite, got ({x}, {y})")
        return x, y

    def _press(self, event):
        x, y = self._position(event)
        button = event.get("button")
        if button == 2:
            self._delete(event)
            return
        if button != 1:
            return
        mapping = self.mapping()
        i = self.editor.pick(mapping, x, y)
        if i is None:
            i = self.editor.add(*mapping.from_pixel(x, y))
            self._edited(interactive=False)
        self.editor.selected = self.dragging = i
        self.request_draw()

    def _drag(self, event):
        if self.dragging >= len(self.editor.points):   # the function changed under the drag (a refusal)
            self.dragging = None
            return
        self.editor.move(self.dragging, *self.mapping().from_pixel(*self._position(event)))
        self._edited(interactive=True)

    def _delete(self, event):
        i = self.editor.pick(self.mapping(), *self._position(event))
        if i is None:
            return
        if not self.editor.delete(i):
            self.controls.view.notify("a transfer function keeps at least two points")
            return
        self.dragging = None
        self._edited(interactive=False)

    def _edited(self, interactive: bool):
        self.controls.edited(self.editor.transfer_function(), interactive)
        self.request_draw()

    def _resize(self, event):
        width, height = int(round(event.get("width", 0))), int(round(event.get("height", 0)))
        if width > 8 and height > STRIP_HEIGHT + 8:
            self.size = (width, height)
            self.request_draw()

    # --- the picture ---

    def get_frame(self) -> np.ndarray | None:
        return None if self.editor is None else self.picture()

    def picture(self) -> np.ndarray:
        """The editor's picture: 8-bit sRGB ``(H, W, 3)`` (see the module doc)."""
        width, height = self.size
        mapping = self.mapping()
        plot = int(mapping.height)
        frame = np.empty((height, width, 3), np.uint8)
        frame[:] = BACKGROUND
        self._bars(frame[:plot], mapping)
        values = mapping.value_range[0] + (np.arange(width) + 0.5) / width * (mapping.value_range[1]
                                                                            - mapping.value_range[0])
        self._curve(frame[:plot], mapping, values)
        self._points(frame[:plot], mapping)
        points = self.editor.points
        rgb = np.stack([np.interp(values, points[:, 0], points[:, c]) for c in (1, 2, 3)], axis=-1)
        frame[plot:] = np.round(255 * linear_to_srgb(np.clip(rgb, 0.0, 1.0))).astype(np.uint8)[None]
        return frame

    def _bars(self, frame, mapping):
        key = (self.field, mapping.value_range)
        if self._heights is None or self._heights[:2] != key:
            self._heights = (*key, histogram(value_sample(self.field), mapping.value_range))
        heights = self._heights[2]
        height, width = frame.shape[:2]
        columns = np.minimum((np.arange(width) * len(heights)) // width, len(heights) - 1)
        tops = height - np.round(heights[columns] * height).astype(int)
        rows = np.arange(height)[:, None]
        frame[rows >= tops[None, :]] = BARS

    def _curve(self, frame, mapping, values):
        """The opacity curve: at each column the rows between its y and the next column's (a connected line)."""
        points = self.editor.points
        opacity = np.interp(values, points[:, 0], points[:, 4])
        ys = np.array([mapping.to_pixel(v, o)[1] for v, o in zip(values, opacity)])
        ys = np.clip(np.round(ys - 0.5).astype(int), 0, frame.shape[0] - 1)
        following = np.append(ys[1:], ys[-1])
        for x, (a, b) in enumerate(zip(ys, following)):
            frame[min(a, b):max(a, b) + 1, x] = CURVE

    def _points(self, frame, mapping):
        height, width = frame.shape[:2]
        for i, (value, opacity) in enumerate(self.editor.points[:, [0, 4]]):
            px, py = mapping.to_pixel(value, opacity)
            x, y = int(round(px - 0.5)), int(round(py - 0.5))
            frame[max(y - POINT_HALF, 0):min(y + POINT_HALF + 1, height),
                  max(x - POINT_HALF, 0):min(x + POINT_HALF + 1, width)] = (
                SELECTED if i == self.editor.selected else POINT)


def same_function(editor: TransferFunctionEditor, tf: TransferFunction) -> bool:
    """Whether the editor holds ``tf``'s points and opacity model (an edit's own function coming back)."""
    return (editor.opacity_model == tf.opacity_model and editor.points.shape == np.shape(tf.points)
            and bool(np.array_equal(editor.points, tf.points)))
