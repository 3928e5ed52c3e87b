"""Visibility orders of a tetrahedral mesh's cells for compositing (front to back here; drawn
reversed, back to front, with the over operator).

**exact** (default): an order that is right along the ray through every pixel centre, on convex
and non-convex meshes alike.  Along such a ray, two consecutive cells either share a face or are
separated by a gap (a concavity, a hole, another part of the mesh).

* Across every shared face the cell on the eye's side of the face is in front (Williams' MPVO
  relation, 1992): one comparison per interior face and view.
* Across the gaps: the mesh's boundary faces are intersected with the pixels' rays; where a ray
  leaves the mesh through a face of cell A and next enters it through a face of cell B, A is in
  front of B (the rays' sampling of the boundary relations of Williams' XMPVO: exact for the
  pixels drawn, which are the only ones the image has).

A topological sort of these relations (Kahn's, each cell placed by the largest centroid distance
of itself and what is related in front of it) orders every pixel's cells correctly.  A cycle
(cells in front of each other, which happens in real meshes) stops the sort; it is broken by
taking the remaining cell placed nearest the eye as if nothing were in front of it, and counted
(``stats["cycles_broken"]``).

The per-view loops (the faces' relations and the sort) run compiled with numba where it is installed
(:mod:`.order_compiled`, the optional extra ``numba``), else in numpy here: the same order either way.
Where the mesh's own numbering scatters neighbouring cells (:func:`scattered`) they run on the cells
renumbered once per mesh along a space-filling curve (:func:`locality_order`), so that a cell's
neighbours lie near it in memory; ties go by the mesh's own numbering, so the order is the same.

**centroid**: cells by the distance of their centroid from the eye (as VTK's
``vtkCellCenterDepthSort``): fast, and wrong where a large cell's centroid lies behind a small
cell that it hides in part.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import time
from dataclasses import dataclass

import numpy as np

from ...fields.mesh_rays import candidate_pairs, image_plane, paired_faces
from ...fields.ragged import ranges

ORDERS = ("exact", "centroid")
EDGE_MARGIN = 1e-9  # barycentric slack of the boundary faces' ray hits
TOUCHING = 1e-9     # boundary crossings this close along a ray (relative to the mesh's size) meet
EDGE_ON = 1e-9      # a face whose plane passes this close to the eye (relative sine) is seen edge on
PAIRS_PER_CHUNK = 1 << 21
#: A boundary this close to convex (relative to the mesh's size: no boundary point further outside a
#: boundary face's plane) counts as convex, so that no ray crosses it more than twice and no ray need
#: be cast against it.  The shared tetraMesh's flat sides bend by 5.9e-7 (its points' rounding); a
#: ray crossing such a fold three times runs within that of a face's plane, where the GL draw's
#: float32 clipping of the ray against the cells' planes is already a matter of rounding.
CONVEX_SLACK = 1e-6
#: Boundary faces times boundary points tested at most for :attr:`Adjacency.convex` (once per mesh,
#: about a tenth of a second; larger boundaries count as not convex unless a fold is found sooner)
CONVEX_WORK = 50_000_000


def compiled():
    """:mod:`.order_compiled` (numba) when numba is installed, else ``None`` (the numpy code here)."""
    try:
        return importlib.import_module(".order_compiled", __package__)
    except ImportError:
        return None


#: Pixels a cell's projected bounding box is grown by before it is tested for pixel centres
#: (:func:`reaching`): the geometry shader grows the footprint by a twentieth of a pixel, a mitre by at
#: most 1.42 of that (0.071), and the host's float64 projection differs from the shader's float32 one
#: and the rasterizer's snapping by far less than the 0.029 left.
REACH_MARGIN = 0.1


def reaching(points, tets, view_projection, width: int, height: int, fast=None, tile: int = 0,
             tiles: np.ndarray | None = None) -> np.ndarray:
    """``(M,)`` booleans: which cells' projected bounding boxes (grown by :data:`REACH_MARGIN` pixels)
    hold a pixel centre of the image; the others draw no fragment (the rasterizer keeps only pixel
    centres inside a footprint, which lies in the box).  ``points``: relative to the centre
    ``view_projection`` takes (float64), all in front of the eye's plane; pixels in GL window
    coordinates (centres at ``i + 0.5``).  ``fast``: :mod:`.order_compiled` (one pass), else numpy.
    ``tile > 0``: ``tiles`` (``(M,)`` uint32) gets each cell's first and last column and first and last
    row of the ``tile`` x ``tile``-pixel screen tiles holding those pixel centres, a byte each from the
    lowest (zeros where it reaches none; at most 256 tiles a side)."""
    out = np.empty(len(tets), np.bool_)
    if fast is not None:
        fast.reaching(points, tets, np.ascontiguousarray(view_projection, np.float64), float(width),
                      float(height), REACH_MARGIN, out, int(tile), np.zeros(0, np.uint32) if tiles is None
                      else tiles)
        return out
    xy = points @ view_projection[:2, :3].T + view_projection[:2, 3]
    w = points @ view_projection[3, :3] + view_projection[3, 3]
    q = (xy / w[:, None] * 0.5 + 0.5) * np.array([width, height], float)
    corners = q[tets]
    lo = np.maximum(np.ceil(corners.min(axis=1) - REACH_MARGIN - 0.5), 0.0)
    hi = np.minimum(np.floor(corners.max(axis=1) + REACH_MARGIN - 0.5), [width - 1.0, height - 1.0])
    np.all(lo <= hi, axis=1, out=out)
    if tile > 0:
        lo[~out], hi[~out] = 0.0, 0.0
        first, last = lo.astype(np.uint32) // tile, hi.astype(np.uint32) // tile
        tiles[:] = first[:, 0] | (last[:, 0] << 8) | (first[:, 1] << 16) | (last[:, 1] << 24)
    return out


#: Screen tiles (pixels a side) the drawn order is grouped by (:func:`tile_coherent`): llvmpipe's
#: rasterizer bins triangles into tiles of 64 x 64 pixels and rasterizes a tile's in the order drawn.
TILE = 64


def tile_coherent(order: np.ndarray, tiles: np.ndarray, columns: int, rows: int, fast=None) -> np.ndarray:
    """``order`` (the cells in the order drawn) regrouped by screen tile, so that the rasterizer, which
    works a tile at a time, finds a tile's triangles together rather than one in every few hundred; the
    cells touching any one tile keep their order (``tiles``: the ``columns`` x ``rows`` tiles each cell's
    pixel centres lie in, packed as :func:`reaching` gives them).  Two cells that cover
    a common pixel centre share a tile, so every pixel meets the same fragments in the same order: the
    same picture, to the bit.  ``fast``: :mod:`.order_compiled`; without it (numpy) ``order`` as it is."""
    if fast is None or not len(order):
        return order
    return fast.tile_coherent(np.ascontiguousarray(order), tiles, int(columns), int(rows))


@dataclass
class Adjacency:
    """The mesh's faces, once per mesh: interior faces (the two cells, a vertex and the normal
    pointing out of the first cell) and boundary faces (vertices, their cell)."""

    pairs: np.ndarray          # (F, 2) cells sharing each interior face
    face_point: np.ndarray     # (F, 3)
    face_normal: np.ndarray    # (F, 3), out of pairs[:, 0]
    boundary: np.ndarray       # (B, 3) vertex indices
    boundary_cell: np.ndarray  # (B,)
    non_manifold: int          # faces shared by more than two cells (their extra cells: boundary)
    boundary_corners: np.ndarray  # (B, 3, 3) the boundary faces' vertices
    boundary_edges: np.ndarray    # (B, 2, 3) v1 - v0, v2 - v0 (Moller-Trumbore)
    boundary_normal: np.ndarray   # (B, 3) out of its cell
    size: float                   # the boundary's largest extent along an axis
    face_slots: np.ndarray        # (F, 2) which face of each of its two cells (the vertex it leaves out)

    @functools.cached_property
    def normal_length(self) -> np.ndarray:
        """``(F,)`` the interior faces' normals' lengths (for the edge-on test)."""
        return np.linalg.norm(self.face_normal, axis=1)

    @functools.cached_property
    def convex(self) -> bool:
        """Whether the boundary is convex (within :data:`CONVEX_SLACK`): every boundary point on the
        inner side of every boundary face's plane.  Then no ray crosses the boundary more than twice
        and there are no gaps to relate.  ``False`` when the test would cost more than
        :data:`CONVEX_WORK` (a large boundary: the rays decide, as for any non-convex mesh), and for a
        mesh without a boundary."""
        if not len(self.boundary):
            return False
        points = self.boundary_corners.reshape(-1, 3)[np.unique(self.boundary.ravel(), return_index=True)[1]]
        normal = self.boundary_normal / np.maximum(np.linalg.norm(self.boundary_normal, axis=1, keepdims=True),
                                                   1e-300)
        offset = np.einsum("ij,ij->i", normal, self.boundary_corners[:, 0]) + CONVEX_SLACK * self.size
        chunk = max(CONVEX_WORK // (16 * len(points)), 1)
        for first in range(0, len(normal), chunk):
            if first * len(points) > CONVEX_WORK:
                return False
            if (points @ normal[first:first + chunk].T > offset[first:first + chunk]).any():
                return False
        return True


def adjacency(points: np.ndarray, tets: np.ndarray) -> Adjacency:
    faces, cells, which, first = paired_faces(tets)
    opposite = tets[cells, which]
    # a face shared by two cells: interior; by one: boundary; by more (a broken mesh): the first
    # two pair up and the rest count as boundary faces
    # the interior faces by their first cell: the per-view pass over them writes both cells' records
    # (order_compiled), and in the faces' own order (by their vertices) those writes scatter over the
    # whole mesh (the jaw's pass: twice Kahn's sort); the order does not depend on the faces' order
    first = first[np.argsort(cells[first], kind="stable")]
    interior_a, interior_b = first, first + 1
    extra = int(np.all(faces[1:] == faces[:-1], axis=1).sum()) - len(first)  # cells past a pair's two
    lone = np.ones(len(faces), bool)
    lone[interior_a] = lone[interior_b] = False
    pa, pb, pc = (points[faces[interior_a, i]] for i in range(3))
    normal = np.cross(pb - pa, pc - pa)
    inward = np.einsum("ij,ij->i", normal, points[opposite[interior_a]] - pa) > 0
    normal[inward] *= -1.0
    boundary, boundary_cell = faces[lone], cells[lone]
    corners = points[boundary]
    edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=1)
    out = np.cross(edges[:, 0], edges[:, 1])
    centroid = points[tets[boundary_cell]].mean(axis=1)
    out[np.einsum("ij,ij->i", out, centroid - corners[:, 0]) > 0] *= -1.0
    return Adjacency(np.stack([cells[interior_a], cells[interior_b]], axis=1), pa, normal, boundary, boundary_cell,
                     extra, corners, edges, out,
                     float(np.ptp(corners.reshape(-1, 3), axis=0).max()) if len(corners) else 0.0,
                     np.stack([which[interior_a], which[interior_b]], axis=1).astype(np.int64))


def eye_of(camera):
    """``(eye, None)`` for a perspective camera, ``(None, forward)`` for an orthographic one."""
    f, _, _ = camera.basis()
    return (np.asarray(camera.eye, float), None) if camera.projection == "perspective" else (None, f)


def centroid_depth(centroids: np.ndarray, camera) -> np.ndarray:
    eye, forward = eye_of(camera)
    if eye is not None:
        return np.linalg.norm(centroids - eye, axis=1)
    return centroids @ forward


def face_relations(adj: Adjacency, camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(front, back)`` cells across every interior face not seen edge on, and the faces seen edge on
    (their plane through the eye, or along the view direction, within :data:`EDGE_ON`)."""
    eye, forward = eye_of(camera)
    toward_eye = (eye[None, :] - adj.face_point) if eye is not None else -forward[None, :]
    side = np.einsum("ij,ij->i", adj.face_normal, toward_eye)
    a, b = adj.pairs[:, 0], adj.pairs[:, 1]
    front = np.where(side > 0, b, a)  # the eye beyond a's face: b is on the eye's side
    back = np.where(side > 0, a, b)
    scale = adj.normal_length * np.linalg.norm(toward_eye, axis=1)
    edge_on = np.abs(side) <= EDGE_ON * scale
    return front[~edge_on], back[~edge_on], np.nonzero(edge_on)[0]


