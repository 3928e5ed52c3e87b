"""A field's transfer function as the widget's controls set it (pure; no widgets): a base function (the scene's
own or a preset's), moved and stretched by a window and level, its opacity scaled.

Window and level are in the field's data units (level: the centre of the values the function spans, window:
their width), as on a CT console: the base's control points, spanning ``[lo, hi]``, are mapped linearly onto
``[level - window / 2, level + window / 2]``.  The opacity scale multiplies every point's opacity (alpha, clamped
to 1, or extinction).  At the base's own window and level and a scale of 1 the base is returned unchanged, so
the widget renders exactly the scene it was given.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..transfer_function import TransferFunction, preset


@dataclass(frozen=True)
class Look:
    """``base``: the transfer function before the controls; ``window`` (> 0) and ``level``: data units;
    ``opacity``: the opacity scale (> 0)."""

    base: TransferFunction
    window: float
    level: float
    opacity: float = 1.0

    @classmethod
    def of(cls, tf: TransferFunction) -> "Look":
        """The look that gives ``tf`` itself."""
        lo, hi = tf.domain
        return cls(tf, hi - lo if hi > lo else 1.0, (lo + hi) / 2.0)

    @property
    def span(self) -> tuple[float, float]:
        return self.level - self.window / 2.0, self.level + self.window / 2.0

    def with_(self, **changes) -> "Look":
        return dataclasses.replace(self, **changes)

    def transfer_function(self) -> TransferFunction:
        """The base moved onto the window, its opacity scaled."""
        if not self.window > 0 or not self.opacity > 0:
            raise SceneError(f"window ({self.window:g}) and opacity scale ({self.opacity:g}) must be positive")
        base = self.base
        if self == Look.of(base).with_(opacity=self.opacity) and self.opacity == 1.0:
            return base
        points = base.points.copy()
        lo, hi = base.domain
        if hi > lo:
            new_lo, new_hi = self.span
            points[:, 0] = new_lo + (points[:, 0] - lo) * ((new_hi - new_lo) / (hi - lo))
        else:
            points[:, 0] += self.level - lo
        points[:, 4] *= self.opacity
        if base.opacity_model == "alpha":
            points[:, 4] = np.minimum(points[:, 4], 1.0)
        return TransferFunction(points, unit_distance=base.unit_distance, opacity_model=base.opacity_model)


def preset_look(name: str, field, unit_distance: float, rescale_intercept: float = 0.0) -> Look:
    """The look of preset ``name`` on ``field`` (its value range; CT presets in Hounsfield units through
    ``rescale_intercept``), opacity per ``unit_distance`` world units."""
    tf = preset(name, field.value_range, rescale_intercept, unit_distance=unit_distance)
    return Look.of(tf)
