"""The exact visibility order's per-view loops compiled with numba (the optional extra ``numba``):
the same relations and the same topological sort as :mod:`.order`'s numpy code, result for result
(``tests/test_projected_tetrahedra.py`` checks both paths give the same order, ``tests/test_order_sorts.py``
the sorts), in one pass each instead of a few dozen numpy passes and sorts: the faces' relations
written straight into each cell's record (key, counts and the cells behind it in 32 bytes), Kahn's
sort on the records, and the final order by a bucket sort of the keys.

Imported only through :func:`.order.compiled`, which falls back to the numpy code where numba is
not installed.  Every function is ``njit(cache=True)``: the first call of a fresh install compiles
(a few seconds, once), later processes load the compiled code from ``__pycache__``.
"""

from __future__ import annotations

import numba
import numpy as np


def exact_order(n, pairs, front_of, extra_front, extra_back, depth, original=None):
    """Cells ``0..n-1`` front to back and the cycles broken, as :func:`.order.topological` gives them for
    the relations across the interior faces (``front_of``: each face's front cell, of its two in ``pairs``)
    and the ``extra`` ones (across gaps): Kahn's sort a level at a time, each cell's key the largest
    ``depth`` of itself and of every cell related in front of it (final when its cell goes out, so one pass
    in level order carries it); a cycle (no cell left free) is broken by taking the cell not yet out with
    the smallest key (the lowest index among equal ones); the order is by key, ties by level, then by index.
    A relation given twice counts twice both ways (in the in-degree and when released), which gives the same
    levels and keys as counting it once.

    ``original``: the cells renumbered (:func:`.order.locality_order`: ``original[i]`` is cell ``i``'s
    index in the mesh): ties (cycles broken, the order's last key) go by the original index and the
    order is of original indices, the order of the mesh's own numbering."""
    records = _records(np.asarray(depth, np.float64))
    _given_relations(records, pairs, front_of)
    return _sorted(records, extra_front, extra_back, original)


def view_order(pairs, face_point, face_normal, normal_length, eye, forward, perspective, edge_on_sine, depth,
               extra_front, extra_back, original=None):
    """``(order, broken, flat)``: :func:`exact_order` with each interior face's front cell decided
    (:func:`_face_relations`) in the same pass that relates the cells (no array of fronts), and how
    many faces were seen edge on."""
    records = _records(np.asarray(depth, np.float64))
    flat = _face_relations(records, pairs, face_point, face_normal, normal_length, eye, forward, perspective,
                           edge_on_sine)
    order, broken = _sorted(records, extra_front, extra_back, original)
    return order, broken, flat


def _records(depth):
    """Each cell's 32-byte record, in a float64 array ``(4 n,)`` aligned to 64 bytes (two records a
    cache line): its key (float64, ``depth`` to begin with), then as int32 its count of relations
    in front of it not yet settled (``-1 - level`` once out), its count of cells behind it across
    its faces and those cells (at most four).  Kahn's sort is bound by random accesses to the cells;
    with all a cell needs in one record, a cell going out touches one cache line, and each relation
    it settles one more (three and one with the key, counts and faces in separate arrays)."""
    n = len(depth)
    raw = np.empty(4 * n + 8)
    first = (-raw.ctypes.data % 64) // 8
    records = raw[first:first + 4 * n]
    _fill(records, depth)
    return records


@numba.njit(cache=True)
def _fill(records, depth):
    """Each record's key ``depth``, no relations yet."""
    ints = records.view(np.int32)
    for i in range(len(depth)):
        records[4 * i] = depth[i]
        ints[8 * i + 2] = 0
        ints[8 * i + 3] = 0


@numba.njit(cache=True, inline="always")
def _relate(ints, front, back):
    """``front`` in front of ``back`` across their shared face."""
    out = ints[8 * front + 3]
    ints[8 * front + 4 + out] = back
    ints[8 * front + 3] = out + 1
    ints[8 * back + 2] += 1