def boundary_relations(adj: Adjacency, origins, directions, t_min, fast=None) -> tuple[np.ndarray, np.ndarray]:
    """``(front, back)`` cells across the gaps along the rays: a ray's exit through a boundary face
    of one cell, then its next entry through a boundary face of another (``t_min``: where each ray
    starts).  ``fast``: :mod:`.order_compiled`, whose :func:`~.order_compiled.boundary_hits` finds the
    same hits in one compiled pass (numpy's candidate pairs where it is ``None``, or the rays come
    from no camera)."""
    if not len(adj.boundary) or not len(origins):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    frame = image_plane(origins, directions) if fast is not None else None
    if frame is not None:
        ray_xy, eye, forward, basis = frame
        ray, t, face = fast.boundary_hits(adj.boundary_corners, adj.boundary_edges, ray_xy, origins, directions,
                                          t_min, np.zeros(3) if eye is None else eye, forward, basis,
                                          eye is not None, EDGE_MARGIN)
    else:
        ray, t, face = _boundary_hits(adj, origins, directions, t_min)
    return _across_gaps(adj, directions, ray, t, face, fast)


def _boundary_hits(adj: Adjacency, origins, directions, t_min):
    """``(ray, t, face)``: every hit of a ray on a boundary face beyond its ``t_min``."""
    faces, rays = candidate_pairs(adj.boundary_corners, origins, directions)
    hits_ray, hits_t, hits_face = [], [], []
    for i in range(0, len(faces), PAIRS_PER_CHUNK):
        f, r = faces[i:i + PAIRS_PER_CHUNK], rays[i:i + PAIRS_PER_CHUNK]
        t, hit = _moller_trumbore(adj.boundary_corners[f, 0], adj.boundary_edges[f], origins[r], directions[r])
        hit &= t > t_min[r]
        hits_ray.append(r[hit])
        hits_t.append(t[hit])
        hits_face.append(f[hit])
    return tuple(np.concatenate(x) for x in (hits_ray, hits_t, hits_face))


