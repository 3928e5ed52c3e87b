"""The column of SPH particles deposited on the host, compiled with numba (the optional extra ``numba``):
the loops of :func:`.column.deposit_numpy`, the same sums in the same order per particle.

Imported only through :func:`.column.compiled`, which falls back to the numpy code (or the GL path) where
numba is not installed.  Every particle adds to its own pixels of a per-thread image (float64), so the
threads never write the same memory; the images are summed at the end.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _lerp(table, x):
    """``table`` read linearly at ``x`` in [0, 1] (entries at its ends), as the shaders' ``table_1d``."""
    n = table.shape[0]
    f = min(max(x, 0.0), 1.0) * (n - 1)
    i = min(int(f), n - 2)
    return table[i] + (f - i) * (table[i + 1] - table[i])


@numba.njit(cache=True, inline="always")
def _box(box, x, y):
    """``G(x, y)`` (units of the support, in [-1, 1]) read bilinearly, as the shaders' ``table_2d``."""
    n = box.shape[0]
    fx = (min(max(x, -1.0), 1.0) * 0.5 + 0.5) * (n - 1)
    fy = (min(max(y, -1.0), 1.0) * 0.5 + 0.5) * (n - 1)
    i = min(int(fx), n - 2)
    j = min(int(fy), n - 2)
    wx, wy = fx - i, fy - j
    a = box[i, j] + wx * (box[i + 1, j] - box[i, j])
    b = box[i, j + 1] + wx * (box[i + 1, j + 1] - box[i, j + 1])
    return a + wy * (b - a)


@numba.njit(cache=True, inline="always")
def _first(x, n, ceil=False):
    """The first pixel index at or after ``x`` (``ceil``) or holding it, clamped to [0, n] before the integer
    conversion (a particle far outside the image has coordinates beyond int64)."""
    x = min(max(x, -1.0), float(n))
    return max(int(math.ceil(x)) if ceil else int(math.floor(x)), 0)


@numba.njit(cache=True, inline="always")
def _last(x, n):
    """The last pixel index at or before ``x``, clamped to [-1, n - 1]."""
    return min(int(math.floor(min(max(x, -1.0), float(n)))), n - 1)


@numba.njit(cache=True)
def _one(out, cx, cy, radius, weights, table, box, subpixel):
    """One particle's footprint added to ``out`` ``(channels, height, width)`` (see :func:`deposit`)."""
    channels, height, width = out.shape
    if subpixel:  # each pixel's square: G's differences (weights per unit of pixel area)
        i0, i1 = _first(cx - radius, width), _last(cx + radius, width)
        j0, j1 = _first(cy - radius, height), _last(cy + radius, height)
        for j in range(j0, j1 + 1):
            y0, y1 = (j - cy) / radius, (j + 1 - cy) / radius
            for i in range(i0, i1 + 1):
                x0, x1 = (i - cx) / radius, (i + 1 - cx) / radius
                mass = _box(box, x1, y1) - _box(box, x0, y1) - _box(box, x1, y0) + _box(box, x0, y0)
                for c in range(channels):
                    out[c, j, i] += weights[c] * mass
        return
    inverse = 1.0 / (radius * radius)
    n = table.shape[0]
    j0, j1 = _first(cy - radius - 0.5, height, True), _last(cy + radius - 0.5, height)
    for j in range(j0, j1 + 1):
        dy = j + 0.5 - cy
        rest = radius * radius - dy * dy
        if rest <= 0.0:
            continue
        half = math.sqrt(rest)
        i0, i1 = _first(cx - half - 0.5, width, True), _last(cx + half - 0.5, width)
        dy2 = dy * dy
        if channels == 1:  # the column density: one sum (the renderer's usual case)
            row, weight = out[0, j], weights[0]
            for i in range(i0, i1 + 1):
                dx = i + 0.5 - cx
                f = min((dx * dx + dy2) * inverse, 1.0) * (n - 1)
                k = min(int(f), n - 2)
                row[i] += weight * (table[k] + (f - k) * (table[k + 1] - table[k]))
            continue
        for i in range(i0, i1 + 1):
            dx = i + 0.5 - cx
            f = min((dx * dx + dy2) * inverse, 1.0) * (n - 1)
            k = min(int(f), n - 2)
            value = table[k] + (f - k) * (table[k + 1] - table[k])
            for c in range(channels):
                out[c, j, i] += weights[c] * value


@numba.njit(cache=True)
def deposit_serial(cx, cy, radius, weights, subpixel, table, box, height, width):
    """:func:`deposit` on one thread (small frames: waking threads costs more than it saves)."""
    out = np.zeros((weights.shape[1], height, width))
    for p in range(cx.shape[0]):
        _one(out, cx[p], cy[p], radius[p], weights[p], table, box, subpixel[p])
    return out


@numba.njit(cache=True, parallel=True)
def deposit(cx, cy, radius, weights, subpixel, table, box, height, width, threads):
    """The sum over particles of ``weights[p]`` times the footprint at each pixel, ``(channels, height,
    width)`` float64: the footprint table ``table`` (``h^2 F`` over ``q = rho^2 / R^2``) at the pixel's
    centre, or (``subpixel[p]``) the share ``box`` gives the pixel's square.  Pixels in pixel units (the
    centre of pixel ``i`` at ``i + 0.5``); ``radius`` the support ``R`` in pixels.  As
    :func:`.column.deposit_numpy`; ``threads`` images, one per thread (``numba.get_num_threads()``)."""
    local = np.zeros((threads, weights.shape[1], height, width))
    count = cx.shape[0]
    for t in numba.prange(threads):
        for p in range(t * count // threads, (t + 1) * count // threads):
            _one(local[t], cx[p], cy[p], radius[p], weights[p], table, box, subpixel[p])
    out = np.zeros((weights.shape[1], height, width))
    for t in range(threads):
        out += local[t]
    return out
