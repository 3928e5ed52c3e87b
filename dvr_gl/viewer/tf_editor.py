"""Transfer-function editing: control points added, moved, recoloured and deleted (pure; no window).

The editor holds the points ``(value, r, g, b, opacity)`` of a piecewise-linear transfer function
(data units, linear non-associated colour, opacity in the function's ``opacity_model``; see
:mod:`dvr_gl.transfer_function`).  Values stay strictly increasing: a moved point is clamped
between its neighbours (:data:`MIN_GAP` of the value range apart).  At least two points remain.

:class:`CanvasMapping` maps between the editor panel's pixels and (value, opacity), so picking
and dragging are testable without a window.  :meth:`TransferFunctionEditor.save` and
:func:`load_points` read and write a ``[transfer_function]`` table, the same table a scene file
has, so a saved function can be pasted into a scene (or loaded back).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DvrError, SceneError
from ..image import write_text
from ..scene.schema import TransferFunctionSpec, parse_table
from ..toml_writer import dumps, loads_toml
from ..transfer_function import PRESETS, TransferFunction, find_preset, preset

MIN_GAP = 1e-4        # smallest value gap between neighbouring points, as a fraction of the value range
PICK_RADIUS = 7.0     # pixels within which a click picks a point
MIN_POINTS = 2


@dataclass(frozen=True)
class CanvasMapping:
    """Pixels of the editor's canvas (origin top-left, y down) to data value and opacity.

    ``value_range`` spans the canvas width; opacity 0 is the bottom edge and ``opacity_max`` the top.
    """

    x: float
    y: float
    width: float
    height: float
    value_range: tuple[float, float]
    opacity_max: float

    def to_pixel(self, value: float, opacity: float) -> tuple[float, float]:
        lo, hi = self.value_range
        px = self.x + (value - lo) / (hi - lo) * self.width
        py = self.y + self.height * (1.0 - opacity / self.opacity_max)
        return px, py

    def from_pixel(self, px: float, py: float) -> tuple[float, float]:
        """(value, opacity) under a pixel, clamped to the canvas."""
        lo, hi = self.value_range
        fx = min(1.0, max(0.0, (px - self.x) / self.width))
        fy = min(1.0, max(0.0, (py - self.y) / self.height))
        return lo + fx * (hi - lo), (1.0 - fy) * self.opacity_max


CUSTOM = "custom"  # the preset box's name for a function that is no preset (after an edit)


def preset_name(tf: TransferFunction, value_range: tuple[float, float], rescale_intercept: float = 0.0,
                hint: str | None = None) -> str:
    """The preset whose points over ``value_range`` (with ``rescale_intercept``, as the panel applies presets) are
    ``tf``'s, to 1e-9 of their magnitude, as :data:`PRESETS` spells it; :data:`CUSTOM` if none.  ``hint`` (the
    scene's preset, which may be a colour map) is tried first."""
    points = np.asarray(tf.points, dtype=np.float64)
    tolerance = 1e-9 * (1.0 + float(np.abs(points).max(initial=0.0)))
    names = [n for n in PRESETS if n != hint]
    for name in ([hint] if hint else []) + names:
        try:
            found = find_preset(name)
            lo, hi = value_range
            candidate = (np.asarray(PRESETS[found][0](lo, hi if hi > lo else lo + 1.0, rescale_intercept),
                                    dtype=np.float64) if found in PRESETS
                         else preset(found, value_range, rescale_intercept).points)
        except (DvrError, ValueError, KeyError):
            continue
        if candidate.shape == points.shape and np.allclose(candidate, points, rtol=0.0, atol=tolerance):
            return found
    return CUSTOM


def nice_opacity_max(opacities, model: str = "alpha") -> float:
    """A round top for the opacity axis above the largest opacity (alpha: at most 1)."""
    top = float(np.max(opacities)) if len(opacities) else 0.0
    for candidate in (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0):
        if top <= 0.9 * candidate:
            return candidate
    if model == "alpha":
        return 1.0
    return float(10.0 ** np.ceil(np.log10(top / 0.9)))