def _across_gaps(adj: Adjacency, directions, ray, t, face, fast=None) -> tuple[np.ndarray, np.ndarray]:
    """``(front, back)`` from the boundary hits: each ray's exits related to the entry that ends
    their gap (``fast``: :mod:`.order_compiled`, whose :func:`~.order_compiled.across_gaps` gives the
    same relations in the same order in one pass, for the lexsort, the searches and the gathers)."""
    cell = adj.boundary_cell[face]
    leaving = np.einsum("ij,ij->i", adj.boundary_normal[face], directions[ray]) > 0
    # A leaving face before an entering one at the same t, and within TOUCHING of it: cells that touch
    # without sharing vertices (a multi-block grid's duplicated points at a block interface: the
    # oxygen post) meet at coincident faces whose two triangles give t's a rounding apart, and an
    # entry sorted before the exit it meets would be related to the wrong exit.
    touching = TOUCHING * adj.size
    t_key = t - touching * leaving
    if fast is not None:
        return fast.across_gaps(ray, t_key, leaving, cell, len(directions))
    order = np.lexsort((~leaving, t_key, ray))
    ray, cell, leaving = ray[order], cell[order], leaving[order]
    # Every exit in a gap is in front of the entry that ends the gap: a ray through an edge of the
    # boundary leaves through two cells' faces at once (one of them may hold only a zero-length
    # piece), and relating only the last exit would leave the other unordered against the entry.
    start = np.r_[True, ray[1:] != ray[:-1]]
    entries = np.cumsum(~leaving)
    gap = entries - np.maximum.accumulate(np.where(start, entries - (~leaving), 0))  # entries so far, this ray
    gap = np.where(leaving, gap, gap - 1)   # an exit's gap: entries before it; an entry ends gap (its count - 1)
    key = ray.astype(np.int64) * (len(ray) + 1) + gap
    exits, enters = np.nonzero(leaving)[0], np.nonzero(~leaving)[0]
    ex_order = np.argsort(key[exits], kind="stable")
    ex_key = key[exits][ex_order]
    lo = np.searchsorted(ex_key, key[enters], "left")
    hi = np.searchsorted(ex_key, key[enters], "right")
    count = hi - lo
    which_exit = exits[ex_order][ranges(lo, count)]
    which_entry = np.repeat(enters, count)
    keep = cell[which_exit] != cell[which_entry]
    return cell[which_exit][keep], cell[which_entry][keep]


