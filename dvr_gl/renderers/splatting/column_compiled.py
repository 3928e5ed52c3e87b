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

#: How the loops over a row's run of pixels are compiled: without Python's division checks (a branch that
#: raises in every iteration keeps LLVM from vectorising; no divisor here is zero: supports over 2 pixels,
#: ``u^2 + |v|^2 + 1 >= 1``), with fused multiply-adds, the pixel's offset from a 32-bit counter (AVX2 converts
#: 32-bit integers to doubles four at a time, 64-bit ones not before AVX-512), the run a slice of the row.
#: On the 10^6-particle column one thread's CPU time fell from 1.26-1.91 s to 0.95-1.11 s (the same sums to
#: 4e-16, 2026-11-28, a shared machine).
_RUN = {"error_model": "numpy", "fastmath": {"contract"}}


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


@numba.njit(cache=True, **_RUN)
def _one(out, cx, cy, radius, weights, table, box, subpixel, ray, half):
    """One particle's footprint added to ``out`` ``(channels, height, width)`` (see :func:`deposit`); ``ray``:
    its centre in the view's axes and its support (world units) under a perspective camera, else empty
    (orthographic)."""
    channels, height, width = out.shape
    if ray.shape[0] and not subpixel:
        _one_ray(out, ray[0], ray[1], ray[2], ray[3], weights, table, half[0], half[1])
        return
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
        if channels == 1:  # the column density: one sum (the renderer's usual case), vectorised (_RUN)
            run, weight, d0 = out[0, j, i0:i1 + 1], weights[0], i0 + 0.5 - cx
            for i in range(run.shape[0]):
                dx = d0 + np.float64(np.int32(i))
                f = min((dx * dx + dy2) * inverse, 1.0) * (n - 1)
                k = min(np.int32(f), n - 2)
                run[i] += weight * (table[k] + (f - k) * (table[k + 1] - table[k]))
            continue
        for i in range(i0, i1 + 1):
            dx = i + 0.5 - cx
            f = min((dx * dx + dy2) * inverse, 1.0) * (n - 1)
            k = min(int(f), n - 2)
            value = table[k] + (f - k) * (table[k + 1] - table[k])
            for c in range(channels):
                out[c, j, i] += weights[c] * value


@numba.njit(cache=True, **_RUN)
def _one_ray(out, x, y, z, support, weights, table, half_x, half_y):
    """One particle's footprint along each pixel's own ray (perspective), added to ``out``: ``table`` at ``q =
    |c x d|^2 / (|d|^2 R^2)``, the ray's squared distance from the centre ``c = (x, y, z)`` (view axes, from
    the eye) over the support's, the ray's direction ``d = (u, v, 1)`` through the pixel's centre (``u``, ``v``
    in ``tan`` units of the view's half extents).  The rows are those between the sphere's tangent planes
    through the eye, each row's pixels those between the roots of ``|c x d|^2 = R^2 |d|^2`` (a quadratic in
    ``u``, its leading coefficient ``z^2 + y^2 - R^2 > 0`` in front of the eye), widened by a thousandth of a
    pixel: a pixel beyond the support reads the table's end, zero."""
    channels, height, width = out.shape
    n = table.shape[0]
    r2 = support * support
    du, dv = 2.0 * half_x / width, 2.0 * half_y / height
    den = z * z - r2
    w = math.sqrt(max(y * y + z * z - r2, 0.0))
    v_lo, v_hi = (y * z - support * w) / den, (y * z + support * w) / den
    margin = 1e-3
    j0 = _first((v_lo + half_y) / dv - 0.5 - margin, height, True)
    j1 = _last((v_hi + half_y) / dv - 0.5 + margin, height)
    a = z * z + y * y - r2
    inverse = 1.0 / r2
    for j in range(j0, j1 + 1):
        v = (j + 0.5) * dv - half_y
        b = -2.0 * x * (z + y * v)
        across = y - z * v
        length2 = v * v + 1.0
        c = across * across + (x * x - r2) * length2
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            continue
        root = math.sqrt(disc)
        u0, u1 = (-b - root) / (2.0 * a), (-b + root) / (2.0 * a)
        i0 = _first((u0 + half_x) / du - 0.5 - margin, width, True)
        i1 = _last((u1 + half_x) / du - 0.5 + margin, width)
        a2 = across * across
        if channels == 1:  # the column density: one sum, a loop without branches (_RUN)
            run, weight, u0 = out[0, j, i0:i1 + 1], weights[0], (i0 + 0.5) * du - half_x
            for i in range(run.shape[0]):
                u = u0 + np.float64(np.int32(i)) * du
                bx, ey = z * u - x, x * v - y * u
                f = min((a2 + bx * bx + ey * ey) / (u * u + length2) * inverse, 1.0) * (n - 1)
                k = min(np.int32(f), n - 2)
                run[i] += weight * (table[k] + (f - k) * (table[k + 1] - table[k]))
            continue
        for i in range(i0, i1 + 1):
            u = (i + 0.5) * du - half_x
            bx, ey = z * u - x, x * v - y * u
            f = min((a2 + bx * bx + ey * ey) / (u * u + length2) * inverse, 1.0) * (n - 1)
            k = min(int(f), n - 2)
            value = table[k] + (f - k) * (table[k + 1] - table[k])
            for ch in range(channels):
                out[ch, j, i] += weights[ch] * value


@numba.njit(cache=True)
def deposit_serial(cx, cy, radius, weights, subpixel, rays, half, table, box, height, width):
    """:func:`deposit` on one thread (small frames: waking threads costs more than it saves)."""
    out = np.zeros((weights.shape[1], height, width))
    for p in range(cx.shape[0]):
        _one(out, cx[p], cy[p], radius[p], weights[p], table, box, subpixel[p], rays[p], half)
    return out


@numba.njit(cache=True, parallel=True)
def deposit(cx, cy, radius, weights, subpixel, rays, half, table, box, height, width, threads):
    """The sum over particles of ``weights[p]`` times the footprint at each pixel, ``(channels, height,
    width)`` float64: the footprint table ``table`` (``h^2 F`` over ``q = rho^2 / R^2``) at the pixel's
    centre (orthographic: ``rays`` of ``(N, 0)``), or along the pixel's own ray (perspective: ``rays[p]`` the
    particle's centre in the view's axes (right, up, forward) from the eye and its support ``R``, world
    units; ``half`` the view's half extents ``tan``), or (``subpixel[p]``) the share ``box`` gives the
    pixel's square.  Pixels in pixel units (the centre of pixel ``i`` at ``i + 0.5``); ``radius`` the
    support in pixels (at the particle's depth).  As :func:`.column.deposit_numpy`; ``threads`` images, one
    per thread (``numba.get_num_threads()``)."""
    local = np.zeros((threads, weights.shape[1], height, width))
    count = cx.shape[0]
    for t in numba.prange(threads):
        for p in range(t * count // threads, (t + 1) * count // threads):
            _one(local[t], cx[p], cy[p], radius[p], weights[p], table, box, subpixel[p], rays[p], half)
    out = np.zeros((weights.shape[1], height, width))
    for t in range(threads):
        out += local[t]
    return out
