"""Opaque triangle meshes in the scene (``[[renderer.geometry]]``, docs/geometry.md).

A mesh is read once (meshio: OBJ, PLY, STL, VTK polydata; quadrilaterals and polygons split into
triangles as fans) and kept by path and modification time.  A pixel's ray ends at its nearest
surface: the volume is integrated up to there (the last segment shortened, as at the volume box's
far face), and the surface shows behind it, opaque, Blinn-Phong shaded with ``[renderer.shading]``'s
coefficients and lights (whether or not the volume is shaded), its face normal turned toward the
eye.  :func:`first_hits` finds the surfaces in float64 (Moller and Trumbore's test) for the
references; the GL renderers rasterize the same triangles with a depth buffer.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import SceneError
from .sandbox import check_input_path

#: Rays times triangles tested at once by :func:`first_hits` (float64 arrays of this many entries).
BATCH = 1 << 21


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """``vertices`` ``(V, 3)`` float64 world points, ``triangles`` ``(T, 3)`` int64 indices; ``name``."""

    vertices: np.ndarray
    triangles: np.ndarray
    name: str

    @property
    def corners(self) -> np.ndarray:
        """``(T, 3, 3)``: each triangle's three corners."""
        return self.vertices[self.triangles]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        used = self.vertices[np.unique(self.triangles)]
        return used.min(axis=0), used.max(axis=0)


def read_mesh(path: str | Path) -> TriangleMesh:
    """The triangles of a mesh file (cached by path, size and modification time); the file is checked as
    every input is (:func:`dvr_gl.sandbox.check_input_path`)."""
    p = check_input_path(path, "mesh file (renderer.geometry)")  # a regular file, inside a sandbox's roots
    stat = p.stat()
    return _read(str(p.resolve()), stat.st_size, stat.st_mtime_ns)


@functools.lru_cache(maxsize=8)
def _read(path: str, size: int, mtime: int) -> TriangleMesh:
    try:
        import meshio
    except ImportError:
        raise SceneError("renderer.geometry: reading meshes needs meshio: pip install 'dvr-gl[mesh]'") from None
    from .io.mesh import UnreadableMesh, quiet_read

    try:
        mesh = quiet_read(meshio, path)
    except UnreadableMesh as exc:  # one line, not meshio's prints or a traceback
        raise SceneError(f"renderer.geometry: cannot read {os.path.basename(path)} as a mesh ({exc}); give an "
                         f"OBJ, PLY, STL or VTK polydata file") from None
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise SceneError(f"renderer.geometry: {os.path.basename(path)} has no 3D points")
    if points.shape[1] == 2:
        points = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
    faces = []
    for block in mesh.cells:
        cells = np.asarray(block.data, dtype=np.int64)
        if block.type in ("triangle", "quad", "polygon") or block.type.startswith("polygon"):
            if cells.ndim != 2 or cells.shape[1] < 3:
                continue
            for k in range(1, cells.shape[1] - 1):  # a fan from the first corner
                faces.append(cells[:, [0, k, k + 1]])
    triangles = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    name = os.path.basename(path)
    if not len(triangles):
        raise SceneError(f"renderer.geometry: {name} has no triangles, quadrilaterals or polygons")
    if triangles.min() < 0 or triangles.max() >= len(points):
        raise SceneError(f"renderer.geometry: {name} has faces that name missing points")
    if not np.isfinite(points[np.unique(triangles)]).all():
        raise SceneError(f"renderer.geometry: {name} has points that are not finite (NaN or Inf)")
    return TriangleMesh(points, triangles, name)


def scene_meshes(renderer_spec) -> list[tuple[TriangleMesh, np.ndarray]]:
    """The scene's meshes with their colours (paths as resolved: absolute)."""
    return [(read_mesh(g.path), np.asarray(g.color, dtype=np.float64))
            for g in getattr(renderer_spec, "geometry", None) or []]