class TransferFunctionEditor:
    """Editable control points (see the module doc).  ``version`` counts edits."""

    def __init__(self, tf: TransferFunction):
        self.unit_distance = tf.unit_distance
        self.opacity_model = tf.opacity_model
        self.points = np.array(tf.points, dtype=np.float64)
        self.selected: int | None = None
        self.version = 0

    # --- reading ---

    def transfer_function(self) -> TransferFunction:
        return TransferFunction(self.points.copy(), self.unit_distance, self.opacity_model)

    @property
    def opacity_limit(self) -> float:
        return 1.0 if self.opacity_model == "alpha" else np.inf

    def pick(self, mapping: CanvasMapping, px: float, py: float, radius: float = PICK_RADIUS) -> int | None:
        """Index of the point drawn nearest the pixel, if within ``radius`` pixels."""
        xy = np.array([mapping.to_pixel(v, o) for v, o in self.points[:, [0, 4]]])
        dist = np.hypot(xy[:, 0] - px, xy[:, 1] - py)
        i = int(np.argmin(dist))
        return i if dist[i] <= radius else None

    def _gap(self) -> float:
        lo, hi = self.points[0, 0], self.points[-1, 0]
        return MIN_GAP * max(hi - lo, 1e-12)

    # --- editing ---

    def _edited(self, selected: int | None):
        self.selected = selected
        self.version += 1

    def add(self, value: float, opacity: float) -> int:
        """Insert a point at ``value`` with ``opacity`` and the colour the function has there;
        a value on an existing point moves that point's opacity instead.  Returns its index."""
        values = self.points[:, 0]
        same = np.nonzero(np.abs(values - value) <= self._gap())[0]
        if same.size:
            return self.move(int(same[0]), float(values[same[0]]), opacity)
        # colour (and an albedo column, if any) as the function has them there
        row = [np.interp(value, values, self.points[:, c]) for c in range(self.points.shape[1])]
        row[0], row[4] = value, min(max(opacity, 0.0), self.opacity_limit)
        i = int(np.searchsorted(values, value))
        self.points = np.insert(self.points, i, row, axis=0)
        self._edited(i)
        return i

    def move(self, i: int, value: float, opacity: float) -> int:
        """Move point ``i``: its value clamped between its neighbours (the ends move freely
        outward), its opacity to ``[0, limit]``.  Returns ``i``."""
        gap = self._gap()
        lo = self.points[i - 1, 0] + gap if i > 0 else -np.inf
        hi = self.points[i + 1, 0] - gap if i + 1 < len(self.points) else np.inf
        self.points[i, 0] = min(max(value, lo), hi)
        self.points[i, 4] = min(max(opacity, 0.0), self.opacity_limit)
        self._edited(i)
        return i

    def set_color(self, i: int, rgb):
        """Linear colour of point ``i``, each channel clamped to [0, 1]."""
        self.points[i, 1:4] = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
        self._edited(i)

    def delete(self, i: int) -> bool:
        """Remove point ``i`` unless only :data:`MIN_POINTS` are left.  Returns whether it was removed."""
        if len(self.points) <= MIN_POINTS:
            return False
        self.points = np.delete(self.points, i, axis=0)
        self._edited(None)
        return True

    def replace(self, tf: TransferFunction):
        """Take all points (and the opacity model) of another function: a preset, a loaded file."""
        self.points = np.array(tf.points, dtype=np.float64)
        self.unit_distance, self.opacity_model = tf.unit_distance, tf.opacity_model
        self._edited(None)

    # --- files ---

    def save(self, path: Path | str) -> Path:
        """Write the points as a ``[transfer_function]`` table (scene-file syntax), atomically;
        an existing file is not replaced (:class:`~dvr_gl.errors.DvrError`)."""
        path = Path(path)
        if path.exists():
            raise DvrError(f"{path}: exists; choose another file name (saving never replaces a file)")
        text = dumps({"transfer_function": self.transfer_function().to_dict()},
                     header="dvr-gl transfer function (dvr view); paste into a scene file or load in dvr view")
        write_text(path, text, overwrite=False)
        return path


def load_points(path: Path | str) -> TransferFunction:
    """A transfer function from a TOML file with a ``[transfer_function]`` table of ``points``
    (a file saved by the editor, or a scene file)."""
    path = Path(path)
    try:
        raw = loads_toml(path.read_text(encoding="utf-8"), str(path))
    except FileNotFoundError:
        raise SceneError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise SceneError(f"{path}: cannot read a transfer function ({exc})") from None
    table = raw.get("transfer_function")
    if not isinstance(table, dict):
        raise SceneError(f"{path}: no [transfer_function] table")
    spec = parse_table(TransferFunctionSpec, table, "transfer_function")
    if not spec.points:
        raise SceneError(f"{path}: [transfer_function] has no points (presets are chosen in the panel)")
    unit = 1.0 if spec.unit_distance is None else spec.unit_distance  # a file's own; no data here to take a voxel of
    return TransferFunction(np.array(spec.points, dtype=np.float64), unit, spec.opacity_model)
