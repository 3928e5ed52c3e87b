"""Clipping planes and a cropping box (``[renderer.clipping]``, docs/clipping.md).

The region kept is the intersection of the half-spaces ``n . x + d >= 0`` and the box, in world
coordinates: convex, so the part of a ray inside it is one interval, found exactly (the volume's own
box narrowed by each plane and the cropping box), and the renderers sample that interval as they
sample the box's: whole segments from its entry, the last one shortened.  Points (shadow rays'
samples, slices' fragments) test :meth:`ClipRegion.inside`.  The shaders do the same in
``dvr_gl/gl/shaders/common/clipping.glsl``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SceneError
from .rays import intersect_box


def clipping_in_use(spec) -> bool:
    """Whether a ``[renderer.clipping]`` table clips anything."""
    return spec is not None and (bool(spec.planes) or spec.box is not None)


def check_clipping(spec) -> None:
    """The table's values, each named by its key: planes with a non-zero normal, a box with min <= max."""
    for i, plane in enumerate(spec.planes):
        if not any(plane[:3]):
            raise SceneError(f"renderer.clipping.planes[{i}] has a zero normal {list(plane[:3])}: give "
                             f"[nx, ny, nz, d] with the normal pointing into the part kept")
    if spec.box is not None:
        lo, hi = spec.box
        if any(a > b for a, b in zip(lo, hi)):
            raise SceneError(f"renderer.clipping.box's first corner {list(lo)} must be at most its second "
                             f"{list(hi)} on every axis: give [[xmin, ymin, zmin], [xmax, ymax, zmax]]")
    if len(spec.planes) > MAX_PLANES:
        raise SceneError(f"renderer.clipping.planes: {len(spec.planes)} planes, at most {MAX_PLANES} (a "
                         f"shader's uniforms); combine them into a cropping box where they are axis-aligned")


#: Planes a scene may give (uniform vectors in the shaders: every GL has room for these).
MAX_PLANES = 16


@dataclass(frozen=True, eq=False)
class ClipRegion:
    """The kept region: ``planes`` ``(P, 4)`` with unit normals (``n . x + d >= 0`` kept), and the box
    ``lo``, ``hi`` (``(3,)``; infinite where there is none)."""

    planes: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def of(cls, renderer_spec) -> "ClipRegion | None":
        """The region of a scene's renderer settings, or None where nothing is clipped."""
        spec = getattr(renderer_spec, "clipping", None)
        if not clipping_in_use(spec):
            return None
        planes = np.asarray(spec.planes, dtype=np.float64).reshape(-1, 4)
        planes = planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)  # d in world units
        if spec.box is None:
            lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        else:
            lo, hi = (np.asarray(c, dtype=np.float64) for c in spec.box)
        return cls(planes, lo, hi)

    @property
    def has_box(self) -> bool:
        return bool(np.isfinite(self.lo).all())

    def inside(self, points: np.ndarray) -> np.ndarray:
        """``(N,)`` bool: whether points ``(N, 3)`` are kept (on a plane or the box's face: kept)."""
        p = np.asarray(points, dtype=np.float64)
        keep = np.all((p >= self.lo) & (p <= self.hi), axis=1)
        if len(self.planes):
            keep &= np.all(p @ self.planes[:, :3].T + self.planes[:, 3] >= 0.0, axis=1)
        return keep

    def interval(self, origins, directions, t0, t1) -> tuple[np.ndarray, np.ndarray]:
        """Rays' ``[t0, t1]`` narrowed to the region (empty: ``t1 <= t0``).  A ray parallel to a plane
        keeps all or nothing by which side its origin is on."""
        o = np.asarray(origins, dtype=np.float64)
        d = np.asarray(directions, dtype=np.float64)
        t0, t1 = np.array(t0, dtype=np.float64), np.array(t1, dtype=np.float64)
        if self.has_box:
            enter, leave = intersect_box(o, d, self.lo, self.hi)
            t0, t1 = np.maximum(t0, enter), np.minimum(t1, leave)
        for n, offset in zip(self.planes[:, :3], self.planes[:, 3]):
            at_origin = o @ n + offset   # signed distance of the ray's origin
            rate = d @ n                 # its change per unit t
            with np.errstate(divide="ignore", invalid="ignore"):
                crossing = -at_origin / rate
            t0 = np.where(rate > 0, np.maximum(t0, crossing), t0)
            t1 = np.where(rate < 0, np.minimum(t1, crossing), t1)
            t1 = np.where((rate == 0) & (at_origin < 0), -np.inf, t1)
        return t0, t1

    def shifted(self, origin) -> "ClipRegion":
        """The same region in coordinates relative to ``origin`` (``x' = x - origin``)."""
        o = np.asarray(origin, dtype=np.float64)
        planes = self.planes.copy()
        planes[:, 3] += planes[:, :3] @ o
        return ClipRegion(planes, self.lo - o, self.hi - o)

    def uniforms(self) -> dict:
        """What ``dvr_gl/gl/shaders/common/clipping.glsl`` reads."""
        out = {}
        if len(self.planes):
            out["u_clip_planes"] = [tuple(p) for p in self.planes]
        if self.has_box:
            out["u_clip_lo"], out["u_clip_hi"] = tuple(self.lo), tuple(self.hi)
        return out

    def defines(self) -> dict:
        return {"CLIPPING": True, "NUM_CLIP_PLANES": len(self.planes), "CLIP_BOX": self.has_box}
