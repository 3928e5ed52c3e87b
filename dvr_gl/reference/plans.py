"""Where the same-discretization reference samples: one plan per family of renderers.

A plan gives every ray a sequence of samples ``k = 0 .. count - 1``: the ray
parameter of each, the length of the slab it stands for, and the slab's front
and back (pre-integration reads the scalar at both).

* :class:`RaySegments` (ray casting): segments of length ``d`` tile ``[t0, t1]``
  from ``t0``, the last one shortened; samples at the midpoint (or jittered).
* :class:`PlaneSamples`: the crossings of the ray with a family of parallel
  planes ``spacing`` apart, each standing for the slab to the next plane along
  the ray, of length ``spacing / |cos|`` (``cos``: the ray direction against the
  planes' normal).  View-aligned planes for 3D texture slicing
  (:func:`view_planes`), voxel planes of one axis for 2D texture stacks
  (:func:`axis_planes`).
"""

from __future__ import annotations

import numpy as np

from ..rays import RayBatch, segment_bounds, segment_counts


class SegmentGrid:
    """Samples ``k .. k + m - 1`` of rays ``rows``: parameters, slab lengths and validity ``(rows, m)``."""

    def __init__(self, rays: RayBatch, t, start, length, valid, rows):
        self.rays, self.rows, self.valid = rays, rows, valid
        self.t = t
        self.start = start
        self.length = np.where(valid, length, 0.0)
        mask = valid.reshape(-1)
        self.points = rays.points(rows, t)[mask]
        self.dirs = np.repeat(rays.directions[rows], t.shape[1], axis=0)[mask]

    def ends(self) -> tuple[np.ndarray, np.ndarray]:
        """World points of the valid slabs' fronts and backs (pre-integration reads both)."""
        mask = self.valid.reshape(-1)
        return (self.rays.points(self.rows, self.start)[mask],
                self.rays.points(self.rows, self.start + self.length)[mask])

    def scatter(self, values: np.ndarray, fill=0.0) -> np.ndarray:
        """Values computed for the valid samples back into a ``(rows, m, ...)`` grid."""
        out = np.full(self.valid.shape + values.shape[1:], fill, dtype=np.float64)
        out[self.valid] = values
        return out


class RaySegments:
    """The conventions' segments (ray casting); early termination applies."""

    terminates = True

    def __init__(self, rays: RayBatch, d: float):
        self.rays, self.d = rays, d
        self.count = segment_counts(rays.t0, rays.t1, d)
        self.slab_length = d

    def grid(self, rows, k: int, m: int) -> SegmentGrid:
        ks = k + np.arange(m)[None, :]
        start, length = segment_bounds(self.rays.t0[rows, None], self.rays.t1[rows, None], ks, self.d)
        valid = ks < self.count[rows, None]
        length = np.where(valid, length, 0.0)
        t = start + self.rays.offset[rows, None] * length
        return SegmentGrid(self.rays, t, start, length, valid, rows)


class PlaneSamples:
    """Crossings with parallel planes: ``t_k = first + k step``, each a slab of ``length`` (per ray).
    Slicing renderers blend every slice: no early termination."""

    terminates = False

    def __init__(self, rays: RayBatch, first, step, count, length, spacing: float):
        self.rays = rays
        self.first, self.step, self.count, self.length = first, step, count.astype(np.int64), length
        self.slab_length = spacing

    def grid(self, rows, k: int, m: int) -> SegmentGrid:
        ks = k + np.arange(m)[None, :]
        t = self.first[rows, None] + ks * self.step[rows, None]
        valid = ks < self.count[rows, None]
        length = np.broadcast_to(self.length[rows, None], t.shape)
        return SegmentGrid(self.rays, t, t, length, valid, rows)


def _crossings(rays: RayBatch, offset: np.ndarray, rate: np.ndarray, anchor: float, spacing: float,
               k_lo=None, k_hi=None) -> PlaneSamples:
    """Planes at signed distance ``anchor + k spacing`` along a normal; a ray's distance is
    ``offset + t rate``.  The samples are the planes crossed inside ``[t0, t1]``, front to back."""
    has = rays.t1 > rays.t0
    moving = has & (rate != 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (offset + rays.t0 * rate - anchor) / spacing   # plane coordinates at t0 and t1
        b = (offset + rays.t1 * rate - anchor) / spacing
    # Planes on the box's faces (2D stacks: the first and last voxel planes) are drawn, so they count
    # even when rounding puts them a hair outside [t0, t1].
    k0 = np.ceil(np.minimum(a, b) - 1e-9)
    k1 = np.floor(np.maximum(a, b) + 1e-9)
    if k_lo is not None:
        k0, k1 = np.maximum(k0, k_lo), np.minimum(k1, k_hi)
    count = np.where(moving, np.maximum(k1 - k0 + 1, 0), 0)
    first_k = np.where(rate > 0, k0, k1)                   # the plane met first along the ray
    direction = np.sign(rate)
    with np.errstate(divide="ignore", invalid="ignore"):
        first = np.where(moving, (anchor + first_k * spacing - offset) / rate, 0.0)
        step = np.where(moving, direction * spacing / rate, 0.0)
    return PlaneSamples(rays, first, step, count, np.abs(step), spacing)


def view_planes(rays: RayBatch, camera, box, spacing: float, normal=None) -> PlaneSamples:
    """Planes perpendicular to the view axis (or ``normal``: half-angle slicing's), ``spacing`` apart,
    anchored at the box centre (3D texture slicing draws these)."""
    f = camera.basis()[0] if normal is None else np.asarray(normal, dtype=np.float64)
    eye = np.asarray(camera.eye)
    centre = (np.asarray(box[0]) + np.asarray(box[1])) / 2.0
    return _crossings(rays, (rays.origins - eye) @ f, rays.directions @ f, float((centre - eye) @ f), spacing)


def stack_axis(camera) -> int:
    """The axis (0 = x, 1 = y, 2 = z) whose slices face the viewer most squarely."""
    f, _, _ = camera.basis()
    return int(np.argmax(np.abs(f)))


def axis_planes(rays: RayBatch, camera, volume, axis: int | None = None) -> PlaneSamples:
    """The volume's voxel planes across ``axis`` (default :func:`stack_axis`; 2D texture stacks)."""
    axis = stack_axis(camera) if axis is None else axis
    spacing = volume.spacing[axis]
    return _crossings(rays, rays.origins[:, axis], rays.directions[:, axis], volume.origin[axis], spacing,
                      0, volume.dims[axis] - 1)
