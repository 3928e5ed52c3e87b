"""The average's host steps compiled with numba (the optional extra ``numba``).

:func:`classify_means`: each pixel's mean (its line integral over its chord) classified by the transfer
function, premultiplied, zero off the box, in one pass over the image instead of numpy's dozen (four
``np.interp``, the opacity's two transcendental passes, the division, the masks: about 10 of a cheap
512x512 view's 25 ms).

:func:`chord_integrals`: the short chords' line integrals of the trilinear field, ray by ray (its knots, the
pieces between them, Gauss-Legendre on each), where numpy gathered knots, pieces and points for all rays
at once (4 ms of a cheap view for about 2000 chords).

The same arithmetic as :func:`.projection.average_rgba`'s numpy path, value for value: ``np.interp``'s
piecewise-linear form ``slope (x - x_j) + f_j`` with its slopes made once (constant beyond the end
points), then one ``unit_distance``'s opacity: for the alpha model the point's alpha itself, clamped to
``[0, ALPHA_MAX]`` (numpy's path goes through ``sigma = -ln(1 - alpha) / d`` and ``1 - exp(-sigma d)`` and
back, which only rounds: within 3 ulp; 1.4 of the kernel's 2.3 ms at 512x512), for the extinction model
``1 - exp(-sigma d)`` by ``expm1`` (libm's may differ from numpy's vectorized one in the last bit; the test
bounds both).  :func:`chord_integrals` is
:func:`.projection.direct_integrals`' arithmetic for the trilinear field (``SampledField.knots``,
``smooth_pieces``, ``SampledField.sample``), summed in the same order.  Imported only through
:func:`.projection.compiled_average`;
``njit(cache=True)``: compiled once per install.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# The kernels run on one core (no ``parallel=True``): with one of this machine's two cores busy elsewhere,
# OpenMP's two threads waited for the descheduled one: the cheap average view (cutoffs in turn) took 26-32 ms
# against 6.1-6.5 on one thread (5.5 against 6.7 at load 1.1; 2026-11-28).


@numba.njit(cache=True)
def classify_means(sums, chord, xp, fp, slopes, alpha_model, unit_distance, alpha_max, out):
    """``out`` ``(H, W, 4)``: the premultiplied RGBA of ``sums / chord`` where ``chord > 0``, zero elsewhere;
    ``xp`` ``(K,)`` the transfer function's values, ``fp`` ``(K, 4)`` its colour and opacity columns,
    ``slopes`` ``(K - 1, 4)`` theirs between the points; ``alpha_model``: the opacity column is alpha per
    ``unit_distance`` (else extinction per world unit)."""
    h, w = sums.shape
    last = len(xp) - 1
    for y in range(h):  # on one core (see the note above)
        for x in range(w):
            length = chord[y, x]
            if not length > 0.0:
                out[y, x, 0] = out[y, x, 1] = out[y, x, 2] = out[y, x, 3] = 0.0
                continue
            v = sums[y, x] / length
            if v < xp[0] or v >= xp[last]:  # constant beyond the end points
                j = 0 if v < xp[0] else last
                r, g, b, o = fp[j, 0], fp[j, 1], fp[j, 2], fp[j, 3]
            else:  # the last point at or below v (K is a handful: a linear scan beats bisection)
                j = 0
                while xp[j + 1] <= v:
                    j += 1
                t = v - xp[j]
                r = slopes[j, 0] * t + fp[j, 0]
                g = slopes[j, 1] * t + fp[j, 1]
                b = slopes[j, 2] * t + fp[j, 2]
                o = slopes[j, 3] * t + fp[j, 3]
            if alpha_model:  # one unit_distance's opacity is the point's own alpha: no log1p and expm1 to undo
                alpha = min(max(o, 0.0), alpha_max)
            else:
                alpha = -math.expm1(-o * unit_distance)
            out[y, x, 0] = r * alpha
            out[y, x, 1] = g * alpha
            out[y, x, 2] = b * alpha
            out[y, x, 3] = alpha
    return out


def average_rgba(tf, sums: np.ndarray, chord: np.ndarray, alpha_max: float) -> np.ndarray:
    """:func:`classify_means` on a transfer function (``(H, W, 4)`` float64, made here)."""
    out = np.empty(sums.shape + (4,))
    xp = np.ascontiguousarray(tf.points[:, 0], dtype=np.float64)
    fp = np.ascontiguousarray(tf.points[:, 1:5], dtype=np.float64)
    slopes = np.diff(fp, axis=0) / np.diff(xp)[:, None]  # np.interp's own, made once
    return classify_means(np.ascontiguousarray(sums, dtype=np.float64), np.ascontiguousarray(chord, np.float64),
                          xp, fp, slopes, tf.opacity_model == "alpha", float(tf.unit_distance), alpha_max, out)


@numba.njit(cache=True, inline="always")
def _trilinear(values, u0, u1, u2):
    """``SampledField.sample`` of the linear filter at voxel coordinates ``(u0, u1, u2)`` (x, y, z): clamped
    to the grid, the cell's lower corner at most ``n - 2``, the eight taps added z, y, x outermost first."""
    nz, ny, nx = values.shape
    xs, ys, zs = min(max(u0, 0.0), nx - 1.0), min(max(u1, 0.0), ny - 1.0), min(max(u2, 0.0), nz - 1.0)
    ix, iy, iz = min(int(math.floor(xs)), max(nx - 2, 0)), min(int(math.floor(ys)), max(ny - 2, 0)), \
        min(int(math.floor(zs)), max(nz - 2, 0))
    fx, fy, fz = xs - ix, ys - iy, zs - iz
    total = 0.0
    for c in range(2):
        z, wz = min(iz + c, nz - 1), fz if c else 1.0 - fz
        for b in range(2):
            y, wy = min(iy + b, ny - 1), fy if b else 1.0 - fy
            for a in range(2):
                x, wx = min(ix + a, nx - 1), fx if a else 1.0 - fx
                total += (wz * wy * wx) * values[z, y, x]
    return total


