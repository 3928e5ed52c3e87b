"""Half-angle slicing's geometry (Kniss et al. 2003): the slices and the light buffer, shared by the
renderers that slice half-way to the light and their same-discretization reference.

One directional light travels along ``w``; ``l = -w`` points toward it, ``v`` toward the eye (from the
box's centre).  The slices are planes perpendicular to the half-angle vector ``h``, ``spacing`` apart,
anchored at the box centre like the view-aligned ones: ``h = normalize(v + l)`` where the eye and the
light are on the same side (``v . l >= 0``; the slices then go front to back for the eye, blended
with the under operator), else ``h = normalize(l - v)`` (back to front, over).  Either way they are
drawn in order from the light, each slice first into the eye buffer (lit by the light buffer as the
slices before it left it) and then into the light buffer, which accumulates optical depth
``sigma spacing / |l . h|`` per slice, seen orthographically along the light.

The light buffer covers the box's projection along the light: pixel ``(i, j)`` of ``size`` is the
light ray through ``origin + (i + 0.5) / nx * extent_u * u + (j + 0.5) / ny * extent_v * v``; points are
looked up bilinearly between pixel centres, clamped to the edge pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gl.geometry import box_corners


@dataclass(frozen=True)
class HalfAngle:
    normal: np.ndarray        # h, unit
    toward_light: np.ndarray  # l, unit
    eye_front_to_back: bool   # slices drawn front to back for the eye (under) or back to front (over)
    eye: np.ndarray           # the planes' offsets are measured from here along h
    anchor: float             # the offset of the plane through the box centre
    spacing: float
    first: int                # plane indices k (offset anchor + k spacing), in drawing order
    last: int
    step: int                 # +1 or -1: the drawing order from the light
    light_length: float       # the optical depth's length per slice along the light: spacing / |l . h|
    origin: np.ndarray        # the light buffer: its corner, axes (unit) and extents (world)
    axis_u: np.ndarray
    axis_v: np.ndarray
    extent: tuple
    size: tuple               # (nx, ny) pixels

    def order(self) -> np.ndarray:
        """Plane indices in drawing order (nearest the light first)."""
        return np.arange(self.first, self.last + self.step, self.step)

    def offsets(self, ks) -> np.ndarray:
        return self.anchor + np.asarray(ks, dtype=np.float64) * self.spacing

    def light_uv(self, points: np.ndarray) -> np.ndarray:
        """Light-buffer coordinates in [0, 1]^2 of world points."""
        rel = np.asarray(points, dtype=np.float64) - self.origin
        return np.stack([rel @ self.axis_u / self.extent[0], rel @ self.axis_v / self.extent[1]], axis=-1)


def half_angle(camera, box, light_direction, spacing: float, light_buffer_size: int) -> HalfAngle:
    """The half-angle slices and light buffer for a camera, the volume's box ``(lo, hi)``, the light's
    travel direction and the slice spacing (world units); ``light_buffer_size``: pixels along the
    light buffer's longer side."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in box)
    centre = (lo + hi) / 2.0
    eye = np.asarray(camera.eye, dtype=np.float64)
    v = eye - centre if camera.projection == "perspective" else -np.asarray(camera.basis()[0], dtype=np.float64)
    v = v / max(np.linalg.norm(v), 1e-300)
    w = np.asarray(light_direction, dtype=np.float64)
    toward_light = -w / np.linalg.norm(w)
    same_side = float(v @ toward_light) >= 0.0
    h = v + toward_light if same_side else toward_light - v
    if np.linalg.norm(h) < 1e-9:  # the light straight behind the volume, toward the eye: any h along l
        h = toward_light
    h = h / np.linalg.norm(h)
    anchor = float((centre - eye) @ h)
    depths = (box_corners(lo, hi) - eye) @ h
    k_lo = int(np.ceil((depths.min() - anchor) / spacing))
    k_hi = int(np.floor((depths.max() - anchor) / spacing))
    # from the light: the largest offsets along h first (l . h > 0)
    first, last, step = k_hi, k_lo, -1
    # the light buffer: an orthonormal pair across l, the box's projection's extents
    helper = np.array([1.0, 0.0, 0.0]) if abs(toward_light[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(toward_light, helper)
    u /= np.linalg.norm(u)
    vv = np.cross(toward_light, u)
    corners = box_corners(lo, hi)
    cu, cv = corners @ u, corners @ vv
    margin = 1e-6 * float(np.linalg.norm(hi - lo))
    eu, ev = max(cu.max() - cu.min(), margin) + 2 * margin, max(cv.max() - cv.min(), margin) + 2 * margin
    origin = (cu.min() - margin) * u + (cv.min() - margin) * vv + float(centre @ toward_light) * toward_light
    longer = max(eu, ev)
    nx = max(2, int(round(light_buffer_size * eu / longer)))
    ny = max(2, int(round(light_buffer_size * ev / longer)))
    # v (toward the eye) . h > 0: the slices nearest the light are nearest the eye too
    eye_front_to_back = float(v @ h) > 0.0
    return HalfAngle(h, toward_light, eye_front_to_back, eye, anchor, float(spacing), first, last, step,
                     float(spacing / max(abs(toward_light @ h), 1e-12)), origin, u, vv, (eu, ev), (nx, ny))