def first_hits(meshes, origins: np.ndarray, directions: np.ndarray):
    """The nearest surface along each ray at ``t > 0``: ``(t (N,), normal (N, 3), colour (N, 3))``,
    ``t`` infinite where a ray meets none; ``normal`` the face's unit normal turned toward the ray's
    origin.  Moller and Trumbore's test in float64, edges and corners included."""
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    best = np.full(len(o), np.inf)
    normal = np.zeros((len(o), 3))
    colour = np.zeros((len(o), 3))
    for mesh, rgb in meshes:
        c = mesh.corners
        e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
        face = np.cross(e1, e2)
        length = np.linalg.norm(face, axis=1)
        keep = length > 0  # degenerate triangles cover nothing
        c, e1, e2, face = c[keep], e1[keep], e2[keep], face[keep] / length[keep, None]
        step = max(1, BATCH // max(len(c), 1))
        for start in range(0, len(o), step):
            rows = slice(start, start + step)
            t, tri = _nearest(o[rows], d[rows], c[:, 0], e1, e2)
            closer = t < best[rows]
            idx = np.arange(start, min(start + step, len(o)))[closer]
            best[idx] = t[closer]
            n = face[tri[closer]]
            n = np.where(np.sum(n * d[idx], axis=1, keepdims=True) > 0, -n, n)  # toward the eye
            normal[idx], colour[idx] = n, rgb
    return best, normal, colour


def _nearest(o, d, a, e1, e2):
    """Per ray, the nearest hit parameter among the triangles (inf where none) and its triangle."""
    p = np.cross(d[:, None, :], e2[None, :, :])                     # (R, T, 3)
    det = np.einsum("tk,rtk->rt", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o[:, None, :] - a[None, :, :]
        u = np.einsum("rtk,rtk->rt", s, p) * inv
        q = np.cross(s, e1[None, :, :])
        v = np.einsum("rk,rtk->rt", d, q) * inv
        t = np.einsum("tk,rtk->rt", e2, q) * inv
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)  # (det 0: inf and NaN, not a hit)
    t = np.where(hit, t, np.inf)
    tri = np.argmin(t, axis=1)
    return t[np.arange(len(o)), tri], tri


def surface_rgba(scene, rays) -> np.ndarray | None:
    """``(N, 4)`` premultiplied RGBA of the scene's surfaces seen by ``rays`` (alpha 1 where a ray meets
    one, before its ``t1``), with ``rays.t1`` narrowed to the surfaces; None without geometry.  The
    references call it on their rays before integrating."""
    meshes = scene_meshes(scene.renderer)
    if not meshes:
        return None
    from .reference.shading import blinn_phong

    t, normal, colour = first_hits(meshes, rays.origins, rays.directions)
    seen = np.isfinite(t)
    shading = scene.renderer.shading
    shaded = blinn_phong(colour, normal, rays.directions, shading) if shading.lights else colour
    near = scene.camera.near_distance(rays.directions)
    seen &= t >= near  # a surface before the near plane is cut away with it
    rays.t1 = np.where(seen, np.minimum(rays.t1, t), rays.t1)
    return np.where(seen[:, None], np.concatenate([shaded, np.ones((len(t), 1))], axis=1), 0.0)


def over_surface(rgba: np.ndarray, surface: np.ndarray | None) -> np.ndarray:
    """The volume's premultiplied ``rgba`` ``(..., 4)`` over the opaque surfaces behind it."""
    if surface is None:
        return rgba
    surface = surface.reshape(rgba.shape)
    return rgba + (1.0 - rgba[..., 3:4]) * surface


def icosphere(centre, radius: float, subdivisions: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A sphere's triangles ``(points (V, 3), faces (T, 3))``: an icosahedron's faces split
    ``subdivisions`` times, their corners pushed out to the sphere (the facets lie inside it: the
    largest gap, at a facet's centre, is below ``radius * 0.3 / 4 ** subdivisions``, tested).  For tests and
    pictures."""
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    points = [np.asarray(p, dtype=np.float64) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        middle, faces = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = points[a] + points[b]
                points.append(m / np.linalg.norm(m))
                middle[key] = len(points) - 1
            return middle[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = faces
    return np.asarray(centre) + radius * np.array(points), np.array(f, dtype=np.int32)
