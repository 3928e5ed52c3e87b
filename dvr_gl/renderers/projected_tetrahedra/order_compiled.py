"""The exact visibility order's per-view loops compiled with numba (the optional extra ``numba``):
the same relations and the same topological sort as :mod:`.order`'s numpy code, result for result
(``tests/test_projected_tetrahedra.py`` checks both paths give the same order), in one pass each
instead of a few dozen numpy passes and sorts.

Imported only through :func:`.order.compiled`, which falls back to the numpy code where numba is
not installed.  Every function is ``njit(cache=True)``: the first call of a fresh install compiles
(a few seconds, once), later processes load the compiled code from ``__pycache__``.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def face_fronts(pairs, face_point, face_normal, normal_length, eye, forward, perspective, edge_on_sine, depth):
    """``(front, edge_on)`` for every interior face: which of its two cells is in front, as
    :func:`.order.face_relations` and :meth:`.order.VisibilityOrder.__call__` decide it (the cell
    on the eye's side, the normal pointing out of ``pairs[:, 0]``; a face whose plane passes within
    ``edge_on_sine`` (relative sine) of the eye, or lies along the view direction, is seen edge on:
    the cell whose centroid ``depth`` is smaller, or equal, goes first), and how many faces are
    seen edge on.  ``eye`` for a perspective camera (``perspective``), else ``forward``."""
    n = len(pairs)
    front = np.empty(n, np.int64)
    flat = 0
    fx, fy, fz = -forward[0], -forward[1], -forward[2]
    toward_length = np.sqrt(fx * fx + fy * fy + fz * fz)
    for i in range(n):
        if perspective:
            fx = eye[0] - face_point[i, 0]
            fy = eye[1] - face_point[i, 1]
            fz = eye[2] - face_point[i, 2]
            toward_length = np.sqrt(fx * fx + fy * fy + fz * fz)
        side = face_normal[i, 0] * fx + face_normal[i, 1] * fy + face_normal[i, 2] * fz
        a, b = pairs[i, 0], pairs[i, 1]
        if abs(side) <= edge_on_sine * (normal_length[i] * toward_length):
            flat += 1
            front[i] = a if depth[a] <= depth[b] else b
        else:
            front[i] = b if side > 0 else a  # the eye beyond a's face: b is on the eye's side
    return front, flat


def exact_order(n, face_slots, pairs, front_of, extra_front, extra_back, depth, original=None):
    """Cells ``0..n-1`` front to back and the cycles broken, as :func:`.order.topological` gives them
    for the relations across the interior faces (``front_of``: each face's front cell, of its two
    in ``pairs``; ``face_slots``: which of its cells' four faces it is, ``(F, 2)``) and the
    ``extra`` ones (across gaps): Kahn's sort a level at a time, each cell's key the largest
    ``depth`` of itself and of every cell related in front of it (final when its cell goes out, so
    one pass in level order carries it); a cycle (no cell left free) is broken by taking the cell
    not yet out with the smallest key (the lowest index among equal ones); the order is by key, ties
    by level, then by index.  A relation given twice counts twice both ways (in the in-degree and
    when released), which gives the same levels and keys as counting it once.

    ``original``: the cells renumbered (:func:`.order.locality_order`: ``original[i]`` is cell ``i``'s
    index in the mesh): ties (cycles broken, the order's last key) go by the original index and the
    order is of original indices, the order of the mesh's own numbering."""
    behind, indegree, extra_start, extra_next = _relations(n, face_slots, pairs, front_of, extra_front, extra_back)
    numbering = np.zeros(0, np.int64) if original is None else np.asarray(original, np.int64)
    place, level, steps, broken = _levels(n, behind, extra_start, extra_next, indegree,
                                          np.asarray(depth, np.float64), numbering)
    if original is not None:
        place, level = _renumbered_back(place, level, numbering)
    by_level = _by_level(level, steps)
    return by_level[stable_argsort(place[by_level])], broken


@numba.njit(cache=True)
def _renumbered_back(place, level, original):
    """``place`` and ``level`` of the renumbered cells in the mesh's own numbering."""
    place_back, level_back = np.empty_like(place), np.empty_like(level)
    for i in range(len(original)):
        place_back[original[i]] = place[i]
        level_back[original[i]] = level[i]
    return place_back, level_back


@numba.njit(cache=True)
def _relations(n, face_slots, pairs, front_of, extra_front, extra_back):
    """``behind (n, 4)``: the cell behind each of a cell's faces (-1: none, or in front), each cell's
    count of relations in front of it, and the extra relations by front cell."""
    m = len(extra_front)
    behind = np.full((n, 4), -1, np.int32)  # 32-bit: half the memory the sort's random reads touch
    indegree = np.zeros(n, np.int32)
    for f in range(len(pairs)):
        a, b = pairs[f, 0], pairs[f, 1]
        if front_of[f] == a:
            behind[a, face_slots[f, 0]] = b
            indegree[b] += 1
        else:
            behind[b, face_slots[f, 1]] = a
            indegree[a] += 1
    extra_start = np.zeros(n + 1, np.int64)
    for r in range(m):
        extra_start[extra_front[r] + 1] += 1
        indegree[extra_back[r]] += 1
    for i in range(n):
        extra_start[i + 1] += extra_start[i]
    extra_next = np.empty(m, np.int64)
    fill = extra_start[:n].copy()
    for r in range(m):
        extra_next[fill[extra_front[r]]] = extra_back[r]
        fill[extra_front[r]] += 1
    return behind, indegree, extra_start, extra_next


@numba.njit(cache=True)
def _levels(n, behind, extra_start, extra_next, indegree, depth, original):
    """Kahn's sort: each cell's key (from ``depth``, a new array) and level, the levels' count and the
    cycles broken (a tie of key broken by the lower ``original`` index, else by the lower index).
    Each cell's key and count of relations left in front of it side by side in one ``(n, 2)`` array
    (the count as a float): a relation settled touches one cache line instead of three, and the sort
    is bound by those random accesses; a cell out holds ``-1 - level`` there."""
    state = np.empty((n, 2))
    for i in range(n):
        state[i, 0] = depth[i]
        state[i, 1] = indegree[i]
    frontier = np.empty(n, np.int32)
    following = np.empty(n, np.int32)
    size = 0
    for i in range(n):
        if indegree[i] == 0:
            frontier[size] = i
            size += 1
    remaining, step, broken = n, 0, 0
    while remaining:
        if size == 0:  # a cycle: the nearest remaining cell goes first
            best = -1
            for i in range(n):
                if state[i, 1] >= 0.0 and (best < 0 or state[i, 0] < state[best, 0] or (
                        len(original) and state[i, 0] == state[best, 0] and original[i] < original[best])):
                    best = i
            frontier[0] = best
            size = 1
            broken += 1
        for k in range(size):
            state[frontier[k], 1] = -1.0 - step  # out, at this level
        remaining -= size
        step += 1
        nxt = 0
        for k in range(size):
            c = frontier[k]
            key = state[c, 0]
            for j in range(4):
                if behind[c, j] >= 0:
                    nxt = _release(behind[c, j], key, state, following, nxt)
            for j in range(extra_start[c], extra_start[c + 1]):
                nxt = _release(extra_next[j], key, state, following, nxt)
        frontier, following = following, frontier
        size = nxt
    level = np.empty(n, np.int32)
    place = np.empty(n)
    for i in range(n):
        place[i] = state[i, 0]
        level[i] = np.int32(-1.0 - state[i, 1])
    return place, level, step, broken


@numba.njit(cache=True, inline="always")
def _release(s, key, state, following, nxt):
    """One relation to ``s`` settled by a cell of key ``key``: ``s`` takes the larger key and joins
    the next level when nothing is left in front of it (a cell out already, past a broken cycle,
    keeps its key).  The next level's size."""
    if state[s, 1] < 0.0:
        return nxt
    if key > state[s, 0]:
        state[s, 0] = key
    state[s, 1] -= 1.0
    if state[s, 1] == 0.0:
        following[nxt] = s
        nxt += 1
    return nxt


@numba.njit(cache=True)
def _by_level(level, steps):
    """The cells by level, then by index (a counting sort)."""
    n = len(level)
    per_level = np.zeros(steps + 1, np.int32)
    for i in range(n):
        per_level[level[i] + 1] += 1
    for k in range(steps):
        per_level[k + 1] += per_level[k]
    by_level = np.empty(n, np.int32)
    for i in range(n):
        by_level[per_level[level[i]]] = i
        per_level[level[i]] += 1
    return by_level


@numba.njit(cache=True)
def stable_argsort(values):
    """The stable ascending order of float64 ``values`` (as ``np.argsort(kind="stable")``; -0.0 and
    0.0 equal, no NaNs expected): a least-significant-digit radix sort of the values' bits mapped
    to unsigned integers in the same order, in 11-bit digits (a digit the same in every value is
    skipped), linear in the count where a comparison sort is not."""
    n = len(values)
    raw = values.view(np.uint64)
    top = np.uint64(1) << np.uint64(63)
    bits = np.empty(n, np.uint64)
    for i in range(n):  # negative: all bits flipped; positive (and either zero): the sign bit set
        b = raw[i]
        bits[i] = top if values[i] == 0.0 else (~b if b & top else b | top)
    order = np.arange(n).astype(np.int32)
    spare = np.empty(n, np.int32)
    digit = np.empty(n, np.int32)
    width = 11
    counts = np.empty((1 << width) + 1, np.int64)
    mask = np.uint64((1 << width) - 1)
    for shift in range(0, 64, width):
        counts[:] = 0
        for i in range(n):
            d = np.int32((bits[i] >> np.uint64(shift)) & mask)
            digit[i] = d
            counts[d + 1] += 1
        if counts.max() == n:  # one digit for all: nothing moves
            continue
        for k in range(1 << width):
            counts[k + 1] += counts[k]
        for i in range(n):
            j = order[i]
            d = digit[j]
            spare[counts[d]] = j
            counts[d] += 1
        order, spare = spare, order
    return order


@numba.njit(cache=True)
def boundary_hits(corners, edges, ray_xy, origins, directions, t_min, eye, forward, basis, perspective, edge_margin):
    """``(ray, t, face)`` of every hit of a ray on a boundary face beyond the ray's ``t_min``: the hits
    :func:`.order.boundary_relations` finds in numpy (``candidate_pairs`` of
    :mod:`dvr_gl.fields.mesh_rays`, then Moller-Trumbore with the edges included by
    ``edge_margin`` in barycentric coordinates), in one pass over the faces.  ``ray_xy``, ``eye``,
    ``forward``, ``basis``: the rays' image plane (:func:`dvr_gl.fields.mesh_rays.image_plane`); a
    face is tested against the rays binned under its projected bounding box (grown by 1e-9 of the
    rays' extent; the whole box of rays where some corner is behind the eye), so the test is the
    numpy code's, pair for pair, in the same arithmetic."""
    n_rays = len(ray_xy)
    lo_x, lo_y, hi_x, hi_y = ray_xy[0, 0], ray_xy[0, 1], ray_xy[0, 0], ray_xy[0, 1]
    for r in range(n_rays):
        lo_x, lo_y = min(lo_x, ray_xy[r, 0]), min(lo_y, ray_xy[r, 1])
        hi_x, hi_y = max(hi_x, ray_xy[r, 0]), max(hi_y, ray_xy[r, 1])
    extent = max(max(hi_x - lo_x, hi_y - lo_y), 1e-300)
    g = max(1, int(np.sqrt(n_rays)))
    size = extent / g * (1.0 + 1e-9)
    start = np.zeros(g * g + 1, np.int64)
    bin_of = np.empty(n_rays, np.int64)
    for r in range(n_rays):
        bx = min(int((ray_xy[r, 0] - lo_x) / size), g - 1)
        by = min(int((ray_xy[r, 1] - lo_y) / size), g - 1)
        bin_of[r] = by * g + bx
        start[bin_of[r] + 1] += 1
    for b in range(g * g):
        start[b + 1] += start[b]
    by_bin = np.empty(n_rays, np.int64)
    fill = start[:-1].copy()
    for r in range(n_rays):
        by_bin[fill[bin_of[r]]] = r
        fill[bin_of[r]] += 1
    margin = 1e-9 * extent
    cap = max(1024, 4 * n_rays)
    hit_ray, hit_t, hit_face = np.empty(cap, np.int64), np.empty(cap), np.empty(cap, np.int64)
    found = 0
    xy = np.empty((3, 2))
    for face in range(len(corners)):
        valid = 0
        for k in range(3):
            qx, qy, qz = corners[face, k, 0], corners[face, k, 1], corners[face, k, 2]
            if perspective:
                qx, qy, qz = qx - eye[0], qy - eye[1], qz - eye[2]
                w = qx * forward[0] + qy * forward[1] + qz * forward[2]
                if not w > 0:
                    continue
            else:
                w = 1.0
            xy[valid, 0] = (qx * basis[0, 0] + qy * basis[1, 0] + qz * basis[2, 0]) / w
            xy[valid, 1] = (qx * basis[0, 1] + qy * basis[1, 1] + qz * basis[2, 1]) / w
            valid += 1
        if valid == 0:
            continue
        if valid < 3:  # straddles the eye's plane: every ray
            blo_x, blo_y, bhi_x, bhi_y = lo_x, lo_y, hi_x, hi_y
        else:
            blo_x = min(xy[0, 0], min(xy[1, 0], xy[2, 0])) - margin
            blo_y = min(xy[0, 1], min(xy[1, 1], xy[2, 1])) - margin
            bhi_x = max(xy[0, 0], max(xy[1, 0], xy[2, 0])) + margin
            bhi_y = max(xy[0, 1], max(xy[1, 1], xy[2, 1])) + margin
            if bhi_x < lo_x or bhi_y < lo_y or blo_x > hi_x or blo_y > hi_y:
                continue
        b0x, b0y = _bin(blo_x, lo_x, size, g), _bin(blo_y, lo_y, size, g)
        b1x, b1y = _bin(bhi_x, lo_x, size, g), _bin(bhi_y, lo_y, size, g)
        for by in range(b0y, b1y + 1):
            for bx in range(b0x, b1x + 1):
                b = by * g + bx
                for j in range(start[b], start[b + 1]):
                    r = by_bin[j]
                    if not (blo_x <= ray_xy[r, 0] <= bhi_x and blo_y <= ray_xy[r, 1] <= bhi_y):
                        continue
                    t = _moller_trumbore(corners, edges, face, origins, directions, r, edge_margin)
                    if t > t_min[r]:
                        if found == cap:
                            cap *= 2
                            hit_ray, hit_t, hit_face = _grown(hit_ray, cap), _grown(hit_t, cap), _grown(hit_face, cap)
                        hit_ray[found], hit_t[found], hit_face[found] = r, t, face
                        found += 1
    return hit_ray[:found], hit_t[:found], hit_face[:found]


@numba.njit(cache=True, inline="always")
def _bin(x, lo, size, g):
    """The bin of coordinate ``x`` (clipped to the grid; NaN to the first bin, as ``np.nan_to_num``)."""
    v = (x - lo) / size
    if not v > 0.0:
        return 0
    return int(min(v, g - 1.0))


@numba.njit(cache=True)
def _grown(a, cap):
    out = np.empty(cap, a.dtype)
    out[:len(a)] = a
    return out


@numba.njit(cache=True, inline="always")
def _moller_trumbore(corners, edges, face, origins, directions, r, eps):
    """The ray's ``t`` on the face where it crosses it (edges included by ``eps``), else NaN: the
    arithmetic of :func:`.order._moller_trumbore` (``np.cross``, then products summed x + y + z)."""
    dx, dy, dz = directions[r, 0], directions[r, 1], directions[r, 2]
    e1x, e1y, e1z = edges[face, 0, 0], edges[face, 0, 1], edges[face, 0, 2]
    e2x, e2y, e2z = edges[face, 1, 0], edges[face, 1, 1], edges[face, 1, 2]
    px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = e1x * px + e1y * py + e1z * pz
    if det == 0.0:
        return np.nan
    inv = 1.0 / det
    sx, sy, sz = origins[r, 0] - corners[face, 0, 0], origins[r, 1] - corners[face, 0, 1], \
        origins[r, 2] - corners[face, 0, 2]
    u = (sx * px + sy * py + sz * pz) * inv
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
    v = (dx * qx + dy * qy + dz * qz) * inv
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    if u >= -eps and v >= -eps and u + v <= 1 + eps and np.isfinite(t):
        return t
    return np.nan


@numba.njit(cache=True)
def distances(points, eye):
    """``(N,)`` each point's distance from ``eye``: :func:`.order.centroid_depth`'s perspective depth,
    bit for bit (``np.linalg.norm(points - eye, axis=1)`` sums the squares x + y + z in that
    order), in one pass instead of four."""
    out = np.empty(len(points))
    for i in range(len(points)):
        dx, dy, dz = points[i, 0] - eye[0], points[i, 1] - eye[1], points[i, 2] - eye[2]
        out[i] = np.sqrt(dx * dx + dy * dy + dz * dz)
    return out
