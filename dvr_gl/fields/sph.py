"""The SPH kernel in float64: the M4 cubic spline (Monaghan and Lattanzio 1985), and the integrals
that footprint tables are made from (a particle's kernel integrated along a line and over a square).

Conventions (SPLASH's, Monaghan's): smoothing length ``h``, support radius ``2h``,

    W(r, h) = w(r / h) / (pi h^3),   w(q) = 1 - 3/2 q^2 + 3/4 q^3   (0 <= q < 1)
                                           = 1/4 (2 - q)^3           (1 <= q < 2)
                                           = 0                       (q >= 2),

of unit integral; it is C2 (its third derivative jumps at ``q = 1`` and ``q = 2``).  Along a line
at distance ``rho`` from its centre the kernel integrates to the footprint ``F(rho) = f(rho / h) /
(pi h^2)``; ``f`` and the partial integrals below have no short closed form, so they are
integrated here by Gauss-Legendre quadrature on pieces cut where the line crosses ``q = 1`` (the
integrand is smooth inside each piece), to float64 rounding.

Snapshot codes state ``h`` differently: GADGET's ``SmoothingLength`` is the support (``2h`` here),
SWIFT's ``SmoothingLengths`` is Dehnen and Aly's ``h``, whose support is ``gamma h`` with ``gamma =
1.825742`` for the cubic spline; the readers convert (:mod:`dvr_gl.io.particles`).
"""

from __future__ import annotations

import functools
import math

import numpy as np

SUPPORT = 2.0  # the support radius in smoothing lengths
#: SWIFT's (Dehnen and Aly 2012) support-to-smoothing-length ratio of the cubic spline.
SWIFT_CUBIC_GAMMA = 1.825742
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(48)


def w(q: np.ndarray) -> np.ndarray:
    """The dimensionless kernel ``w(q)``, ``q = r / h`` (unit integral after ``1 / (pi h^3)``)."""
    q = np.asarray(q, dtype=np.float64)
    inner = 1.0 - 1.5 * q * q + 0.75 * q ** 3
    outer = 0.25 * np.maximum(2.0 - q, 0.0) ** 3
    return np.where(q < 1.0, inner, outer)


def dw(q: np.ndarray) -> np.ndarray:
    """``dw/dq``."""
    q = np.asarray(q, dtype=np.float64)
    return np.where(q < 1.0, -3.0 * q + 2.25 * q * q, -0.75 * np.maximum(2.0 - q, 0.0) ** 2)