@numba.njit(cache=True)
def _given_relations(records, pairs, front_of):
    """The interior faces' relations from each face's front cell ``front_of`` (one of its ``pairs``); a
    cell is in at most four pairs (one a face), so its record holds the cells behind it."""
    ints = records.view(np.int32)
    for f in range(len(pairs)):
        a, b = pairs[f, 0], pairs[f, 1]
        if front_of[f] == a:
            _relate(ints, a, b)
        else:
            _relate(ints, b, a)


@numba.njit(cache=True)
def _face_relations(records, pairs, face_point, face_normal, normal_length, eye, forward, perspective,
                    edge_on_sine):
    """The interior faces' relations and how many faces are seen edge on, as
    :func:`.order.face_relations` and :meth:`.order.VisibilityOrder.__call__` decide them: the cell on
    the eye's side in front (the normal pointing out of ``pairs[:, 0]``); a face whose plane passes
    within ``edge_on_sine`` (relative sine) of the eye, or lies along the view direction, is seen
    edge on: the cell whose centroid depth (its record's key, before the sort) is smaller, or equal,
    goes first.  ``eye`` for a perspective camera (``perspective``), else ``forward``."""
    ints = records.view(np.int32)
    flat = 0
    fx, fy, fz = -forward[0], -forward[1], -forward[2]
    toward_length = np.sqrt(fx * fx + fy * fy + fz * fz)
    for i in range(len(pairs)):
        if perspective:
            fx = eye[0] - face_point[i, 0]
            fy = eye[1] - face_point[i, 1]
            fz = eye[2] - face_point[i, 2]
            toward_length = np.sqrt(fx * fx + fy * fy + fz * fz)
        side = face_normal[i, 0] * fx + face_normal[i, 1] * fy + face_normal[i, 2] * fz
        a, b = pairs[i, 0], pairs[i, 1]
        b_first = side > 0  # the eye beyond a's face: b is on the eye's side
        if abs(side) <= edge_on_sine * (normal_length[i] * toward_length):
            flat += 1
            b_first = not records[4 * a] <= records[4 * b]
        # one call with the cells selected, not a branch each way: which way a face faces changes from
        # face to face, and mispredicted branches cost more than the selects
        _relate(ints, b if b_first else a, a if b_first else b)
    return flat


def _sorted(records, extra_front, extra_back, original):
    """The order and the cycles broken, from the records with the faces' relations in them."""
    extra_start, extra_next = _extra_relations(records, np.asarray(extra_front, np.int64),
                                               np.asarray(extra_back, np.int64))
    numbering = np.zeros(0, np.int64) if original is None else np.asarray(original, np.int64)
    broken = _levels(records, extra_start, extra_next, numbering)
    place, level = _place_level(records, numbering)
    return _by_key(place, level), broken


@numba.njit(cache=True)
def _extra_relations(records, extra_front, extra_back):
    """The relations across gaps (any number a cell) by front cell, ``(start (n + 1,), next)``, counted
    in the records of their back cells."""
    ints = records.view(np.int32)
    n, m = len(records) // 4, len(extra_front)
    extra_start = np.zeros(n + 1, np.int64)
    for r in range(m):
        extra_start[extra_front[r] + 1] += 1
        ints[8 * extra_back[r] + 2] += 1
    for i in range(n):
        extra_start[i + 1] += extra_start[i]
    extra_next = np.empty(m, np.int32)
    fill = extra_start[:n].copy()
    for r in range(m):
        extra_next[fill[extra_front[r]]] = extra_back[r]
        fill[extra_front[r]] += 1
    return extra_start, extra_next