def _moller_trumbore(v0, edges, o, d):
    """Ray-triangle hits (a vertex ``v0`` and its two edges): ``t`` and whether the ray crosses the
    triangle (edges included)."""
    e1, e2 = edges[:, 0], edges[:, 1]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("ij,ij->i", d, q) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
    # edges included with a margin: a ray through an edge of the boundary must hit both faces there
    # (a miss would leave a cell unrelated across a gap; a second hit relates one more exit)
    eps = EDGE_MARGIN
    hit = (det != 0) & (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps) & np.isfinite(t)
    return t, hit


def topological(n: int, front: np.ndarray, back: np.ndarray, depth: np.ndarray,
                original: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Cells ``0..n-1`` front to back respecting every ``front -> back`` relation, and the number of
    cycles broken.

    Kahn's algorithm, a level at a time, gives each cell the earliest level its relations allow; a
    cell with few relations (one the pixels' rays only touch, such as a cell beside a face seen edge
    on) would then go out in the first levels however far it lies.  So each cell is placed by a key
    instead: the largest ``depth`` of itself and everything related in front of it (its own depth
    where nothing is, as in the centroid order), ties by level.  A relation's back cell has at
    least its front cell's key and a later level, so every relation holds.

    ``original``: the cells renumbered (:func:`locality_order`; ``original[i]``: cell ``i``'s index in
    the mesh): ties go by the original index and the order is of original indices."""
    key = _distinct(front.astype(np.int64) * n + back)  # each relation once
    src, dst = key // n, key % n
    indegree = np.bincount(dst, minlength=n)
    order_src = np.argsort(src, kind="stable")
    dst_by_src = dst[order_src]
    start = np.searchsorted(src[order_src], np.arange(n + 1))
    done = np.zeros(n, bool)
    place = np.asarray(depth, np.float64).copy()  # the key: grows with what is related in front
    level = np.zeros(n, np.int64)
    broken, step = 0, 0
    frontier = np.nonzero(indegree == 0)[0]
    remaining = n
    while remaining:
        if not len(frontier):  # a cycle: the nearest remaining cell goes first
            left = np.nonzero(~done)[0]
            if original is None:
                frontier = left[[np.argmin(place[left])]]
            else:  # the lowest original index among the nearest
                left = left[place[left] == place[left].min()]
                frontier = left[[np.argmin(original[left])]]
            indegree[frontier] = 0
            broken += 1
        level[frontier] = step
        step += 1
        done[frontier] = True
        remaining -= len(frontier)
        count = start[frontier + 1] - start[frontier]
        nxt = dst_by_src[ranges(start[frontier], count)]
        if len(nxt):
            # each successor once, with how many of its relations this level settles and the largest
            # key in front of it (a sort, as np.unique; np.subtract.at costs several times that)
            by = np.argsort(nxt)
            nxt, keys = nxt[by], np.repeat(place[frontier], count)[by]
            first = np.r_[True, nxt[1:] != nxt[:-1]]
            at = np.nonzero(first)[0]
            cells = nxt[first]
            indegree[cells] -= np.diff(np.r_[at, len(nxt)])
            open_ = ~done[cells]  # a cell already out (past a broken cycle) keeps its key
            place[cells[open_]] = np.maximum(place[cells[open_]], np.maximum.reduceat(keys, at)[open_])
            frontier = cells[(indegree[cells] == 0) & open_]
        else:
            frontier = np.zeros(0, np.int64)
    if original is not None:  # back to the mesh's numbering
        place[original], level[original] = place.copy(), level.copy()
    return np.lexsort((level, place)), broken


def _distinct(values: np.ndarray) -> np.ndarray:
    """Sorted distinct values (np.unique's hashing path costs several times a sort here)."""
    values = np.sort(values)
    return values[np.r_[True, values[1:] != values[:-1]]] if len(values) else values


def locality_order(points: np.ndarray) -> np.ndarray:
    """``(N,)`` the points' indices along a Morton (Z-order) curve through their bounding box (21 bits
    an axis; ties in the input order): a numbering in which points near each other in space are, for
    the most part, near each other in it."""
    lo = points.min(axis=0)
    extent = max(float(np.ptp(points, axis=0).max()), 1e-300) if len(points) else 1.0
    cells = np.clip((points - lo) * ((1 << 21) / extent), 0, (1 << 21) - 1).astype(np.uint64)
    code = _spread(cells[:, 0]) | (_spread(cells[:, 1]) << np.uint64(1)) | (_spread(cells[:, 2]) << np.uint64(2))
    return np.argsort(code, kind="stable")


def _spread(x: np.ndarray) -> np.ndarray:
    """21-bit integers with two zero bits put after each bit (bit k to bit 3k)."""
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


#: Cells this far apart in the numbering count as far (the sort's state for them: 32 KB, two float64
#: a cell) ...
NEAR_CELLS = 1024
#: ... and a numbering with more than this fraction of the interior faces between far cells is
#: scattered.  Measured (README): the shared meshes' own numberings have 0.5-21 % (Morton 4-13 %) and
#: the sort gains nothing from renumbering them; the same meshes shuffled have 92-99 %, and renumbered
#: their sort takes half the time.
SCATTERED = 0.5


def scattered(adj: Adjacency) -> bool:
    """Whether the numbering of the mesh's cells scatters neighbours: more than :data:`SCATTERED` of
    the interior faces between cells more than :data:`NEAR_CELLS` apart in it."""
    if not len(adj.pairs):
        return False
    return float(np.mean(np.abs(adj.pairs[:, 0] - adj.pairs[:, 1]) > NEAR_CELLS)) > SCATTERED


@dataclass
class Renumbered:
    """The mesh's cells renumbered for locality (:func:`locality_order` of their centroids), once per
    mesh: ``cells[i]`` is cell ``i``'s index in the mesh; the interior faces renumbered with them
    and sorted by their first cell (the boundary faces as they are, their cells renumbered)."""

    cells: np.ndarray
    adjacency: Adjacency
    seconds: float  # what renumbering cost (once per mesh)


def renumbered(adj: Adjacency, centroids: np.ndarray) -> Renumbered:
    """The mesh's faces ``adj`` with the cells renumbered along :func:`locality_order` of their
    ``centroids`` (the faces' points, normals and slots the same values, reordered)."""
    start = time.perf_counter()
    cells = locality_order(centroids)
    rank = np.empty(len(cells), np.int64)
    rank[cells] = np.arange(len(cells))
    pairs = rank[adj.pairs]
    faces = np.argsort(pairs[:, 0], kind="stable")
    local = dataclasses.replace(adj, pairs=pairs[faces], face_point=adj.face_point[faces],
                                face_normal=adj.face_normal[faces], face_slots=adj.face_slots[faces],
                                boundary_cell=rank[adj.boundary_cell])
    local.__dict__["normal_length"] = adj.normal_length[faces]  # the same lengths, not recomputed
    return Renumbered(cells, local, time.perf_counter() - start)


class VisibilityOrder:
    """The orders of one mesh (its faces and centroids computed once)."""

    #: Run the exact order's per-view loops on the cells renumbered for locality (:func:`renumbered`,
    #: once per mesh; the same order): ``None`` (the default) where the mesh's own numbering is
    #: :func:`scattered`, ``True`` always, ``False`` never.
    renumber: bool | None = None

    def __init__(self, mesh, compiled_loops: bool = True):
        """``compiled_loops``: run the per-view loops compiled where numba is installed (else numpy)."""
        self.mesh = mesh
        self.fast = compiled() if compiled_loops else None
        self.centroids = mesh.points[mesh.tets].mean(axis=1)

    @functools.cached_property
    def adjacency(self) -> Adjacency:
        return adjacency(self.mesh.points, self.mesh.tets)

    @functools.cached_property
    def renumbered(self) -> Renumbered:
        """The cells renumbered for locality and the faces with them (once per mesh)."""
        return renumbered(self.adjacency, self.centroids)

    @functools.cached_property
    def scattered(self) -> bool:
        """Whether the mesh's own numbering scatters neighbouring cells (:func:`scattered`; once)."""
        return scattered(self.adjacency)

    def __call__(self, camera, width: int, height: int, kind: str = "exact",
                 pixels: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
        """Cells front to back and ``stats``: seconds, relations, cycles broken, rays cast.  ``pixels``:
        which pixels' rays (``(height * width,)`` booleans, row 0 at the top) may cross a gap and so
        are cast against the boundary; all of them when ``None``."""
        start = time.perf_counter()
        eye, _ = eye_of(camera)
        if self.fast is not None and eye is not None:
            depth = self.fast.distances(self.centroids, eye)
        else:
            depth = centroid_depth(self.centroids, camera)
        if kind == "centroid":  # compiled: a radix sort, linear in the cells (the jaw's 454,288: 12-19 ms, numpy 53-58)
            order = self.fast.stable_argsort(depth) if self.fast is not None else np.argsort(depth, kind="stable")
            return order, {"order": "centroid", "order_seconds": time.perf_counter() - start,
                           "compiled": self.fast is not None}
        adj, original = self.adjacency, None
        if self.scattered if self.renumber is None else self.renumber:
            local = self.renumbered
            adj, original, depth = local.adjacency, local.cells, depth[local.cells]
        if self.fast is not None:
            return self._compiled(adj, original, camera, o_d_t(camera, width, height, pixels), depth, start)
        f1, b1, edge_on = face_relations(adj, camera)
        o, d, t_min = o_d_t(camera, width, height, pixels)
        f2, b2 = boundary_relations(adj, o, d, t_min)
        # Across a face seen edge on (the eye in its plane) which cell is in front is a matter of
        # rounding, in the relation and in the float32 clipping that splits a ray lying in the plane
        # between the two cells: the one whose centroid is nearer goes first.
        a, b = adj.pairs[edge_on, 0], adj.pairs[edge_on, 1]
        nearer = depth[a] <= depth[b]
        f3, b3 = np.where(nearer, a, b), np.where(nearer, b, a)
        order, broken = topological(len(self.mesh.tets), np.concatenate([f1, f2, f3]), np.concatenate([b1, b2, b3]),
                                    depth, original)
        return order, {"order": "exact", "compiled": False, "order_seconds": time.perf_counter() - start,
                       "renumbered": original is not None,
                       "face_relations": int(len(f1)), "boundary_relations": int(len(f2)),
                       "edge_on_faces": int(len(edge_on)),
                       "rays_cast": len(d),
                       "cycles_broken": broken, "non_manifold_faces": adj.non_manifold}

    def _compiled(self, adj, original, camera, rays, depth, start) -> tuple[np.ndarray, dict]:
        """The exact order with the per-view loops compiled (:mod:`.order_compiled`): the same order
        as the numpy code (``adj``, ``depth``: the cells renumbered where ``original`` is given)."""
        fast = self.fast
        eye, forward = eye_of(camera)
        perspective = eye is not None
        f2, b2 = boundary_relations(adj, *rays, fast=fast)
        order, broken, flat = fast.view_order(adj.pairs, adj.face_point, adj.face_normal, adj.normal_length,
                                              eye if perspective else np.zeros(3),
                                              np.zeros(3) if perspective else forward, perspective, EDGE_ON, depth,
                                              f2, b2, original)
        return order, {"order": "exact", "compiled": True, "order_seconds": time.perf_counter() - start,
                       "renumbered": original is not None,
                       "face_relations": int(len(adj.pairs) - flat), "boundary_relations": int(len(f2)),
                       "edge_on_faces": int(flat), "rays_cast": len(rays[1]),
                       "cycles_broken": int(broken), "non_manifold_faces": adj.non_manifold}


def o_d_t(camera, width: int, height: int, pixels):
    """The rays cast against the boundary: origins, directions and where each starts."""
    o, d = camera.pixel_rays(width, height, None if pixels is None else np.nonzero(pixels)[0])
    return o, d, camera.near_distance(d)
