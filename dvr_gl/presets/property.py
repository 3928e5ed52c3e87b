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

from .. import progress
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
        pieces = self._pieces()
        for n in np.unique(pieces[pieces > 1]):  # the colour space's curve between colour points
            chosen = np.nonzero(pieces == n)[0]
            dense.append(np.linspace(cx[chosen], cx[chosen + 1], n + 1, axis=1)[:, 1:-1].ravel())
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

    def _pieces(self) -> np.ndarray:
        """How many linear pieces each colour segment needs (powers of two, at most 64): all segments at
        once, a block at a time (a segment at a time, each interpolating the whole map, was quadratic in
        the number of points: 40,000 took 40 s)."""
        cx = self.colours[:, 0]
        pieces = np.ones(max(len(cx) - 1, 0), dtype=np.int64)
        if not len(pieces):
            return pieces
        a, b = cx[:-1], cx[1:]
        # opaque somewhere on [a, b] (the opacity is linear between its points and never negative): at
        # an end or at an opacity point strictly inside; the others are never seen, one piece
        ox, oa = self.opacity[:, 0], self.opacity[:, 1]
        positive = np.r_[0, np.cumsum(oa > 0)]
        inner = positive[np.searchsorted(ox, b, "left")] - positive[np.searchsorted(ox, a, "right")]
        seen = np.nonzero((np.interp(a, ox, oa) > 0) | (np.interp(b, ox, oa) > 0) | (inner > 0))[0]
        block = 1024  # segments: 257 probes of 3 channels each, a few MB a block
        starts = range(0, len(seen), block)
        # a bar for a map of many points (about 0.1 s a block on two shared cores: 1.6 million points, the most
        # a 64 MiB file holds, take minutes)
        with progress.task(f"transfer function {self.name}", len(starts), "block") as step:
            for done, start in enumerate(starts):
                chosen = seen[start:start + block]
                pieces[chosen] = self._block_pieces(chosen)
                step(done + 1)
        return pieces

    def _block_pieces(self, chosen: np.ndarray) -> np.ndarray:
        """:meth:`_pieces` for the colour segments ``chosen`` (increasing indices): the fewest evenly spaced
        nodes whose linear colour, interpolated linearly, stays within :data:`COLOUR_TOLERANCE` of the
        source's at 257 probes.  The sRGB encoding is monotone, so that is the linear colour within the
        band the tolerance makes around the source's, decoded once (no encoding per trial).  A segment's
        colours depend on its two ends only: the block interpolates the table of their rows (the whole
        table, converted to Lab or Msh for each block, made a million points quadratic again)."""
        probes = 256
        table = self.colours[np.union1d(chosen, chosen + 1)]
        a, b = self.colours[chosen, 0], self.colours[chosen + 1, 0]
        exact = colour.interpolate(table, np.linspace(a, b, probes + 1, axis=1).ravel(), self.space)
        exact = exact.reshape(len(a), probes + 1, 3)
        low = colour.srgb_to_linear(exact - COLOUR_TOLERANCE)
        high = colour.srgb_to_linear(exact + COLOUR_TOLERANCE)
        out = np.full(len(a), 64, dtype=np.int64)
        left = np.arange(len(a))
        for n in (1, 2, 4, 8, 16, 32, 64):
            nodes = np.linspace(a[left], b[left], n + 1, axis=1).ravel()
            lin = colour.srgb_to_linear(colour.interpolate(table, nodes, self.space))
            lin = lin.reshape(len(left), n + 1, 3)
            # the probes 256 / n to a piece (n divides 256), and the last node
            f = (np.arange(probes // n) / (probes // n))[None, None, :, None]
            approx = (lin[:, :-1, None] * (1.0 - f) + lin[:, 1:, None] * f).reshape(len(left), probes, 3)
            approx = np.concatenate([approx, lin[:, -1:]], axis=1)
            good = ((approx >= low) & (approx <= high)).all(axis=(1, 2))
            out[left[good]] = n
            left, low, high = left[~good], low[~good], high[~good]
            if not len(left):
                break
        return out


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
    HigherAndUnique): a value not above its predecessor moves 10 float32 steps above it.  Values already
    apart are checked at once; from the first that moves, one at a time (each depends on the last)."""
    out = np.array(x, dtype=np.float64)
    if len(out) < 2:
        return out
    with np.errstate(over="ignore"):  # a value beyond float32's range has an infinite floor: refused later
        moved = np.nonzero(out[1:] < _ten_steps_above(out[:-1]))[0]
        for i in range(int(moved[0]) + 1 if moved.size else len(out), len(out)):
            out[i] = max(out[i], float(_ten_steps_above(out[i - 1:i])[0]))
    return out


def _ten_steps_above(values: np.ndarray) -> np.ndarray:
    """10 float32 steps above each value (rounded to float32; 0 counts from float32's smallest normal)."""
    floor = values.astype(np.float32)
    floor[values == 0] = np.finfo(np.float32).tiny
    for _ in range(10):
        floor = np.nextafter(floor, np.float32(np.inf))
    return floor.astype(np.float64)


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
    if np.abs(a).max() > MAX_VALUE:
        raise SceneError(f"{what}: holds numbers beyond +-{MAX_VALUE:g}; give values in the data's range")
    return a.reshape(-1, width)


#: The largest control value (in magnitude): Slicer's unique values step above it in float32, whose
#: largest is 3.4e38 (beyond, the step is infinite).
MAX_VALUE = 1e38
