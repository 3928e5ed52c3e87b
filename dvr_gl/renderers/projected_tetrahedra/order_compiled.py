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


def exact_order(n, face_slots, pairs, front_of, extra_front, extra_back, depth):
    """Cells ``0..n-1`` front to back and the cycles broken, as :func:`.order.topological` gives them
    for the relations across the interior faces (``front_of``: each face's front cell, of its two
    in ``pairs``; ``face_slots``: which of its cells' four faces it is, ``(F, 2)``) and the
    ``extra`` ones (across gaps): Kahn's sort a level at a time, each cell's key the largest
    ``depth`` of itself and of every cell related in front of it (final when its cell goes out, so
    one pass in level order carries it); a cycle (no cell left free) is broken by taking the cell
    not yet out with the smallest key (the lowest index among equal ones); the order is by key, ties
    by level, then by index.  A relation given twice counts twice both ways (in the in-degree and
    when released), which gives the same levels and keys as counting it once."""
    behind, indegree, extra_start, extra_next = _relations(n, face_slots, pairs, front_of, extra_front, extra_back)
    place, level, steps, broken = _levels(n, behind, extra_start, extra_next, indegree, depth.astype(np.float64))
    by_level = _by_level(level, steps)
    return by_level[stable_argsort(place[by_level])], broken


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
def _levels(n, behind, extra_start, extra_next, indegree, place):
    """Kahn's sort: each cell's key (``place``, in place) and level, the levels' count and the
    cycles broken."""
    level = np.zeros(n, np.int32)
    done = np.zeros(n, np.bool_)
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
                if not done[i] and (best < 0 or place[i] < place[best]):
                    best = i
            frontier[0] = best
            indegree[best] = 0
            size = 1
            broken += 1
        for k in range(size):
            c = frontier[k]
            level[c] = step
            done[c] = True
        remaining -= size
        step += 1
        nxt = 0
        for k in range(size):
            c = frontier[k]
            key = place[c]
            for j in range(4):
                if behind[c, j] >= 0:
                    nxt = _release(behind[c, j], key, place, indegree, done, following, nxt)
            for j in range(extra_start[c], extra_start[c + 1]):
                nxt = _release(extra_next[j], key, place, indegree, done, following, nxt)
        frontier, following = following, frontier
        size = nxt
    return place, level, step, broken


@numba.njit(cache=True, inline="always")
def _release(s, key, place, indegree, done, following, nxt):
    """One relation to ``s`` settled by a cell of key ``key``: ``s`` takes the larger key and joins
    the next level when nothing is left in front of it.  The next level's size."""
    if done[s]:  # out already (past a broken cycle): keeps its key
        return nxt
    if key > place[s]:
        place[s] = key
    indegree[s] -= 1
    if indegree[s] == 0:
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