@numba.njit(cache=True)
def _levels(records, extra_start, extra_next, original):
    """Kahn's sort on the records: each cell's key and ``-1 - level`` left in its record; the cycles
    broken (a tie of key broken by the lower ``original`` index, else by the lower index)."""
    ints = records.view(np.int32)
    n = len(records) // 4
    frontier = np.empty(n + 1, np.int32)  # one spare: a release writes its cell before it counts
    following = np.empty(n + 1, np.int32)
    size = 0
    for i in range(n):
        frontier[size] = i
        size += ints[8 * i + 2] == 0
    remaining, step, broken = n, 0, 0
    while remaining:
        if size == 0:  # a cycle: the nearest remaining cell goes first
            best = -1
            for i in range(n):
                if ints[8 * i + 2] >= 0 and (best < 0 or records[4 * i] < records[4 * best] or (
                        len(original) and records[4 * i] == records[4 * best] and original[i] < original[best])):
                    best = i
            frontier[0] = best
            size = 1
            broken += 1
        for k in range(size):
            ints[8 * frontier[k] + 2] = -1 - step  # out, at this level
        remaining -= size
        step += 1
        nxt = 0
        for k in range(size):
            c = frontier[k]
            key = records[4 * c]
            for j in range(ints[8 * c + 3]):
                nxt = _release(ints[8 * c + 4 + j], key, records, ints, following, nxt)
            for j in range(extra_start[c], extra_start[c + 1]):
                nxt = _release(extra_next[j], key, records, ints, following, nxt)
        frontier, following = following, frontier
        size = nxt
    return broken


@numba.njit(cache=True, inline="always")
def _release(s, key, records, ints, following, nxt):
    """One relation to ``s`` settled by a cell of key ``key``: ``s`` takes the larger key and joins
    the next level when nothing is left in front of it (a cell out already, past a broken cycle,
    keeps its key).  The next level's size.  Without branches on the data (a select and a count),
    which the sort's mispredictions cost."""
    count = ints[8 * s + 2]
    if count < 0:
        return nxt
    v = records[4 * s]
    records[4 * s] = key if key > v else v
    count -= 1
    ints[8 * s + 2] = count
    following[nxt] = s
    return nxt + (count == 0)


@numba.njit(cache=True)
def _place_level(records, original):
    """Each cell's key and level from the records, in the mesh's own numbering where ``original``."""
    ints = records.view(np.int32)
    n = len(records) // 4
    place, level = np.empty(n), np.empty(n, np.int32)
    for i in range(n):
        j = original[i] if len(original) else i
        place[j] = records[4 * i]
        level[j] = -1 - ints[8 * i + 2]
    return place, level


#: A bucket of :func:`_by_key` with more cells than this is sorted by merge sorts, not by insertion.
SMALL_BUCKET = 32


@numba.njit(cache=True)
def _by_key(place, level):
    """Cells by ``place``, ties by ``level``, then by index (``np.lexsort((level, place))``; -0.0 and
    0.0 equal, no NaNs expected): a bucket sort.  The buckets are a monotone function of the value
    (so the buckets are in order and only a bucket's own cells need sorting): about ``n / 32``
    equal ranges of value, each split in turn into as many equal parts as half its cells, so that
    clustered values (the oxygen post's refined blocks) spread too; cells go into their buckets in
    index order, and each bucket is sorted by (value, level), stably, by insertion (a few cells) or
    by two stable merge sorts.  Two passes over the values and one scatter, where a radix sort of
    64-bit keys takes five or six."""
    n = len(place)
    lo, hi = np.inf, -np.inf
    for i in range(n):
        lo = min(lo, place[i])
        hi = max(hi, place[i])
    span = hi - lo
    ranges = max(n >> 5, 1) if 0.0 < span < np.inf else 1
    scale = ranges / span if ranges > 1 else 0.0
    per_range = np.zeros(ranges + 1, np.int32)
    for i in range(n):  # x = (place - lo) * scale, x's integer part its range: each step monotone
        per_range[min(int((place[i] - lo) * scale), ranges - 1) if ranges > 1 else 0] += 1
    base = np.empty(ranges + 1, np.int32)  # each range's first bucket
    base[0] = 0
    for r in range(ranges):
        per_range[r] = max(per_range[r] >> 1, 1)  # its buckets
        base[r + 1] = base[r] + per_range[r]
    buckets = base[ranges]
    start = np.zeros(buckets + 1, np.int32)
    bucket = np.empty(n, np.int32)
    for i in range(n):
        b = 0
        if ranges > 1:
            x = (place[i] - lo) * scale
            r = min(int(x), ranges - 1)
            b = base[r] + min(int((x - r) * per_range[r]), per_range[r] - 1)
        bucket[i] = b
        start[b + 1] += 1
    for b in range(buckets):
        start[b + 1] += start[b]
    fill = start[:buckets].copy()
    keys, levels, cells = np.empty(n), np.empty(n, np.int32), np.empty(n, np.int32)
    for i in range(n):
        p = fill[bucket[i]]
        fill[bucket[i]] = p + 1
        keys[p], levels[p], cells[p] = place[i], level[i], i
    for b in range(buckets):
        s, e = start[b], start[b + 1]
        if e - s > SMALL_BUCKET:
            by = np.argsort(levels[s:e], kind="mergesort")
            by = by[np.argsort(keys[s:e][by], kind="mergesort")]
            cells[s:e] = cells[s:e][by]
            continue
        for p in range(s + 1, e):  # insertion, stable
            k, lv, c = keys[p], levels[p], cells[p]
            q = p - 1
            while q >= s and (keys[q] > k or (keys[q] == k and levels[q] > lv)):
                keys[q + 1], levels[q + 1], cells[q + 1] = keys[q], levels[q], cells[q]
                q -= 1
            keys[q + 1], levels[q + 1], cells[q + 1] = k, lv, c
    return cells


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