@numba.njit(cache=True)
def chord_integrals(values, spacing, origin, origins, directions, t0, t1, nodes, weights):
    """The integral of the trilinear field ``values`` ``(nz, ny, nx)`` (``spacing``, ``origin``: x, y, z world
    units) along each ray ``origins + t directions`` over ``[t0, t1]``: the pieces between the planes where
    the filter's knots lie (the grid's, inside it), each by Gauss-Legendre ``nodes``/``weights`` on [-1, 1]."""
    out = np.zeros(len(t0))
    dims = (values.shape[2], values.shape[1], values.shape[0])
    knots = np.empty(sum(dims) + 2)
    for r in range(len(t0)):
        out[r] = _chord_integral(values, spacing, origin, origins[r], directions[r], t0[r], t1[r], nodes, weights,
                                 dims, knots)
    return out


@numba.njit(cache=True)
def _chord_integral(values, spacing, origin, o, direction, a, b, nodes, weights, dims, knots):
    """One ray's integral for :func:`chord_integrals` (0 for an empty chord, ``b <= a``); ``knots`` scratch."""
    if not b > a:
        return 0.0
    m = 0
    knots[m] = a
    m += 1
    for axis in range(3):
        d = direction[axis] / spacing[axis]
        if d == 0.0:
            continue
        u0 = (o[axis] - origin[axis]) / spacing[axis]
        ua, ub = u0 + a * d, u0 + b * d
        lo = max(math.ceil(min(ua, ub)), 0.0)
        hi = min(math.floor(max(ua, ub)), dims[axis] - 1.0)
        k = lo
        while k <= hi:
            t = (k - u0) / d
            if a < t < b:
                knots[m] = t
                m += 1
            k += 1.0
    knots[m] = b
    m += 1
    # insertion sort in place: a short chord's dozen knots, in three runs each already in order (np.sort's
    # copy a ray: 1.71 ms for the blobs' 2140 short chords, this 0.98; the same order, the same sums)
    for i in range(1, m):
        x = knots[i]
        j = i - 1
        while j >= 0 and knots[j] > x:
            knots[j + 1] = knots[j]
            j -= 1
        knots[j + 1] = x
    total = 0.0
    for i in range(m - 1):
        lo_t, hi_t = knots[i], knots[i + 1]
        if not hi_t > lo_t:
            continue
        half = 0.5 * (hi_t - lo_t)
        piece = 0.0
        for q in range(len(nodes)):
            t = lo_t + half * (nodes[q] + 1.0)
            ux = (o[0] + t * direction[0] - origin[0]) / spacing[0]
            uy = (o[1] + t * direction[1] - origin[1]) / spacing[1]
            uz = (o[2] + t * direction[2] - origin[2]) / spacing[2]
            piece += _trilinear(values, ux, uy, uz) * weights[q]
        total += half * piece
    return total
