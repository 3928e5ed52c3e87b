"""Opaque triangle meshes in the scene (``[[renderer.geometry]]``, docs/geometry.md).

A mesh is read once (OBJ by :func:`_obj_faces`, ``.vtk``/``.vtu`` by the strict readers of
:mod:`dvr_gl.io.mesh_vtk`, PLY and STL by meshio; quadrilaterals and polygons split into
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

from . import limits, progress
from .checks import WORLD_RANGE
from .clipping import ClipRegion
from .errors import SceneError, install_hint
from .rays import RayBatch
from .sandbox import check_bytes, check_input_path
from .shading import blinn_phong

#: Memory while reading a mesh file, per byte of the file (meshio's peak, with a margin).
BYTES_PER_FILE_BYTE = 10


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
    name = os.path.basename(path)
    # meshio's peak while reading is up to 7x the file (binary STL; OBJ 6x, PLY 5x: measured)
    check_bytes(size * float(BYTES_PER_FILE_BYTE), f"reading the mesh {name} (renderer.geometry)",
                "use a smaller mesh (fewer triangles)")
    if path.lower().endswith((".vtk", ".vtu")):
        points, faces = _vtk_faces(path)
    elif path.lower().endswith(".obj"):
        points, faces = _obj_faces(path)
    else:
        points, faces = _meshio_faces(path)
    triangles = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    if not len(triangles):
        raise SceneError(f"renderer.geometry: {name} has no triangles, quadrilaterals or polygons")
    if triangles.min() < 0 or triangles.max() >= len(points):
        raise SceneError(f"renderer.geometry: {name} has faces that name missing points")
    used = points[np.unique(triangles)]
    if not np.isfinite(used).all():
        raise SceneError(f"renderer.geometry: {name} has points that are not finite (NaN or Inf)")
    reach = float(np.abs(used).max())
    if reach > WORLD_RANGE[1]:  # beyond, the float64 test's products overflow (and float32 GL's)
        raise SceneError(f"renderer.geometry: {name} has points {reach:.3g} world units from the origin, beyond "
                         f"{WORLD_RANGE[1]:g}; rescale or move the mesh")
    return TriangleMesh(points, triangles, name)


def _obj_faces(path: str):
    """Points and triangle blocks of a Wavefront OBJ file: ``v x y z`` and ``f`` lines (``i``, ``i/t``,
    ``i//n``, ``i/t/n``; negative indices count back from the last vertex so far, as the format says,
    which meshio misread as missing points); other statements are ignored."""
    name = os.path.basename(path)
    with open(path, "rb") as f:
        text = f.read().replace(b"\\\r\n", b" ").replace(b"\\\n", b" ")  # continued lines joined
    vertices, faces = [], {}
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split()
        if not words or words[0] not in (b"v", b"f"):
            continue
        try:
            if words[0] == b"v":
                if len(words) < 4:
                    raise ValueError("a vertex needs x, y and z")
                vertices.append((float(words[1]), float(words[2]), float(words[3])))
                continue
            corners = []
            for word in words[1:]:
                i = int(word.split(b"/")[0])
                if i == 0 or not -len(vertices) <= i <= 2**62:
                    raise ValueError(f"vertex {i} (of {len(vertices)} so far)")
                corners.append(i - 1 if i > 0 else len(vertices) + i)
        except ValueError as exc:
            raise SceneError(f"renderer.geometry: {name}, line {number}: {line.decode('latin-1')[:40]!r} is not a "
                             f"vertex or face ({exc}); fix the OBJ file") from None
        if len(corners) >= 3:
            faces.setdefault(len(corners), []).append(corners)
    points = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    blocks = []
    for n, cells in faces.items():  # fans from the first corner
        cells = np.array(cells, dtype=np.int64)
        blocks += [cells[:, [0, k, k + 1]] for k in range(1, n - 1)]
    return points, blocks


READABLE = "give an OBJ, PLY or STL file, or a VTK file (.vtk, .vtu) of surface cells"


def _meshio_faces(path: str):
    """Points and triangle blocks of a PLY or STL file (or another format meshio knows) read by meshio (a
    PLY header checked first:
    meshio loops forever on one cut short, and for every face an ``element face`` count claims)."""
    try:
        import meshio
    except ImportError:
        raise SceneError(f"renderer.geometry: reading meshes needs meshio: {install_hint('mesh')}") from None
    from .io.mesh import UnreadableMesh, quiet_read

    name = os.path.basename(path)
    if path.lower().endswith(".ply"):
        _check_ply_header(path)
    try:
        mesh = quiet_read(meshio, path)
    except UnreadableMesh as exc:  # one line, not meshio's prints or a traceback
        raise SceneError(f"renderer.geometry: cannot read {name} as a mesh ({exc}); {READABLE}") from None
    points = np.asarray(mesh.points)
    if points.ndim != 2 or points.shape[1] not in (2, 3) or points.dtype.kind not in "iuf":
        raise SceneError(f"renderer.geometry: {name} has no 3D points")
    points = points.astype(np.float64)
    if points.shape[1] == 2:
        points = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
    faces = []
    for block in mesh.cells:
        cells = np.asarray(block.data)
        if block.type in ("triangle", "quad", "polygon") or block.type.startswith("polygon"):
            if cells.ndim != 2 or cells.shape[1] < 3 or cells.dtype.kind not in "iu":
                continue
            cells = cells.astype(np.int64)
            for k in range(1, cells.shape[1] - 1):  # a fan from the first corner
                faces.append(cells[:, [0, k, k + 1]])
    return points, faces


#: Bytes of a PLY header read to find its end (headers are a few hundred bytes; comments may add more).
PLY_HEADER_BYTES = 1 << 20


def _check_ply_header(path: str):
    """A PLY header must end (an ``end_header`` line) and its element counts fit the file."""
    name = os.path.basename(path)
    with open(path, "rb") as f:
        head = f.read(PLY_HEADER_BYTES)
    size = os.path.getsize(path)
    lines = head.split(b"\n")
    ends = [i for i, line in enumerate(lines) if line.strip() == b"end_header"]
    if not ends:
        raise SceneError(f"renderer.geometry: cannot read {name} as a mesh (no 'end_header' line in its first "
                         f"{PLY_HEADER_BYTES >> 20} MiB: a PLY file cut short, or not PLY); {READABLE}")
    for line in lines[:ends[0]]:
        words = line.split()
        if words[:1] == [b"element"]:
            if len(words) != 3 or not words[2].isdigit() or int(words[2]) > size:
                raise SceneError(f"renderer.geometry: {name}: {line.decode('latin-1')[:60]!r} does not count what a "
                                 f"file of {size} bytes can hold; the PLY header is damaged")


def _vtk_faces(path: str):
    """Points and triangle blocks of a legacy ``.vtk`` (POLYDATA or UNSTRUCTURED_GRID) or ``.vtu`` file,
    read strictly (:mod:`dvr_gl.io.mesh_vtk`): triangles, quadrilaterals, pixels and polygons as fans,
    triangle strips as their triangles."""
    from .errors import VolumeError
    from .io.mesh_vtk import check_cells, read_legacy, read_vtu

    try:
        grid = read_vtu(Path(path)) if path.lower().endswith(".vtu") else read_legacy(Path(path))
        check_cells(path, grid)
    except VolumeError as exc:
        raise SceneError(f"renderer.geometry: {exc}") from None
    sizes = np.diff(grid.offsets)
    starts = grid.offsets[:-1]
    faces = []
    for t in (5, 7, 8, 9):  # triangle, polygon, pixel (corners 0 1 3 2), quad: fans from the first corner
        for n in np.unique(sizes[grid.types == t]).tolist():
            first = starts[(grid.types == t) & (sizes == n)]
            cells = grid.connectivity[first[:, None] + np.arange(n)]
            if t == 8:
                cells = cells[:, [0, 1, 3, 2]]
            faces += [cells[:, [0, k, k + 1]] for k in range(1, n - 1)]
    for first, n in zip(starts[grid.types == 6].tolist(), sizes[grid.types == 6].tolist()):
        strip = grid.connectivity[first:first + n]
        k = np.arange(n - 2)
        faces.append(np.stack([strip[k], strip[k + 1], strip[k + 2]], axis=1))
    return grid.points, faces


def scene_meshes(renderer_spec) -> list[tuple[TriangleMesh, np.ndarray]]:
    """The scene's meshes with their colours (paths as resolved: absolute)."""
    return [(read_mesh(g.path), np.asarray(g.color, dtype=np.float64))
            for g in getattr(renderer_spec, "geometry", None) or []]


