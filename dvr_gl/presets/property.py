"""A volume property as other programs write it, and its conversion to our transfer function.

VTK (so 3D Slicer and ParaView) keeps colour and scalar opacity as two piecewise functions with their
own control values; colours are display (sRGB-encoded) numbers, interpolated in the map's colour
space (RGB, Lab, HSV or Moreland's diverging space).  Our :class:`~dvr_gl.transfer_function.
TransferFunction` has one list of points with linear colour, linear between points.  The conversion
takes the union of both functions' values and, between colour points, adds values until linear
interpolation of the linear colour follows the source's interpolation within :data:`COLOUR_TOLERANCE`
(sRGB units): opacity is linear in value, so it is reproduced exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from . import colour

# Largest sRGB difference (0..1) between the source's colour interpolation and ours: half an 8-bit
# step, so an 8-bit picture of the map differs by at most one code value.
COLOUR_TOLERANCE = 0.5 / 255
# Opacity ramp given to a colour map that has none (matplotlib maps, ParaView maps without
# "Points"): 0 at the low end to this alpha per unit distance at the high end, as `viridis` always had.
RAMP_ALPHA = 0.1


@dataclass(frozen=True, eq=False)
class VolumeProperty:
    """A transfer function as written by another program.

    name: its name.  opacity: ``(N, 2)`` rows ``(value, alpha)``, alpha per ``unit_distance``
    (VTK's scalar opacity).  colours: ``(K, 4)`` rows ``(value, r, g, b)``, sRGB-encoded.
    space: how colours are interpolated (:data:`colour.SPACES`).  stretch: values are stretched
    from the colour points' range onto the data's value range (ParaView's presets, colour maps);
    otherwise they are data values (Slicer's, in Hounsfield units for CT).
    shading: ``{"enabled", "ambient", "diffuse", "specular", "shininess"}`` or None.
    gradient_opacity: ``(M, 2)`` rows ``(|gradient|, factor)`` or None (not modelled: see
    :func:`gradient_opacity_is_constant`).  interpolation: VTK's 0 (nearest) or 1 (linear).
    """

    name: str
    opacity: np.ndarray
    colours: np.ndarray
    space: str = "rgb"
    stretch: bool = False
    shading: dict | None = None
    gradient_opacity: np.ndarray | None = None
    interpolation: int = 1
    source: str = ""

    def points(self, value_range=(0.0, 1.0), rescale_intercept: float = 0.0) -> np.ndarray:
        """``(M, 5)`` rows ``(value, r, g, b, alpha)`` in data units, colour linear.

        Stretched properties map their colour range onto ``value_range``; the others are shifted by
        ``rescale_intercept`` (their values are ``data + rescale_intercept``, e.g. Hounsfield units)."""
        cx = self.colours[:, 0]
        ox = self.opacity[:, 0]
        values = np.union1d(cx, ox)
        dense = [values]
        for i in range(len(cx) - 1):  # the colour space's curve between colour points
            n = self._pieces(i)
            if n > 1:
                dense.append(np.linspace(cx[i], cx[i + 1], n + 1)[1:-1])
        values = np.unique(np.concatenate(dense))
        srgb = colour.interpolate(self.colours, values, self.space)
        alpha = np.interp(values, ox, self.opacity[:, 1])
        if self.stretch:  # the colour points' range onto the value range
            lo, hi = (float(v) for v in value_range)
            hi = hi if hi > lo else lo + 1.0
            x0, x1 = float(cx[0]), float(cx[-1])
            placed = lo + (values - x0) * ((hi - lo) / (x1 - x0) if x1 > x0 else 0.0)
        else:
            placed = values - rescale_intercept
        out = np.column_stack([placed, colour.srgb_to_linear(srgb), alpha])
        return _strictly_increasing(out)

    def _pieces(self, i: int) -> int:
        """How many linear pieces colour segment ``i`` needs (powers of two, at most 64)."""
        a, b = self.colours[i, 0], self.colours[i + 1, 0]
        ox, oa = self.opacity[:, 0], self.opacity[:, 1]
        inside = oa[(ox > a) & (ox < b)]
        if max(np.interp([a, b], ox, oa).max(), inside.max(initial=0.0)) == 0.0:
            return 1  # transparent throughout: its colour is never seen
        probe = np.linspace(a, b, 257)
        exact = colour.interpolate(self.colours, probe, self.space)
        for n in (1, 2, 4, 8, 16, 32, 64):
            nodes = np.linspace(a, b, n + 1)
            lin = colour.srgb_to_linear(colour.interpolate(self.colours, nodes, self.space))
            approx = colour.linear_to_srgb(np.stack([np.interp(probe, nodes, lin[:, c]) for c in range(3)], axis=-1))
            if np.max(np.abs(approx - exact)) <= COLOUR_TOLERANCE:
                return n
        return 64


def gradient_opacity_is_constant(prop: VolumeProperty) -> bool:
    """Whether the gradient opacity is 1 for every gradient magnitude >= 0 (then dropping it is
    exact); Slicer's presets write ``4 0 1 255 1`` (1 from 0 to 255, clamped beyond)."""
    g = prop.gradient_opacity
    if g is None or len(g) == 0:
        return True
    inside = g[g[:, 0] >= 0, 1]
    at_zero = np.interp(0.0, g[:, 0], g[:, 1])
    return bool(np.all(inside == 1.0) and at_zero == 1.0 and g[-1, 1] == 1.0)


def unique_values(x: np.ndarray) -> np.ndarray:
    """Control values made strictly increasing as Slicer makes them (vtkMRMLVolumePropertyNode::
    HigherAndUnique): a value not above its predecessor moves 10 float32 steps above it."""
    out = np.array(x, dtype=np.float64)
    for i in range(1, len(out)):
        floor = np.float32(out[i - 1]) if out[i - 1] != 0 else np.finfo(np.float32).tiny
        for _ in range(10):
            floor = np.nextafter(floor, np.float32(np.inf))
        out[i] = max(out[i], float(floor))
    return out


def _strictly_increasing(points: np.ndarray) -> np.ndarray:
    """Drop rows whose value equals its predecessor's after placing (a stretch onto a tiny range)."""
    keep = np.r_[True, np.diff(points[:, 0]) > 0]
    return points[keep]


def flat_rows(numbers, width: int, what: str) -> np.ndarray:
    """A flat list of numbers as ``(N, width)`` rows, refused in one line if ragged or empty."""
    try:
        a = np.asarray(numbers, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise SceneError(f"{what}: not a list of numbers") from None
    if a.size == 0 or a.size % width:
        raise SceneError(f"{what}: {a.size} numbers, not a non-empty multiple of {width}")
    if not np.isfinite(a).all():
        raise SceneError(f"{what}: holds NaN or infinite numbers")
    return a.reshape(-1, width)