@numba.njit(cache=True)
def across_gaps(ray, t_key, leaving, cell, n_rays):
    """``(front, back)`` cells across the gaps along the rays, as :func:`.order._across_gaps` relates
    them, relation for relation and in its order: the hits (``ray``, ``t_key``: where along it, an
    exit moved earlier by the touching distance; ``leaving``; ``cell``) grouped by ray (a counting
    sort, stable), each ray's sorted by ``t_key``, exits before entries at the same one, then in the
    order given (``np.lexsort((~leaving, t_key, ray))``), and each entry related to every exit since the
    ray's previous entry (of another cell)."""
    m = len(ray)
    start = np.zeros(n_rays + 1, np.int64)
    for h in range(m):
        start[ray[h] + 1] += 1
    for r in range(n_rays):
        start[r + 1] += start[r]
    fill = start[:n_rays].copy()
    hits = np.empty(m, np.int64)
    for h in range(m):
        hits[fill[ray[h]]] = h
        fill[ray[h]] += 1
    front, back = np.empty(m, np.int64), np.empty(m, np.int64)
    found = 0
    for r in range(n_rays):
        s, e = start[r], start[r + 1]
        if e - s > SMALL_BUCKET:  # two stable merge sorts
            by = np.argsort(~leaving[hits[s:e]], kind="mergesort")
            by = by[np.argsort(t_key[hits[s:e]][by], kind="mergesort")]
            hits[s:e] = hits[s:e][by]
        else:
            for p in range(s + 1, e):  # insertion, stable
                h = hits[p]
                q = p - 1
                while q >= s and (t_key[hits[q]] > t_key[h] or (
                        t_key[hits[q]] == t_key[h] and leaving[h] and not leaving[hits[q]])):
                    hits[q + 1] = hits[q]
                    q -= 1
                hits[q + 1] = h
        first = s  # hits[first:p]: the exits since the ray's last entry
        for p in range(s, e):
            h = hits[p]
            if leaving[h]:
                continue
            for q in range(first, p):
                if cell[hits[q]] != cell[h]:
                    if found == len(front):
                        front, back = _grown(front, 2 * found), _grown(back, 2 * found)
                    front[found], back[found] = cell[hits[q]], cell[h]
                    found += 1
            first = p + 1
    return front[:found], back[:found]


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