def first_hits(meshes, origins: np.ndarray, directions: np.ndarray):
    """The nearest surface along each ray at ``t > 0``: ``(t (N,), normal (N, 3), colour (N, 3))``,
    ``t`` infinite where a ray meets none; ``normal`` the face's unit normal turned toward the ray's
    origin.  Moller and Trumbore's test in float64, edges and corners included, of the pairs that
    :class:`HitPlan` finds can meet (the work is refused over ``limits.bound`` by :func:`check_surface_work`, with
    progress)."""
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    best = np.full(len(o), np.inf)
    normal = np.zeros((len(o), 3))
    colour = np.zeros((len(o), 3))
    triangles = sum(len(mesh.triangles) for mesh, _ in meshes)
    check_bytes(PAIR_CHUNK * BYTES_PER_PAIR + triangles * float(BYTES_PER_HOST_TRIANGLE) + len(o) * 160.0,
                f"testing {len(o)} rays against {triangles} triangles (renderer.geometry)",
                "lower --size or use a smaller mesh (fewer triangles)")
    corners, faces, rgbs, owner = [], [], [], []
    for k, (mesh, rgb) in enumerate(meshes):
        c = mesh.corners
        face = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        length = np.linalg.norm(face, axis=1)
        keep = length > 0  # degenerate triangles cover nothing
        corners.append(c[keep])
        faces.append(face[keep] / length[keep, None])
        owner.append(np.full(int(keep.sum()), k))
        rgbs.append(np.asarray(rgb, dtype=np.float64))
    if not len(o) or not sum(len(c) for c in corners):
        return best, normal, colour  # (a mesh of degenerate triangles only covers nothing)
    c, face, owner = np.concatenate(corners), np.concatenate(faces), np.concatenate(owner)
    a, e1, e2 = c[:, 0], c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    plan = HitPlan(o, d, c)
    check_surface_work(plan.pairs, len(o), len(c))
    tri = np.full(len(o), -1)
    with progress.task("surfaces", int(plan.pairs), "test") as step:
        done = 0
        for ray, idx in plan.chunks():
            t = _hit(o[ray], d[ray], a[idx], e1[idx], e2[idx])
            found = np.isfinite(t)
            ray, idx, t = ray[found], idx[found], t[found]
            order = np.lexsort((idx, t, ray))  # per ray, the nearest first (ties: the first triangle)
            ray, idx, t = ray[order], idx[order], t[order]
            first = np.ones(len(ray), bool)
            first[1:] = ray[1:] != ray[:-1]
            ray, idx, t = ray[first], idx[first], t[first]
            closer = (t < best[ray]) | ((t == best[ray]) & (idx < tri[ray]))
            best[ray[closer]], tri[ray[closer]] = t[closer], idx[closer]
            done += len(found)
            step(done)
    seen = tri >= 0
    n = face[tri[seen]]
    normal[seen] = np.where(np.sum(n * d[seen], axis=1, keepdims=True) > 0, -n, n)  # toward the eye
    colour[seen] = np.asarray(rgbs)[owner[tri[seen]]]
    return best, normal, colour


