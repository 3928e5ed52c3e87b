"""Rays through a tetrahedral mesh, exactly: the piece of each ray inside each cell.

A tetrahedron is the intersection of the four half-spaces of its faces, so the part of a ray
``o + t d`` inside it is ``[max of entering faces' t, min of leaving faces' t]`` (Cyrus-Beck
clipping); every cell a ray crosses gives one piece ``(ray, a, b, cell)``.  Pieces of
neighbouring cells meet exactly: a face's plane is computed from its three vertices in the order
of their global indices, so both cells sharing it compute the same ``t`` to the last bit (the
other cell's plane is the same numbers; only the inside differs).  Nothing depends on the mesh
being convex or connected: a ray leaving the mesh through a concavity simply has no piece there,
and zero-volume cells (which bound no piece) are left out beforehand.

Which rays to test against which cell: rays are binned in their image plane (the camera's
rays share an eye, perspective, or a direction, orthographic) and each cell is tested
against the rays in the bins its projected bounding box covers; cells straddling the eye's
plane are tested against every ray.  (Rays from no camera are tested against every cell.)
"""

from __future__ import annotations

import numpy as np

from .ragged import ranges, ranks

PAIRS_PER_CHUNK = 1 << 21  # (cell, ray) tests at a time: ~200 MB of temporaries


class FacePlanes:
    """The four face planes of each tetrahedron: ``normal (M, 4, 3)``, ``offset (M, 4)`` and
    ``side (M, 4)`` (+1 or -1: inside is ``side * (normal . p - offset) >= 0``); face k is
    opposite vertex k."""

    def __init__(self, points: np.ndarray, tets: np.ndarray):
        normal = np.empty((len(tets), 4, 3))
        offset = np.empty((len(tets), 4))
        side = np.empty((len(tets), 4))
        for k in range(4):
            face = np.sort(np.delete(tets, k, axis=1), axis=1)  # global order: shared faces agree
            pa, pb, pc = (points[face[:, i]] for i in range(3))
            n = np.cross(pb - pa, pc - pa)
            normal[:, k] = n
            offset[:, k] = _dot(n, pa)
            side[:, k] = np.where(_dot(n, points[tets[:, k]]) >= offset[:, k], 1.0, -1.0)
        self.normal, self.offset, self.side = normal, offset, side


def paired_faces(tets: np.ndarray):
    """Every cell's four faces (face k opposite vertex k) as vertex triples in global order, sorted:
    ``faces (4M, 3)``, their ``owner`` cells and ``which`` face of the owner each is, and ``first``:
    the indices where a face and the next are the same face of two cells (a face shared by more
    than two cells, in a broken mesh: its first two pair up, the others stay unpaired)."""
    n = len(tets)
    faces = np.concatenate([np.sort(np.delete(tets, k, axis=1), axis=1) for k in range(4)])
    owner, which = np.tile(np.arange(n), 4), np.repeat(np.arange(4), n)
    order = np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))
    faces, owner, which = faces[order], owner[order], which[order]
    same = np.all(faces[1:] == faces[:-1], axis=1)
    first = np.nonzero(same & ~np.r_[False, same[:-1]])[0]  # the first two of each run of equal faces
    return faces, owner, which, first


def face_neighbours(tets: np.ndarray) -> np.ndarray:
    """``(M, 4)`` int32: the cell across face k of each cell (face k opposite vertex k, as
    :class:`FacePlanes`), -1 where the face is on the boundary (or unpaired: :func:`paired_faces`)."""
    _, owner, which, i = paired_faces(tets)
    out = np.full((len(tets), 4), -1, np.int32)
    out[owner[i], which[i]] = owner[i + 1]
    out[owner[i + 1], which[i + 1]] = owner[i]
    return out