@numba.njit(cache=True, nogil=True)
def reaching(points, tets, view_projection, width, height, margin, out, tile, tiles):
    """``out[c]``: whether cell ``c``'s projected bounding box, grown by ``margin`` pixels, holds a pixel
    centre of the ``width`` x ``height`` image (:func:`.order.reaching`'s loops; every point in front of
    the eye's plane); ``tiles[c]``: the first and last column and row of the ``tile`` x ``tile``-pixel
    screen tiles holding those pixel centres, where ``tile > 0`` (:func:`.order.reaching`'s packing)."""
    m = view_projection
    q = np.empty((len(points), 2))
    for i in range(len(points)):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        w = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
        q[i, 0] = ((m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]) / w * 0.5 + 0.5) * width
        q[i, 1] = ((m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]) / w * 0.5 + 0.5) * height
    for c in range(len(tets)):
        a = tets[c, 0]
        x0, x1, y0, y1 = q[a, 0], q[a, 0], q[a, 1], q[a, 1]
        for k in range(1, 4):
            b = tets[c, k]
            x0, x1 = min(x0, q[b, 0]), max(x1, q[b, 0])
            y0, y1 = min(y0, q[b, 1]), max(y1, q[b, 1])
        # pixel centres at i + 0.5, i = 0 .. width - 1
        i0, i1 = max(np.ceil(x0 - margin - 0.5), 0.0), min(np.floor(x1 + margin - 0.5), width - 1.0)
        j0, j1 = max(np.ceil(y0 - margin - 0.5), 0.0), min(np.floor(y1 + margin - 0.5), height - 1.0)
        out[c] = i0 <= i1 and j0 <= j1
        if tile > 0:
            if not out[c]:
                i0, i1, j0, j1 = 0.0, 0.0, 0.0, 0.0
            tiles[c] = ((int(i0) // tile) | ((int(i1) // tile) << 8) | ((int(j0) // tile) << 16)
                        | ((int(j1) // tile) << 24))


@numba.njit(cache=True, nogil=True)
def tile_coherent(order, cell_tiles, columns, rows):
    """:func:`.order.tile_coherent`'s loops: ``order`` (cells) regrouped by screen tile, every tile's
    cells in their order there.  Each tile keeps a queue of the slots whose cells touch it
    (``cell_tiles``: each cell's first and last column and row of the ``columns`` x ``rows`` tiles, packed
    in bytes); sweeps over the tiles take each tile's cells while the next one is first in the queue of
    every tile it touches.  The first slot not taken is always first in all its queues, so every sweep
    takes one; after about eight queue entries' work a slot (a pathological mesh), the slots left go in
    their order.  Packed, a slot's tiles are 4 bytes: the gathers in the order's scattered cells hit the
    cache."""
    n = len(order)
    count = np.zeros(columns * rows + 1, np.int64)
    rect = np.empty(n, np.uint32)
    for p in range(n):
        r = cell_tiles[order[p]]
        rect[p] = r
        for ty in range((r >> 16) & 255, (r >> 24) + 1):
            for tx in range(r & 255, ((r >> 8) & 255) + 1):
                count[ty * columns + tx + 1] += 1
    for t in range(columns * rows):
        count[t + 1] += count[t]
    queue = np.empty(count[-1], np.int32)
    head = count[:-1].copy()
    for p in range(n):
        r = rect[p]
        for ty in range((r >> 16) & 255, (r >> 24) + 1):
            for tx in range(r & 255, ((r >> 8) & 255) + 1):
                t = ty * columns + tx
                queue[head[t]] = p
                head[t] += 1
    head[:] = count[:-1]
    taken = np.zeros(n, np.bool_)
    out = np.empty(n, order.dtype)
    k, budget = 0, 8 * (len(queue) + columns * rows)
    while k < n and budget > 0:
        for t in range(columns * rows):
            budget -= 1
            while head[t] < count[t + 1]:
                p = queue[head[t]]
                if taken[p]:
                    head[t] += 1
                    continue
                if not _first_everywhere(p, t, rect[p], columns, queue, head, taken):
                    break
                taken[p] = True
                out[k] = order[p]
                k += 1
                head[t] += 1
                budget -= 1
    for p in range(n):  # what the budget left, in its order
        if not taken[p]:
            out[k] = order[p]
            k += 1
    return out


@numba.njit(cache=True, inline="always")
def _first_everywhere(p, t, r, columns, queue, head, taken):
    """Whether slot ``p`` (its tiles ``r``, packed) is first, past the slots taken, in the queue of every
    tile it touches but ``t``."""
    if (r & 255) == ((r >> 8) & 255) and ((r >> 16) & 255) == (r >> 24):
        return True
    for ty in range((r >> 16) & 255, (r >> 24) + 1):
        for tx in range(r & 255, ((r >> 8) & 255) + 1):
            u = ty * columns + tx
            if u == t:
                continue
            while taken[queue[head[u]]]:
                head[u] += 1
            if queue[head[u]] != p:
                return False
    return True
