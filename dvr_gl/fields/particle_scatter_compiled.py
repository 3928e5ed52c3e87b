"""The SPH sum scattered from particles onto the points of a grid (:mod:`.particle_scatter`), compiled with
numba (the optional extra ``numba``); imported only through :func:`.particle_scatter.compiled`."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _cell_range(c, reach, lo, size, n):
    """The cells ``[first, last]`` along one axis that ``[c - reach, c + reach]`` meets, clamped into ``[0,
    n)``; ``first > last`` where it misses the grid."""
    u0 = math.floor((c - reach - lo) / size)
    u1 = math.floor((c + reach - lo) / size)
    if u1 < 0 or u0 > n - 1:
        return 1, 0
    return int(max(u0, 0.0)), int(min(u1, n - 1.0))


@numba.njit(cache=True, inline="always")
def _gap(c, lo, size, cell):
    """The distance from ``c`` to cell ``cell`` (``[lo + cell size, lo + (cell + 1) size]``) along one axis."""
    a = lo + cell * size
    return max(a - c, c - (a + size), 0.0)


@numba.njit(cache=True)
def _scatter(px, py, pz, start, lo, size, dims, x, y, z, h, carried, first, last, out):
    """Adds ``W(|p_k - x_j|, h_j) carried[j]`` into ``out[k]`` for the particles ``j`` in ``[first, last)``
    and every point ``p_k = (px[k], py[k], pz[k])`` strictly inside their support ``2 h_j``: the M4 kernel
    of :func:`..sph.kernel` (as :func:`..particles._pair_sum`).  The points are in cell order, cell ``c``'s
    from ``start[c]`` to ``start[c + 1]`` (x fastest, cubes of ``size`` from ``lo``, ``dims`` a side); a
    particle visits the cells of each row (y, z) that the chord of its support through the row's slab
    meets."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    one = carried.shape[1] == 1
    flat = out.reshape(out.shape[0] * out.shape[1])  # the sums of one channel, 1D
    for j in range(first, last):
        hj, xj, yj, zj = h[j], x[j], y[j], z[j]
        reach = 2.0 * hj
        r2max = reach * reach
        y0, y1 = _cell_range(yj, reach, lo[1], size, ny)
        z0, z1 = _cell_range(zj, reach, lo[2], size, nz)
        scale = 1.0 / (math.pi * hj ** 3)
        inverse, weight = 1.0 / hj, carried[j, 0]
        for cz in range(z0, z1 + 1):
            gz = _gap(zj, lo[2], size, cz)
            for cy in range(y0, y1 + 1):
                gy = _gap(yj, lo[1], size, cy)
                rest = r2max - gy * gy - gz * gz
                if rest <= 0.0:
                    continue
                x0, x1 = _cell_range(xj, math.sqrt(rest), lo[0], size, nx)
                if x0 > x1:
                    continue
                row = (cz * ny + cy) * nx
                a, b = start[row + x0], start[row + x1 + 1]
                if one:
                    _row(px, py, pz, a, b, xj, yj, zj, r2max, inverse, scale * weight, flat)
                    continue
                for k in range(a, b):
                    wk = scale * _w(px[k] - xj, py[k] - yj, pz[k] - zj, r2max, inverse)
                    for c in range(carried.shape[1]):
                        out[k, c] += wk * carried[j, c]


@numba.njit(cache=True, inline="always")
def _w(dx, dy, dz, r2max, inverse):
    """The M4 kernel's ``w(q)`` at the offset ``(dx, dy, dz)`` (``q = r / h``, ``inverse = 1 / h``), zero at
    and beyond the support (``r2max = (2 h)^2``); without branches, so that a row's loop vectorizes."""
    r2 = dx * dx + dy * dy + dz * dz
    q = math.sqrt(r2) * inverse
    outer = max(2.0 - q, 0.0)
    wq = 1.0 - q * q * (1.5 - 0.75 * q) if q < 1.0 else 0.25 * outer * outer * outer
    return wq if r2 < r2max else 0.0


@numba.njit(cache=True, inline="always")
def _row(px, py, pz, a, b, xj, yj, zj, r2max, inverse, weight, out):
    """``out[k] += weight w(q)`` for the points ``k`` in ``[a, b)`` (one row of cells); through slices, whose
    indices numba knows to be in range: the loop vectorizes (2.3 ns a point against 7.9)."""
    qx, qy, qz, sums = px[a:b], py[a:b], pz[a:b], out[a:b]
    for k in range(b - a):
        sums[k] += weight * _w(qx[k] - xj, qy[k] - yj, qz[k] - zj, r2max, inverse)


@numba.njit(cache=True)
def _bin(x, y, z, lo, size, dims, clamp):
    """Counting sort of the points ``(x, y, z)`` into the cells (x fastest; cubes of ``size`` from ``lo``,
    ``dims`` a side): ``(order, start)``, the points cell by cell, cell ``c``'s from ``start[c]`` to
    ``start[c + 1]``; a point outside the grid is clamped into it (``clamp``) or left out."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    cell = np.empty(x.shape[0], np.int64)
    start = np.zeros(nx * ny * nz + 1, np.int64)
    for i in range(x.shape[0]):
        u = math.floor((x[i] - lo[0]) / size)
        v = math.floor((y[i] - lo[1]) / size)
        w = math.floor((z[i] - lo[2]) / size)
        if not clamp and (u < 0 or v < 0 or w < 0 or u >= nx or v >= ny or w >= nz):
            cell[i] = -1
            continue
        u, v, w = min(max(u, 0), nx - 1), min(max(v, 0), ny - 1), min(max(w, 0), nz - 1)
        cell[i] = (int(w) * ny + int(v)) * nx + int(u)
        start[cell[i] + 1] += 1
    for c in range(nx * ny * nz):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(start[-1], np.int64)
    for i in range(x.shape[0]):
        if cell[i] >= 0:
            order[fill[cell[i]]] = i
            fill[cell[i]] += 1
    return order, start


@numba.njit(cache=True)
def _take(values, order):
    out = np.empty((order.shape[0],) + values.shape[1:], values.dtype)
    for k in range(order.shape[0]):
        out[k] = values[order[k]]
    return out


@numba.njit(cache=True, parallel=True)
def level_sums(px, py, pz, x, y, z, h, carried, lo, size, dims, threads, out):
    """Adds ``sum_j W(|p_k - x_j|, h_j) carried[j]`` over the particles ``j`` (one level: support radii
    of one to two cells of ``size``) into ``out[k]`` for every point ``p_k = (px[k], py[k], pz[k])`` in the
    grid (cubes of ``size`` from ``lo``, ``dims`` a side; the points outside are beyond every support): the
    points counted into its cells, the particles visited cell by cell in ``threads`` shares (neighbours in
    turn meet the same points), each scattered (:func:`_scatter`) into its own sums, added at the end."""
    order, start = _bin(px, py, pz, lo, size, dims, False)
    sx, sy, sz = _take(px, order), _take(py, order), _take(pz, order)
    who = _bin(x, y, z, lo, size, dims, True)[0]
    wx, wy, wz, wh, wc = _take(x, who), _take(y, who), _take(z, who), _take(h, who), _take(carried, who)
    count = who.shape[0]
    local = np.zeros((threads, order.shape[0], carried.shape[1]))
    for t in numba.prange(threads):
        _scatter(sx, sy, sz, start, lo, size, dims, wx, wy, wz, wh, wc, t * count // threads,
                 (t + 1) * count // threads, local[t])
    for t in range(threads):
        for k in range(order.shape[0]):
            for c in range(carried.shape[1]):
                out[order[k], c] += local[t, k, c]