def boundary_faces(points: np.ndarray, tets: np.ndarray, neighbours: np.ndarray):
    """The faces with no neighbour (``neighbours`` from :func:`face_neighbours`): their cells ``(B,)``,
    corners ``(B, 3, 3)`` and normals ``(B, 3)`` pointing out of their cells (by the opposite
    vertex; not unit length)."""
    cell, k = np.nonzero(neighbours < 0)
    keep = np.ones((len(cell), 4), bool)
    keep[np.arange(len(cell)), k] = False
    corners = points[tets[cell][keep].reshape(-1, 3)]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = np.einsum("ij,ij->i", normal, points[tets[cell, k]] - corners[:, 0]) > 0
    normal[inward] *= -1.0
    return cell, corners, normal


def _dot(a, b):
    """Row-wise dot product, always summed x + y + z in that order (bit-identical for equal input)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def image_plane(origins, directions):
    """The rays' image plane: ``(ray_xy (N, 2), eye, forward, basis (3, 2))``, a 2D coordinate per ray
    and the frame that gives it (``eye`` ``None`` for parallel rays: a point ``p`` is at ``p @ basis``;
    else at ``((p - eye) @ basis) / ((p - eye) @ forward)``, in front of the eye where the divisor is
    positive); ``None`` for rays from no camera (neither one eye nor parallel)."""
    f = directions.mean(axis=0)
    f /= np.linalg.norm(f)
    helper = np.eye(3)[np.argmin(np.abs(f))]
    r = np.cross(f, helper)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    basis = np.stack([r, u], axis=1)  # (3, 2)
    if np.all(origins == origins[0]):  # perspective: rays from one eye
        return (directions @ basis) / (directions @ f)[:, None], origins[0], f, basis
    if np.allclose(directions, directions[0], rtol=0, atol=1e-12):  # orthographic: parallel rays
        return origins @ basis, None, f, basis
    return None


def _image_plane(origins, directions):
    """A 2D coordinate per ray and a function projecting world points to the same coordinates
    (``(xy (N, 2), valid (N,))``: invalid where a point is not in front of the eye)."""
    frame = image_plane(origins, directions)
    if frame is None:
        return None, None  # no camera's rays: no image plane
    ray_xy, eye, f, basis = frame
    if eye is not None:

        def project(p):
            q = p - eye
            w = q @ f
            valid = w > 0
            with np.errstate(divide="ignore", invalid="ignore"):
                return (q @ basis) / np.where(valid, w, 1.0)[:, None], valid
        return ray_xy, project
    return ray_xy, lambda p: (p @ basis, np.ones(len(p), bool))


def candidate_pairs(corners, origins, directions):
    """``(polygon, ray)`` pairs whose projected bounding box holds the ray (a superset of the pairs
    that intersect); ``corners (M, k, 3)``: each cell's or polygon's vertices."""
    k = corners.shape[1]
    ray_xy, project = _image_plane(origins, directions)
    if ray_xy is None:  # every cell against every ray (O(cells x rays): rays from no camera, tests)
        return np.repeat(np.arange(len(corners)), len(origins)), np.tile(np.arange(len(origins)), len(corners))
    lo, hi = ray_xy.min(axis=0), ray_xy.max(axis=0)
    extent = max(float((hi - lo).max()), 1e-300)
    g = max(1, int(np.sqrt(len(ray_xy))))
    cell = extent / g * (1.0 + 1e-9)
    bins = np.minimum(((ray_xy - lo) / cell).astype(np.int64), g - 1)
    key = bins[:, 1] * g + bins[:, 0]
    order = np.argsort(key, kind="stable")
    start = np.searchsorted(key[order], np.arange(g * g + 1))

    xy, valid = project(corners.reshape(-1, 3))
    xy, valid = xy.reshape(-1, k, 2), valid.reshape(-1, k)
    straddles = ~valid.all(axis=1) & valid.any(axis=1)
    margin = 1e-9 * extent
    with np.errstate(invalid="ignore"):
        blo = np.where(valid[..., None], xy, np.inf).min(axis=1) - margin
        bhi = np.where(valid[..., None], xy, -np.inf).max(axis=1) + margin
    blo[straddles], bhi[straddles] = lo, hi
    seen = valid.any(axis=1) & np.all(bhi >= lo, axis=1) & np.all(blo <= hi, axis=1)
    idx = np.nonzero(seen)[0]
    with np.errstate(invalid="ignore"):  # rays on one point (extent 0): one bin, every cell in it
        b0 = np.clip(np.nan_to_num((blo[idx] - lo) / cell).astype(np.int64), 0, g - 1)
        b1 = np.clip(np.nan_to_num((bhi[idx] - lo) / cell).astype(np.int64), 0, g - 1)
    nx, ny = b1[:, 0] - b0[:, 0] + 1, b1[:, 1] - b0[:, 1] + 1
    # (cell, bin) pairs
    count = nx * ny
    tet_of = np.repeat(idx, count)
    local = ranks(count)
    rep = lambda a: np.repeat(a, count)  # noqa: E731
    bx = rep(b0[:, 0]) + local % rep(nx)
    by = rep(b0[:, 1]) + local // rep(nx)
    b = by * g + bx
    # (cell, ray) pairs
    n_rays = start[b + 1] - start[b]
    tet_of = np.repeat(tet_of, n_rays)
    ray_of = order[ranges(start[b], n_rays)]
    inside = np.all((ray_xy[ray_of] >= blo[tet_of]) & (ray_xy[ray_of] <= bhi[tet_of]), axis=1)
    return tet_of[inside], ray_of[inside]


def clip(planes: FacePlanes, cells, rays, origins, directions, t0, t1):
    """The part ``[a, b]`` of each ray inside each cell (Cyrus-Beck), clipped to ``[t0, t1]``;
    empty where ``b <= a``."""
    n, h, s = planes.normal[cells], planes.offset[cells], planes.side[cells]
    o, d = origins[rays][:, None, :], directions[rays][:, None, :]
    nd = _dot(n, d) * s
    no = (_dot(n, o) - h) * s  # >= 0 inside the face's half-space at t = 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -no / nd
    a = np.max(np.where(nd > 0, t, -np.inf), axis=1)
    b = np.min(np.where(nd < 0, t, np.inf), axis=1)
    # a ray parallel to a face: inside its half-space or not, for all t; a ray lying in a face shared
    # by two cells belongs to the one on the plane's positive side (side > 0), so to exactly one
    outside_parallel = np.any((nd == 0) & ((no < 0) | ((no == 0) & (s < 0))), axis=1)
    a = np.maximum(a, t0[rays])
    b = np.where(outside_parallel, -np.inf, np.minimum(b, t1[rays]))
    return a, b


def ray_pieces(corners, planes: FacePlanes, origins, directions, t0, t1):
    """Pieces ``(ray, a, b, cell)`` of every ray inside every cell it crosses, sorted by ray and
    then along it (``corners (M, 4, 3)``: the cells' vertices; ``t0``, ``t1``: each ray's extent;
    rays with ``t1 <= t0`` have none)."""
    live = np.nonzero(t1 > t0)[0]
    out = [np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros(0, np.int64)]
    if not len(live) or not len(corners):
        return tuple(out)
    cells, rays = candidate_pairs(corners, origins[live], directions[live])
    rays = live[rays]
    parts = [tuple(out)]  # rays through the box that meet no cell (a mesh's gaps) have no piece
    for i in range(0, len(cells), PAIRS_PER_CHUNK):
        c, r = cells[i:i + PAIRS_PER_CHUNK], rays[i:i + PAIRS_PER_CHUNK]
        a, b = clip(planes, c, r, origins, directions, t0, t1)
        keep = b > a
        parts.append((r[keep], a[keep], b[keep], c[keep]))
    ray, a, b, cell = (np.concatenate([p[k] for p in parts]) for k in range(4))
    order = np.lexsort((a, ray))
    return ray[order], a[order], b[order], cell[order]
