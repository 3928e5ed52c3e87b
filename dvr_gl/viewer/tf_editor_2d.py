"""The viewer's 2D transfer-function editor, without a window: ParaView-style boxes over value x |gradient|.

A box is ``[value, gradient, width, height, r, g, b, alpha]`` (value and gradient magnitude in the field's units,
gradient per world unit; colour linear 0..1; alpha per the function's ``unit_distance``), as the scene key
``boxes_2d`` stores it. Every edit rebuilds the table exactly as :meth:`TransferFunction2D.from_boxes` does, so
the editor's function is the one a scene file with the same keys gives. The histogram drawn under the boxes is
:func:`histogram_2d`'s, shown as log1p of the counts (a few dense bins would otherwise hide the rest).
"""
from __future__ import annotations

import numpy as np

from ..renderers.registry import plugin
from ..transfer_function_2d import BOX_TABLE_SIZE, TransferFunction2D, histogram_2d

#: a new box's size as a fraction of each axis, and its colour and alpha
NEW_BOX_FRACTION = 0.1
NEW_BOX_RGBA = (1.0, 1.0, 1.0, 0.5)


def renders_2d(renderer: str, kind: str = "grid") -> bool:
    """Whether the renderer declares it classifies ``kind`` data with a 2D transfer function (its trait)."""
    return kind in plugin(renderer).transfer_function_2d


class BoxEditor2D:
    """The boxes of one field's 2D transfer function, and the histogram they are drawn over."""

    def __init__(self, data, spacing, boxes=(), bins=BOX_TABLE_SIZE, unit_distance: float = 1.0):
        counts, self.value_range, self.gradient_range = histogram_2d(data, spacing, bins=bins)
        self.log_counts = np.log1p(counts)
        self.size, self.unit_distance = tuple(bins), unit_distance
        self.boxes = [list(map(float, b)) for b in boxes]

    @property
    def transfer_function(self) -> TransferFunction2D:
        """The function the boxes draw (an empty editor: a transparent table)."""
        if not self.boxes:  # from_boxes refuses none, as a scene file's boxes_2d must hold one
            return TransferFunction2D(np.zeros((*self.size, 4)), self.value_range, self.gradient_range,
                                      self.unit_distance)
        return TransferFunction2D.from_boxes(self.boxes, self.value_range, self.gradient_range, self.size,
                                             self.unit_distance)

    def add(self, value: float, gradient: float) -> int:
        """A box centred at (value, gradient) of a tenth of each axis; its index."""
        w = NEW_BOX_FRACTION * (self.value_range[1] - self.value_range[0])
        h = NEW_BOX_FRACTION * (self.gradient_range[1] - self.gradient_range[0])
        self.boxes.append([value - w / 2, gradient - h / 2, w, h, *NEW_BOX_RGBA])
        return len(self.boxes) - 1

    def move(self, i: int, value: float, gradient: float):
        """Box i's lower corner to (value, gradient)."""
        self.boxes[i][0:2] = [float(value), float(gradient)]

    def resize(self, i: int, width: float, height: float):
        """Box i's width and height (field units; kept positive, as from_boxes requires)."""
        self.boxes[i][2:4] = [max(float(width), 1e-12), max(float(height), 1e-12)]

    def set_color(self, i: int, rgb):
        self.boxes[i][4:7] = [float(np.clip(c, 0.0, 1.0)) for c in rgb]

    def set_opacity(self, i: int, alpha: float):
        self.boxes[i][7] = float(np.clip(alpha, 0.0, 1.0))

    def delete(self, i: int):
        del self.boxes[i]

    def pick(self, value: float, gradient: float) -> int | None:
        """The topmost box containing (value, gradient), or None."""
        for i in reversed(range(len(self.boxes))):
            x, y, w, h = self.boxes[i][:4]
            if x <= value <= x + w and y <= gradient <= y + h:
                return i
        return None

    def scene_keys(self) -> dict:
        """The ``[transfer_function]`` keys a saved scene holds (schema: boxes_2d, value_range_2d, ...)."""
        return {"boxes_2d": [list(b) for b in self.boxes], "value_range_2d": list(self.value_range),
                "gradient_range_2d": list(self.gradient_range), "size_2d": list(self.size)}
