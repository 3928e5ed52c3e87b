"""Reconstruction filters in float64: the continuous field a regular grid stands for.

Voxel coordinate ``u = (p - origin) / spacing`` per axis; sample ``i`` sits at
``u = i``.  Out-of-range taps are clamped to the edge (as GL's
CLAMP_TO_EDGE), so the field is defined on and slightly beyond the box.

* ``nearest``: the sample at ``floor(u + 0.5)``.
* ``linear``: trilinear interpolation between the 8 surrounding samples.
* ``cubic_bspline``: the uniform cubic B-spline applied to the samples (an
  approximating, smoothing, C2 filter; the GPU evaluates it with 8 trilinear
  fetches, Sigg & Hadwiger 2005).
* ``catmull_rom``: the interpolating Catmull-Rom cubic (C1; may overshoot).

The ray-space structure of each field is known: the filter is a polynomial
between *knots* (``u`` integer; half-integer for nearest), which the
converged integrator uses to split rays into smooth pieces.
"""

from __future__ import annotations

import numpy as np

from ..model import FILTERS
from .ragged import ranges

TAPS = {"nearest": 1, "linear": 2, "cubic_bspline": 4, "catmull_rom": 4}
# Degree of the field as a polynomial of the ray parameter between knots.
DEGREE = {"nearest": 0, "linear": 3, "cubic_bspline": 9, "catmull_rom": 9}


def _axis_taps(u: np.ndarray, n: int, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Tap indices and weights ``(N, taps)`` along one axis."""
    if kind == "nearest":
        i = np.clip(np.floor(u + 0.5), 0, n - 1).astype(np.int64)
        return i[:, None], np.ones((len(u), 1))
    if kind == "linear":
        uc = np.clip(u, 0.0, n - 1)
        i0 = np.clip(np.floor(uc), 0, max(n - 2, 0)).astype(np.int64)
        f = uc - i0
        idx = np.stack([i0, np.minimum(i0 + 1, n - 1)], axis=1)
        return idx, np.stack([1.0 - f, f], axis=1)
    i = np.floor(u)
    f = u - i
    f2, f3 = f * f, f * f * f
    if kind == "cubic_bspline":
        w = np.stack([(1 - f) ** 3 / 6.0, (3 * f3 - 6 * f2 + 4) / 6.0,
                      (-3 * f3 + 3 * f2 + 3 * f + 1) / 6.0, f3 / 6.0], axis=1)
    elif kind == "catmull_rom":
        w = np.stack([(-f3 + 2 * f2 - f) / 2.0, (3 * f3 - 5 * f2 + 2) / 2.0,
                      (-3 * f3 + 4 * f2 + f) / 2.0, (f3 - f2) / 2.0], axis=1)
    else:
        raise ValueError(f"unknown filter {kind!r}; choose one of {', '.join(FILTERS)}")
    idx = np.clip(i.astype(np.int64)[:, None] + np.arange(-1, 3)[None, :], 0, n - 1)
    return idx, w


class SampledField:
    """A volume (scalar ``(nz, ny, nx)`` or multi-channel ``(nz, ny, nx, C)``) reconstructed by a filter."""

    def __init__(self, values: np.ndarray, spacing, origin, kind: str = "linear"):
        if kind not in TAPS:
            raise ValueError(f"unknown filter {kind!r}; choose one of {', '.join(FILTERS)}")
        self.values = values
        self.channels = values.shape[3] if values.ndim == 4 else 0
        self.flat = values.reshape(values.shape[0] * values.shape[1] * values.shape[2], -1)
        self.nz, self.ny, self.nx = values.shape[:3]
        self.spacing = np.asarray(spacing, dtype=np.float64)
        self.origin = np.asarray(origin, dtype=np.float64)
        self.kind = kind
        self.degree = DEGREE[kind]

    @classmethod
    def of_volume(cls, volume, kind: str = "linear") -> "SampledField":
        return cls(volume.data, volume.spacing, volume.origin, kind)

    def sample(self, points: np.ndarray) -> np.ndarray:
        """Field values at world points ``(N, 3)``: ``(N,)`` or ``(N, C)`` float64."""
        u = (np.asarray(points, dtype=np.float64) - self.origin) / self.spacing
        ix, wx = _axis_taps(u[:, 0], self.nx, self.kind)
        iy, wy = _axis_taps(u[:, 1], self.ny, self.kind)
        iz, wz = _axis_taps(u[:, 2], self.nz, self.kind)
        out = np.zeros((len(u), self.flat.shape[1]))
        for c in range(iz.shape[1]):
            for b in range(iy.shape[1]):
                row = (iz[:, c] * self.ny + iy[:, b]) * self.nx
                wzy = wz[:, c] * wy[:, b]
                for a in range(ix.shape[1]):
                    out += (wzy * wx[:, a])[:, None] * self.flat[row + ix[:, a]]
        return out if self.channels else out[:, 0]

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """Central differences one voxel apart along each world axis, ``(N, 3)`` in value/world unit."""
        p = np.asarray(points, dtype=np.float64)
        g = np.empty((len(p), 3))
        for axis in range(3):
            h = np.zeros(3)
            h[axis] = self.spacing[axis]
            g[:, axis] = (self.sample(p + h) - self.sample(p - h)) / (2.0 * self.spacing[axis])
        return g

    def knots(self, origins: np.ndarray, directions: np.ndarray, t0: np.ndarray, t1: np.ndarray):
        """Ray parameters in ``(t0, t1)`` where a ray crosses a knot plane of the filter.

        Returns ``(ray_index, t)`` arrays (unsorted).  Between consecutive knots
        the field is a polynomial along the ray (smooth).
        """
        shift = 0.5 if self.kind == "nearest" else 0.0
        rays, ts = [], []
        for axis, n in enumerate((self.nx, self.ny, self.nz)):
            d = directions[:, axis] / self.spacing[axis]
            u0 = (origins[:, axis] - self.origin[axis]) / self.spacing[axis] - shift
            moving = np.abs(d) > 0
            ua = np.where(moving, u0 + t0 * d, 0.0)
            ub = np.where(moving, u0 + t1 * d, 0.0)
            lo = np.ceil(np.minimum(ua, ub))
            hi = np.floor(np.maximum(ua, ub))
            # Only knots inside the grid matter: beyond it the field is clamped (constant per axis).
            lo = np.maximum(lo, 0.0)
            hi = np.minimum(hi, n - 1)
            count = np.where(moving, np.maximum(hi - lo + 1, 0), 0).astype(np.int64)
            if count.sum() == 0:
                continue
            ray = np.repeat(np.arange(len(d)), count)
            knot = ranges(lo, count)
            t = (knot - u0[ray]) / d[ray]
            inside = (t > t0[ray]) & (t < t1[ray])
            rays.append(ray[inside])
            ts.append(t[inside])
        if not rays:
            return np.zeros(0, np.int64), np.zeros(0)
        return np.concatenate(rays), np.concatenate(ts)
