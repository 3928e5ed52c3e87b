"""Camera matrices and proxy geometry for the slicing renderers.

The matrices reproduce :meth:`dvr_gl.camera.Camera.pixel_rays`: a point projects
to the pixel whose ray passes through it.  Matrices are numpy row-major
(``clip = P V x``); :func:`gl_matrix` gives the column-major bytes GL expects.
"""

from __future__ import annotations

import numpy as np

# The 12 edges of a box as pairs of corner indices; corner i has x = bit 0, y = bit 1, z = bit 2.
BOX_EDGES = np.array([(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
                      (0, 4), (1, 5), (2, 6), (3, 7)])


def box_corners(lo, hi) -> np.ndarray:
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return np.array([[(hi if i & 1 else lo)[0], (hi if i & 2 else lo)[1], (hi if i & 4 else lo)[2]]
                     for i in range(8)])


def view_matrix(camera) -> np.ndarray:
    f, r, u = camera.basis()
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = r, u, -f
    m[:3, 3] = -m[:3, :3] @ np.asarray(camera.eye)
    return m


def projection_matrix(camera, aspect: float, near: float, far: float) -> np.ndarray:
    p = np.zeros((4, 4))
    half_w, half_h = camera.half_extent(aspect)
    p[0, 0], p[1, 1] = 1.0 / half_w, 1.0 / half_h
    if camera.projection == "perspective":
        p[2, 2], p[2, 3] = (far + near) / (near - far), 2.0 * far * near / (near - far)
        p[3, 2] = -1.0
    else:
        p[2, 2], p[2, 3] = -2.0 / (far - near), -(far + near) / (far - near)
        p[3, 3] = 1.0
    return p


def depth_range(camera, lo, hi) -> tuple[float, float]:
    """Nearest and farthest depth (along the view axis from the eye) of the box's corners."""
    f, _, _ = camera.basis()
    depths = (box_corners(lo, hi) - np.asarray(camera.eye)) @ f
    return float(depths.min()), float(depths.max())


def clip_planes(camera, lo, hi) -> tuple[float, float]:
    """Near and far clip distances for drawing the box: far beyond it, and near at the camera's but
    at least 1e-3 of the box diagonal for a perspective matrix.  A nearer near plane squeezes every
    depth against 1 in normalized device coordinates, and float32 rounding then pushes vertices past
    the far plane, clipping whole triangles (seen with 1e-6).  Renderers that draw geometry take
    this near plane as their camera's (see :func:`dvr_gl.renderers.slicing.reference`)."""
    diag = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
    _, far = depth_range(camera, lo, hi)
    near = max(camera.near, 1e-3 * diag) if camera.projection == "perspective" else camera.near
    return near, max(far, near) + 0.01 * diag + 1e-6


def gl_matrix(m: np.ndarray) -> bytes:
    return np.ascontiguousarray(m.T, dtype=np.float32).tobytes()


def slice_polygons(normal, offsets: np.ndarray, lo, hi, reference_point, right, up) -> np.ndarray:
    """Triangles ``(K, 10, 3, 3)`` (with NaN padding) of the polygons where the planes
    ``(x - reference_point) . normal = offset`` cut the box; 3 to 6 vertices each, ordered by angle
    in the plane (``right``, ``up``), fanned from the first."""
    corners = box_corners(lo, hi)
    depth = (corners - np.asarray(reference_point)) @ np.asarray(normal)      # (8,)
    a, b = BOX_EDGES[:, 0], BOX_EDGES[:, 1]
    da, db = depth[a], depth[b]
    with np.errstate(divide="ignore", invalid="ignore"):  # edges parallel to the planes: no cut
        s = (offsets[:, None] - da[None, :]) / (db - da)[None, :]             # (K, 12)
        cut = (s >= 0) & (s <= 1) & np.isfinite(s)
        points = corners[a][None] + s[..., None] * (corners[b] - corners[a])[None]  # (K, 12, 3)
    points[~cut] = np.nan
    centre = np.nanmean(points, axis=1, keepdims=True)
    rel = points - centre
    angle = np.arctan2(rel @ np.asarray(up), rel @ np.asarray(right))
    angle[~cut] = np.inf                                                      # padding last
    order = np.argsort(angle, axis=1)
    points = np.take_along_axis(points, order[..., None], axis=1)
    count = cut.sum(axis=1)
    tris = np.full((len(offsets), 10, 3, 3), np.nan)
    for i in range(1, 11):
        ok = i + 1 < count
        tris[ok, i - 1, 0] = points[ok, 0]
        tris[ok, i - 1, 1] = points[ok, i]
        tris[ok, i - 1, 2] = points[ok, i + 1]
    return tris