def _hit(o, d, a, e1, e2):
    """Moller and Trumbore per (ray, triangle) pair: the hit parameter, inf where none."""
    p = np.cross(d, e2)
    det = np.einsum("ik,ik->i", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - a
        u = np.einsum("ik,ik->i", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("ik,ik->i", d, q) * inv
        t = np.einsum("ik,ik->i", e2, q) * inv
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)  # (det 0: inf and NaN, not a hit)
    return np.where(hit, t, np.inf)


#: Pairs tested at once (each about :data:`BYTES_PER_PAIR` of float64 temporaries).
PAIR_CHUNK = 1 << 17
BYTES_PER_PAIR = 480
BYTES_PER_HOST_TRIANGLE = 640   # corners, edges, normals, projected boxes and their bins (measured 610)
SURFACE_WORK = "ray-triangle tests"  # the unit of limits.BOUNDS the host test counts
def check_surface_work(pairs: float, rays: int, triangles: int) -> None:
    limits.check_work(limits.Work(pairs, SURFACE_WORK, f"{rays} rays against the {triangles} triangles their "
                                  "boxes cover", "lower --size, use a mesh with fewer or smaller triangles, or a GL "
                                  "renderer that rasterizes them"), "the surfaces")


class HitPlan:
    """Which (ray, triangle) pairs can meet, found in 2D without testing them all.

    Rays through one point (a perspective camera) are placed by where their direction crosses a plane
    in front of that point, rays of one direction (orthographic) by where they cross a plane across it;
    a triangle wholly in front of the point projects to a triangle there that every ray meeting it
    crosses (a projective map keeps lines), so its box, widened by a rounding margin, holds those
    rays.  The rays are binned about two to a cell of a grid over their extent and a triangle tested
    against the rays of the cells its box covers.  A triangle straddling the plane through the point
    is tested against every ray, and rays nearly across the view direction (or rays that share
    neither origin nor direction) against every triangle.  ``pairs`` counts the tests (the work)."""

    def __init__(self, o: np.ndarray, d: np.ndarray, corners: np.ndarray):
        n_rays, n_tris = len(o), len(corners)
        scale = max(float(np.abs(corners).max()), float(np.abs(o).max()), 1.0)
        dn = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
        self.rays_all = np.zeros(0, np.int64)       # rays tested against every triangle
        self.tris_all = np.zeros(0, np.int64)       # triangles tested against every binned ray
        if np.ptp(o, axis=0).max() <= 1e-12 * scale:                       # one origin
            f = _unit(dn.mean(axis=0))
            r, u = _frame(f)
            depth = dn @ f
            binned = depth > 0.2
            ray_xy = np.stack([dn @ r, dn @ u], axis=1)[binned] / depth[binned, None]
            v = corners - o[0]
            z = v @ f
            front = (z > 1e-9 * np.linalg.norm(v, axis=2)).all(axis=1)
            behind = (z <= 0).all(axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                tri_xy = np.stack([v @ r, v @ u], axis=2) / z[..., None]
            boxed = front
            self.tris_all = np.flatnonzero(~front & ~behind)
        elif np.ptp(dn, axis=0).max() <= 1e-12:                          # one direction
            f = _unit(dn[0])
            r, u = _frame(f)
            binned = np.ones(n_rays, bool)
            ray_xy = np.stack([o @ r, o @ u], axis=1)
            tri_xy = np.stack([corners @ r, corners @ u], axis=2)
            boxed = np.ones(n_tris, bool)
        else:                                                               # anything else: all pairs
            binned = np.zeros(n_rays, bool)
            boxed = np.zeros(n_tris, bool)
            ray_xy = np.zeros((0, 2))
            tri_xy = np.zeros((n_tris, 3, 2))
        self.rays_all = np.flatnonzero(~binned)
        self.n_tris = n_tris
        self.order = np.flatnonzero(binned)                                   # binned rays, by cell below
        self.entries = np.zeros((0, 3), np.int64)                             # (triangle, first, count)
        if len(self.order):
            self._bin(ray_xy, tri_xy[boxed], np.flatnonzero(boxed), scale)
        self.pairs = float(self.entries[:, 2].sum()) + float(len(self.rays_all)) * n_tris \
            + float(len(self.tris_all)) * len(self.order)

    def _bin(self, ray_xy, tri_xy, tris, scale):
        lo, hi = ray_xy.min(axis=0), ray_xy.max(axis=0)
        extent = np.maximum(hi - lo, 1e-12 * max(float(np.abs(ray_xy).max()), 1e-300))
        cells = max(1, len(ray_xy) // 2)
        ratio = float(np.clip(extent[0] / extent[1], 1.0 / cells, cells))
        gx = int(np.clip(round(np.sqrt(cells * ratio)), 1, cells))
        gy = int(np.clip(cells // gx, 1, cells))
        size = extent / [gx, gy]
        cell = np.minimum(((ray_xy - lo) / size).astype(np.int64), [gx - 1, gy - 1])
        ids = cell[:, 1] * gx + cell[:, 0]
        sort = np.argsort(ids, kind="stable")
        self.order = self.order[sort]
        start = np.searchsorted(ids[sort], np.arange(gx * gy + 1))           # rays of cell k: start[k]..start[k+1]
        margin = 1e-9 * (float(np.abs(tri_xy).max(initial=0.0)) + float(np.abs(ray_xy).max())) + 1e-12 * scale
        grid = np.array([gx, gy], dtype=np.float64)
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):  # far boxes: clipped to the grid
            box_lo = np.floor(np.clip((tri_xy.min(axis=1) - margin - lo) / size, -1.0, grid))
            box_hi = np.floor(np.clip((tri_xy.max(axis=1) + margin - lo) / size, -1.0, grid))
        inside = (box_hi[:, 0] >= 0) & (box_hi[:, 1] >= 0) & (box_lo[:, 0] < gx) & (box_lo[:, 1] < gy)
        tris = tris[inside]
        x0 = np.clip(box_lo[inside, 0], 0, gx - 1).astype(np.int64)
        x1 = np.clip(box_hi[inside, 0], 0, gx - 1).astype(np.int64)
        y0 = np.clip(box_lo[inside, 1], 0, gy - 1).astype(np.int64)
        y1 = np.clip(box_hi[inside, 1], 0, gy - 1).astype(np.int64)
        rows = y1 - y0 + 1                                                    # one entry per triangle and grid row
        tri = np.repeat(tris, rows)
        row = np.repeat(y0, rows) + _ramp(rows)
        first = start[row * gx + np.repeat(x0, rows)]
        count = start[row * gx + np.repeat(x1, rows) + 1] - first
        keep = count > 0
        self.entries = np.stack([tri[keep], first[keep], count[keep]], axis=1)

    def chunks(self):
        """``(rays, triangles)`` index pairs, :data:`PAIR_CHUNK` at most at a time."""
        tris = np.arange(self.n_tris)
        for r in range(0, len(self.rays_all), max(1, PAIR_CHUNK // max(self.n_tris, 1))):
            rays = self.rays_all[r:r + max(1, PAIR_CHUNK // max(self.n_tris, 1))]
            yield np.repeat(rays, self.n_tris), np.tile(tris, len(rays))
        for t in self.tris_all:
            for r in range(0, len(self.order), PAIR_CHUNK):
                rays = self.order[r:r + PAIR_CHUNK]
                yield rays, np.full(len(rays), t)
        entries = _split(self.entries, PAIR_CHUNK)
        ends = np.cumsum(entries[:, 2])
        at = 0
        while at < len(entries):
            stop = int(np.searchsorted(ends, (ends[at - 1] if at else 0) + PAIR_CHUNK, side="right"))
            stop = max(stop, at + 1)
            part = entries[at:stop]
            count = part[:, 2]
            positions = np.repeat(part[:, 1], count) + _ramp(count)
            yield self.order[positions], np.repeat(part[:, 0], count)
            at = stop


def _ramp(counts: np.ndarray) -> np.ndarray:
    """``0..n-1`` for each ``n`` of ``counts``, concatenated."""
    counts = np.asarray(counts, dtype=np.int64)
    total = int(counts.sum())
    if not total:
        return np.zeros(0, np.int64)
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total, dtype=np.int64) - starts


def _split(entries: np.ndarray, most: int) -> np.ndarray:
    """Entries ``(triangle, first, count)`` with counts over ``most`` cut into pieces of ``most``."""
    big = entries[:, 2] > most
    if not big.any():
        return entries
    pieces = -(-entries[:, 2] // most)
    out = np.repeat(entries, pieces, axis=0)
    k = _ramp(pieces)
    out[:, 1] += k * most
    out[:, 2] = np.minimum(np.repeat(entries[:, 2], pieces) - k * most, most)
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 0 else np.array([0.0, 0.0, 1.0])


def _frame(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across ``f`` (and each other)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(f[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    r = _unit(np.cross(f, helper))
    return r, np.cross(f, r)


def surface_rgba(scene, rays) -> np.ndarray | None:
    """``(N, 4)`` premultiplied RGBA of the scene's surfaces seen by ``rays`` (alpha 1 where a ray meets
    one, before its ``t1``), with ``rays.t1`` narrowed to the surfaces; None without geometry.  The
    references call it on their rays before integrating."""
    meshes = scene_meshes(scene.renderer)
    if not meshes:
        return None
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


def chord_lengths(scene) -> np.ndarray:
    """``(H, W)``: each pixel's ray's length inside the field's box (from the near plane, inside the
    clipped region, before a mesh; 0 for a miss), the length an average divides by (world units)."""
    rays = RayBatch.for_camera(scene.camera, scene.image.width, scene.image.height, scene.field.bounds,
                               clip=ClipRegion.of(scene.renderer))
    surface_rgba(scene, rays)  # meshes end the chords
    return np.maximum(rays.t1 - rays.t0, 0.0).reshape(scene.image.height, scene.image.width)


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