def kernel(r2: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``W`` at squared distances ``r2`` for smoothing lengths ``h`` (world units^-3)."""
    h = np.asarray(h, dtype=np.float64)
    return w(np.sqrt(np.asarray(r2, dtype=np.float64)) / h) / (math.pi * h ** 3)


def _line(b: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
    """``integral_{s0}^{s1} w(sqrt(b^2 + s^2)) ds`` (``s >= 0`` on the interval, all in smoothing lengths):
    cut at ``s = sqrt(1 - b^2)`` (where ``q`` crosses 1)."""
    b, s0, s1 = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (b, s0, s1)))
    cut = np.sqrt(np.maximum(1.0 - b * b, 0.0))
    total = np.zeros(b.shape)
    for lo, hi in ((s0, np.minimum(s1, cut)), (np.maximum(s0, cut), s1)):
        span = np.maximum(hi - lo, 0.0)
        s = lo[..., None] + 0.5 * span[..., None] * (_NODES + 1.0)
        total += 0.5 * span * (w(np.sqrt(b[..., None] ** 2 + s * s)) @ _WEIGHTS)
    return total


def line_integral(b: np.ndarray, z0=None, z1=None) -> np.ndarray:
    """``integral_{z0}^{z1} w(sqrt(b^2 + z^2)) dz`` along a line at distance ``b`` from the centre
    (smoothing lengths; ``z`` from the line's nearest approach; default the whole chord): times
    ``1 / (pi h^2)`` the kernel's integral in world units."""
    b = np.asarray(b, dtype=np.float64)
    chord = np.sqrt(np.maximum(SUPPORT ** 2 - b * b, 0.0))
    z0 = -chord if z0 is None else np.clip(z0, -chord, chord)
    z1 = chord if z1 is None else np.clip(z1, -chord, chord)
    z0, z1 = np.broadcast_arrays(z0, np.maximum(z1, z0))
    # split at 0 so that each part runs over s >= 0 (the integrand is even in z)
    neg = _line(b, np.maximum(-z1, 0.0), np.maximum(-z0, 0.0))
    pos = _line(b, np.maximum(z0, 0.0), np.maximum(z1, 0.0))
    return neg + pos


def footprint(b: np.ndarray) -> np.ndarray:
    """The footprint ``f(b) / pi``: the line integral of ``W`` at ``b`` smoothing lengths from the
    centre, times ``h^2`` (so ``F = footprint(rho / h) / h^2``); it integrates to 1 over the plane."""
    return line_integral(b) / math.pi


def _shell(r: np.ndarray) -> np.ndarray:
    """``integral_0^r w(s) s ds``, from the polynomial pieces of ``w``."""
    r = np.minimum(np.asarray(r, dtype=np.float64), SUPPORT)
    inner = lambda x: 0.5 * x ** 2 - 0.375 * x ** 4 + 0.15 * x ** 5  # noqa: E731
    outer = lambda x: x ** 2 - x ** 3 + 0.375 * x ** 4 - 0.05 * x ** 5  # noqa: E731  (1/4 (2 - s)^3 s)
    return np.where(r < 1.0, inner(r), inner(1.0) + outer(r) - outer(1.0))


def slab_mass(z: np.ndarray) -> np.ndarray:
    """The kernel's mass below the plane ``z`` smoothing lengths from its centre (0 at ``-2``, 1 at ``2``):
    a particle's share of a slab is ``slab_mass(z1) - slab_mass(z0)``.  The mass beyond ``|z|`` is the
    integral over ``z' > |z|`` of the disc mass ``m(z') = 2 integral_{z'}^2 w(r) r dr``, by Gauss-Legendre
    on ``[|z|, 1]`` and ``[1, 2]`` (``m`` is smooth on each)."""
    z = np.clip(np.asarray(z, dtype=np.float64), -SUPPORT, SUPPORT)
    a = np.abs(z)
    beyond = np.zeros(a.shape)
    for lo, hi in ((a, np.maximum(a, 1.0)), (np.maximum(a, 1.0), np.full(a.shape, SUPPORT))):
        nodes = lo[..., None] + 0.5 * (hi - lo)[..., None] * (_NODES + 1.0)
        beyond += 0.5 * (hi - lo) * ((2.0 * (_shell(SUPPORT) - _shell(nodes))) @ _WEIGHTS)
    return np.where(z < 0.0, beyond, 1.0 - beyond)


def box_integral(x0, x1, y0, y1, size: int = 1024) -> np.ndarray:
    """The footprint integrated over ``[x0, x1] x [y0, y1]`` (smoothing lengths) by the tensor
    Gauss-Legendre rule on pieces of a tenth of a smoothing length: for tests of the sub-pixel
    footprints (``size`` bounds the nodes per axis)."""
    out = []
    for a0, a1, b0, b1 in zip(*(np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in (x0, x1, y0, y1))):
        a0, a1, b0, b1 = max(a0, -SUPPORT), min(a1, SUPPORT), max(b0, -SUPPORT), min(b1, SUPPORT)
        if a1 <= a0 or b1 <= b0:
            out.append(0.0)
            continue
        xs, xw = _rule(a0, a1, size)
        ys, yw = _rule(b0, b1, size)
        f = footprint(np.sqrt(xs[:, None] ** 2 + ys[None, :] ** 2))
        out.append(float(xw @ f @ yw))
    return np.asarray(out)


def _rule(a: float, b: float, size: int):
    pieces = int(min(max(math.ceil((b - a) / 0.1), 1), size // 8))
    edges = np.linspace(a, b, pieces + 1)
    x, wt = np.polynomial.legendre.leggauss(8)
    half = 0.5 * np.diff(edges)
    nodes = (edges[:-1, None] + half[:, None] * (x + 1.0)).ravel()
    weights = (half[:, None] * wt).ravel()
    return nodes, weights


_FINE_Q = np.linspace(0.0, 1.0, 200001)


@functools.lru_cache(maxsize=1)
def _fine_footprint() -> np.ndarray:
    return footprint(SUPPORT * np.sqrt(_FINE_Q))


def quadrant(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The footprint's share over ``(-2, x) x (-2, y)`` (smoothing lengths; 0 below, 1 at ``(2, 2)``), by a
    48 x 48 Gauss-Legendre rule on the rectangle, the footprint from a 200001-entry table in ``q``
    (linear, 1e-10 of its peak): the float64 judge of a particle smaller than a pixel, whose pixel holds
    ``quadrant(x1, y1) - quadrant(x0, y1) - quadrant(x1, y0) + quadrant(x0, y0)`` of it.  Measured
    within 2e-7 of :func:`box_integral`, and its whole 2.3e-8 off one (the tests of the renderer that
    splats particles)."""
    x = np.clip(np.asarray(x, dtype=np.float64), -SUPPORT, SUPPORT)
    y = np.clip(np.asarray(y, dtype=np.float64), -SUPPORT, SUPPORT)
    x, y = np.broadcast_arrays(x, y)
    table = _fine_footprint()
    out = np.zeros(x.shape)
    flat_x, flat_y, flat = x.ravel(), y.ravel(), out.reshape(-1)
    for i in range(0, len(flat_x), 512):
        xs = -SUPPORT + 0.5 * (flat_x[i:i + 512, None] + SUPPORT) * (_NODES + 1.0)  # (n, 48)
        ys = -SUPPORT + 0.5 * (flat_y[i:i + 512, None] + SUPPORT) * (_NODES + 1.0)
        q = (xs[:, :, None] ** 2 + ys[:, None, :] ** 2) / SUPPORT ** 2
        f = np.where(q < 1.0, np.interp(q, _FINE_Q, table), 0.0)
        wx = 0.5 * (flat_x[i:i + 512, None] + SUPPORT) * _WEIGHTS
        wy = 0.5 * (flat_y[i:i + 512, None] + SUPPORT) * _WEIGHTS
        flat[i:i + 512] = np.einsum("na,nab,nb->n", wx, f, wy)
    return out
