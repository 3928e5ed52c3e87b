"""The average's last host step compiled with numba (the optional extra ``numba``): each pixel's mean
(its line integral over its chord) classified by the transfer function, premultiplied, zero off the box,
in one pass over the image instead of numpy's dozen (four ``np.interp``, the opacity's two transcendental
passes, the division, the masks: about 10 of a cheap 512x512 view's 25 ms).

The same arithmetic as :func:`.projection.average_rgba`'s numpy path, value for value: ``np.interp``'s
piecewise-linear form ``slope (x - x_j) + f_j`` with its slopes made once (constant beyond the end
points), ``1 - exp(-sigma d)`` at one ``unit_distance`` from ``sigma = -ln(1 - alpha) / d`` (alpha clamped
below 1) in the stable forms; libm's ``log1p`` and ``expm1`` may differ from numpy's vectorized ones in
the last bit (the test bounds it).  Imported only through :func:`.projection.compiled_average`;
``njit(cache=True)``: compiled once per install.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, parallel=True)
def classify_means(sums, chord, xp, fp, slopes, alpha_model, unit_distance, alpha_max, out):
    """``out`` ``(H, W, 4)``: the premultiplied RGBA of ``sums / chord`` where ``chord > 0``, zero elsewhere;
    ``xp`` ``(K,)`` the transfer function's values, ``fp`` ``(K, 4)`` its colour and opacity columns,
    ``slopes`` ``(K - 1, 4)`` theirs between the points; ``alpha_model``: the opacity column is alpha per
    ``unit_distance`` (else extinction per world unit)."""
    h, w = sums.shape
    last = len(xp) - 1
    for y in numba.prange(h):  # rows on the cores: the GL is idle by now (its slices were read back)
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
            sigma = -math.log1p(-min(max(o, 0.0), alpha_max)) / unit_distance if alpha_model else o
            alpha = -math.expm1(-sigma * unit_distance)
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
