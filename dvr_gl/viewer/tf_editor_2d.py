"""The viewer's 2D transfer-function editor, without a window: ParaView-style boxes over value x |gradient|.

A box is ``[value, gradient, width, height, r, g, b, alpha]`` (value and gradient magnitude in the field's units,
gradient per world unit; colour linear 0..1; alpha per the function's ``unit_distance``), as the scene key
``boxes_2d`` stores it. Every edit rebuilds the table exactly as :meth:`TransferFunction2D.from_boxes` does, so
the editor's function is the one a scene file with the same keys gives, and a scene saved from the viewer holds
the boxes (:class:`BoxTransferFunction2D`), not only their table. The histogram drawn under the boxes is
:func:`histogram_2d`'s, shown as log1p of the counts (a few dense bins would otherwise hide the rest).

The mouse on the editor's canvas (:class:`Canvas2D`: value to the right, gradient magnitude up, window pixels
with y down) is geometry on the model, testable without a window: :meth:`BoxEditor2D.hit` says which box and
which of its parts (inside, an edge, a corner) is under a pixel, :meth:`BoxEditor2D.drag` moves or resizes the
box grabbed there by a mouse movement.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..renderers.registry import plugin
from ..transfer_function_2d import BOX_TABLE_SIZE, TransferFunction2D, histogram_2d

#: a new box's size as a fraction of each axis, and its colour and alpha
NEW_BOX_FRACTION = 0.1
NEW_BOX_RGBA = (1.0, 1.0, 1.0, 0.5)
#: window pixels within which a box's edge or corner is grabbed (to resize) rather than its inside (to move)
EDGE_PIXELS = 5.0
#: the least width and height a box is resized to, as a fraction of each axis
MIN_BOX_FRACTION = 0.005
#: voxels the histogram is taken over at most (a larger volume: every k-th voxel along each axis)
HISTOGRAM_VOXELS = 1 << 21


def renders_2d(renderer: str, kind: str = "grid") -> bool:
    """Whether the renderer declares it classifies ``kind`` data with a 2D transfer function (its trait)."""
    return kind in plugin(renderer).transfer_function_2d


@dataclass(frozen=True, eq=False, repr=False, init=False)
class BoxTransferFunction2D(TransferFunction2D):
    """A :class:`TransferFunction2D` drawn from boxes, which remembers them: its scene table is the boxes
    (``boxes_2d``, the ranges and ``size_2d``), from which a scene file rebuilds the same table bit for bit."""

    boxes: tuple = ()

    @classmethod
    def of(cls, boxes, value_range, gradient_range, size, unit_distance: float = 1.0) -> "BoxTransferFunction2D":
        tf = cls.from_boxes(boxes, value_range, gradient_range, size, unit_distance)
        object.__setattr__(tf, "boxes", tuple(tuple(float(c) for c in b) for b in boxes))
        return tf

    def to_table(self) -> dict:
        return {"boxes_2d": [list(b) for b in self.boxes], "value_range_2d": list(self.value_range),
                "gradient_range_2d": list(self.gradient_range), "size_2d": list(self.shape),
                "unit_distance": self.unit_distance, "opacity_model": self.opacity_model}


def histogram_voxels(data, spacing, limit: int = HISTOGRAM_VOXELS):
    """``(data, spacing)`` of at most about ``limit`` voxels: every k-th voxel along each axis, the spacing k
    times as long (so gradient magnitudes keep their units)."""
    data = np.asarray(data)
    step = max(1, int(np.ceil((data.size / limit) ** (1 / 3))))
    return data[::step, ::step, ::step], tuple(float(s) * step for s in spacing)


@dataclass(frozen=True)
class Canvas2D:
    """The editor's canvas in window pixels (origin top-left, y down): ``value_range`` across its width,
    ``gradient_range`` up its height (gradient magnitude 0 at the bottom edge)."""

    x: float
    y: float
    width: float
    height: float
    value_range: tuple[float, float]
    gradient_range: tuple[float, float]

    def to_pixel(self, value: float, gradient: float) -> tuple[float, float]:
        (v0, v1), (g0, g1) = self.value_range, self.gradient_range
        return (self.x + (value - v0) / (v1 - v0) * self.width,
                self.y + self.height * (1.0 - (gradient - g0) / (g1 - g0)))

    def from_pixel(self, px: float, py: float) -> tuple[float, float]:
        """(value, gradient magnitude) under a pixel (not clamped: a box may reach past the ranges)."""
        (v0, v1), (g0, g1) = self.value_range, self.gradient_range
        return v0 + (px - self.x) / self.width * (v1 - v0), g0 + (1.0 - (py - self.y) / self.height) * (g1 - g0)

    def per_pixel(self) -> tuple[float, float]:
        """Value and gradient magnitude per pixel (a movement's size in field units; y grows down)."""
        return ((self.value_range[1] - self.value_range[0]) / self.width,
                (self.gradient_range[1] - self.gradient_range[0]) / self.height)

    def box_rect(self, box) -> tuple[float, float, float, float]:
        """A box's pixels ``(left, top, right, bottom)``."""
        x0, y1 = self.to_pixel(box[0], box[1])
        x1, y0 = self.to_pixel(box[0] + box[2], box[1] + box[3])
        return x0, y0, x1, y1

    def contains(self, px: float, py: float) -> bool:
        return self.x <= px <= self.x + self.width and self.y <= py <= self.y + self.height


class BoxEditor2D:
    """The boxes of one field's 2D transfer function, and the histogram they are drawn over.  ``version``
    counts edits (the viewer applies the function when it changes); ``selected`` is the box the panel edits."""

    def __init__(self, data, spacing, boxes=(), bins=BOX_TABLE_SIZE, unit_distance: float = 1.0,
                 value_range=None, gradient_range=None):
        counts, self.value_range, self.gradient_range = histogram_2d(data, spacing, bins=bins,
                                                                     value_range=value_range,
                                                                     gradient_range=gradient_range)
        self.log_counts = np.log1p(counts)
        self.size, self.unit_distance = tuple(bins), unit_distance
        self.boxes = [list(map(float, b)) for b in boxes]
        self.selected: int | None = None
        self.version = 0

    @classmethod
    def for_field(cls, field, tf=None) -> "BoxEditor2D":
        """The editor of a grid ``field`` (its histogram from at most :data:`HISTOGRAM_VOXELS` voxels, over the
        field's value range); the boxes, ranges and table size of ``tf`` where it was drawn from boxes."""
        data, spacing = histogram_voxels(field.data, field.spacing)
        boxes = getattr(tf, "boxes", ())
        if boxes:
            return cls(data, spacing, boxes, tf.shape, tf.unit_distance, tf.value_range, tf.gradient_range)
        lo, hi = field.value_range
        return cls(data, spacing, unit_distance=getattr(tf, "unit_distance", 1.0),
                   value_range=(lo, hi) if hi > lo else None)

    @property
    def transfer_function(self) -> TransferFunction2D:
        """The function the boxes draw (an empty editor: a transparent table)."""
        if not self.boxes:  # from_boxes refuses none, as a scene file's boxes_2d must hold one
            return TransferFunction2D(np.zeros((*self.size, 4)), self.value_range, self.gradient_range,
                                      self.unit_distance)
        return BoxTransferFunction2D.of(self.boxes, self.value_range, self.gradient_range, self.size,
                                        self.unit_distance)

    def _edited(self, selected: int | None):
        self.selected = selected
        self.version += 1

    def add(self, value: float, gradient: float) -> int:
        """A box centred at (value, gradient) of a tenth of each axis, selected; its index."""
        w = NEW_BOX_FRACTION * (self.value_range[1] - self.value_range[0])
        h = NEW_BOX_FRACTION * (self.gradient_range[1] - self.gradient_range[0])
        self.boxes.append([value - w / 2, gradient - h / 2, w, h, *NEW_BOX_RGBA])
        self._edited(len(self.boxes) - 1)
        return len(self.boxes) - 1

    def move(self, i: int, value: float, gradient: float):
        """Box i's lower corner to (value, gradient)."""
        self.boxes[i][0:2] = [float(value), float(gradient)]
        self._edited(i)

    def resize(self, i: int, width: float, height: float):
        """Box i's width and height (field units; kept positive, as from_boxes requires)."""
        self.boxes[i][2:4] = [max(float(width), 1e-12), max(float(height), 1e-12)]
        self._edited(i)

    def set_color(self, i: int, rgb):
        self.boxes[i][4:7] = [float(np.clip(c, 0.0, 1.0)) for c in rgb]
        self._edited(i)

    def set_opacity(self, i: int, alpha: float):
        self.boxes[i][7] = float(np.clip(alpha, 0.0, 1.0))
        self._edited(i)

    def delete(self, i: int):
        del self.boxes[i]
        self._edited(None)

    def pick(self, value: float, gradient: float) -> int | None:
        """The topmost box containing (value, gradient), or None."""
        for i in reversed(range(len(self.boxes))):
            x, y, w, h = self.boxes[i][:4]
            if x <= value <= x + w and y <= gradient <= y + h:
                return i
        return None

    # --- the mouse on the canvas ---

    def hit(self, canvas: Canvas2D, px: float, py: float, margin: float = EDGE_PIXELS):
        """``(box, part)`` under the pixel, the topmost box first, or None: ``part`` is ``"inside"`` or the
        edges grabbed, a string of ``l``, ``r``, ``t``, ``b`` (``"tl"``: the top-left corner), those within
        ``margin`` pixels of the pixel (of a small box, within a third of its size: its middle third moves it)."""
        for i in reversed(range(len(self.boxes))):
            left, top, right, bottom = canvas.box_rect(self.boxes[i])
            if not (left - margin <= px <= right + margin and top - margin <= py <= bottom + margin):
                continue
            near_x, near_y = min(margin, (right - left) / 3), min(margin, (bottom - top) / 3)
            horizontal = "l" if px - left <= near_x else "r" if right - px <= near_x else ""
            vertical = "t" if py - top <= near_y else "b" if bottom - py <= near_y else ""
            if left <= px <= right and top <= py <= bottom and not (horizontal or vertical):
                return i, "inside"
            if horizontal or vertical:
                return i, vertical + horizontal
        return None

    def drag(self, i: int, part: str, grabbed, dx: float, dy: float, canvas: Canvas2D):
        """Box ``i`` as ``grabbed`` (its row when the button went down) moved (``part`` ``"inside"``) or resized
        by the edges in ``part`` by a mouse movement of ``(dx, dy)`` window pixels since then; a box is never
        resized below :data:`MIN_BOX_FRACTION` of an axis, the opposite edge staying where it was."""
        per_v, per_g = canvas.per_pixel()
        dv, dg = dx * per_v, -dy * per_g
        x, y, w, h = (float(c) for c in grabbed[:4])
        if part == "inside":
            self.move(i, x + dv, y + dg)
            return
        min_w = MIN_BOX_FRACTION * (self.value_range[1] - self.value_range[0])
        min_h = MIN_BOX_FRACTION * (self.gradient_range[1] - self.gradient_range[0])
        if "l" in part:
            dv = min(dv, w - min_w)
            x, w = x + dv, w - dv
        elif "r" in part:
            w = max(w + dv, min_w)
        if "b" in part:
            dg = min(dg, h - min_h)
            y, h = y + dg, h - dg
        elif "t" in part:
            h = max(h + dg, min_h)
        self.boxes[i][0:4] = [x, y, w, h]
        self._edited(i)

    def display_cells(self, most=(96, 48)) -> np.ndarray:
        """The log histogram in at most ``most`` cells (value x gradient), each the log1p of its bins'
        counts summed, scaled to the largest (for drawing: a rectangle per cell)."""
        counts = np.expm1(self.log_counts)
        fv, fg = (-(-n // m) for n, m in zip(counts.shape, most))
        nv, ng = -(-counts.shape[0] // fv), -(-counts.shape[1] // fg)
        padded = np.zeros((nv * fv, ng * fg))
        padded[:counts.shape[0], :counts.shape[1]] = counts
        cells = np.log1p(padded.reshape(nv, fv, ng, fg).sum(axis=(1, 3)))
        return cells / cells.max() if cells.max() > 0 else cells

    def scene_keys(self) -> dict:
        """The ``[transfer_function]`` keys a saved scene holds (schema: boxes_2d, value_range_2d, ...)."""
        return {"boxes_2d": [list(b) for b in self.boxes], "value_range_2d": list(self.value_range),
                "gradient_range_2d": list(self.gradient_range), "size_2d": list(self.size)}
