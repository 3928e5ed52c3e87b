"""Pre-integration tables: the emission-absorption integral of a segment, by its end values.

For a segment of length ``d`` along which the scalar runs linearly from ``sf``
(front) to ``sb`` (back), the table holds the associated colour ``C`` and the
optical depth ``tau`` of the whole segment (opacity ``1 - exp(-tau)``; depth,
not opacity, is interpolated and accumulated, as everywhere else).  Entries sit on ``N`` evenly spaced
values over the transfer function's domain in both ``sf`` and ``sb`` (node
centred, like the 1D table), and are interpolated bilinearly between them.

**Exact table** (default).  The transfer function enters as the same 1D table
the renderers use, refined so that its nodes include the pre-integration
nodes: ``M = r (N - 1) + 1`` nodes, with colour and extinction linear between
them.  A segment from node ``i`` to node ``j`` therefore crosses ``|j - i| r``
fine pieces of equal length ``d / (|j - i| r)``.  Each piece is integrated with
its self-attenuation: optically thin pieces (depth at most 0.5, the usual case)
by a power series in the length whose moments are computed once; thicker ones
by Gauss-Legendre quadrature, subdivided so that no part holds an optical depth
over 1 (so a huge ``sigma d`` stays accurate); then, for
each difference ``|j - i|``, the pieces are composited node to node and every
entry is the composite of a window of those, assembled from power-of-two spans
with the over operator ``(C_a + exp(-tau_a) C_b, tau_a + tau_b)``: products of
factors at most 1, no subtraction, no overflow.  ``sf == sb`` is the closed form
``c (1 - exp(-sigma d))`` (no division).  The cost is ``O(N M log r)``: about 0.2 s at 256 x 256 on two cores.

**Fast table** (Engel, Kraus and Ertl 2001).  Integral functions ignore the
attenuation inside the segment: optical depth ``d (S(sb) - S(sf)) / (sb - sf)``
with ``S`` the integral of extinction (exact), and emission
``E = d (K(sb) - K(sf)) / (sb - sf)`` with ``K`` the integral of extinction times
colour; the colour held is ``E (1 - exp(-tau)) / tau``, the extinction-weighted mean colour
times the exact opacity (see :func:`_engel`: without the normalization ``E`` exceeds 1 on
optically thick segments); ``O(N^2)``.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from .errors import SceneError
from .limits import check_preintegration_memory


def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w  # on [0, 1]


GAUSS = {5: _gauss(5), 8: _gauss(8)}
METHODS = ("exact", "fast")


@dataclass(frozen=True, eq=False)
class PreintegrationTable:
    """``table[i_front, i_back] = (C_r, C_g, C_b, tau)`` for segments of length ``segment_length``,
    front and back values at ``domain[0] + i (domain[1] - domain[0]) / (N - 1)``."""

    table: np.ndarray
    domain: tuple[float, float]
    segment_length: float
    method: str
    source: object = None   # the fine 1D table integrated (TransferFunctionLUT)

    @property
    def size(self) -> int:
        return self.table.shape[0]

    def node_coordinate(self, values) -> np.ndarray:
        lo, hi = self.domain
        x = (np.asarray(values, dtype=np.float64) - lo) * ((self.size - 1) / (hi - lo))
        return np.clip(x, 0.0, self.size - 1)

    def lookup(self, front, back) -> tuple[np.ndarray, np.ndarray]:
        """Associated colour ``(..., 3)`` and optical depth of segments, by bilinear interpolation."""
        x, y = self.node_coordinate(front), self.node_coordinate(back)
        i0 = np.minimum(np.floor(x).astype(np.int64), self.size - 2)
        j0 = np.minimum(np.floor(y).astype(np.int64), self.size - 2)
        fx, fy = (x - i0)[..., None], (y - j0)[..., None]
        t = self.table
        row = (t[i0, j0] * (1 - fx) + t[i0 + 1, j0] * fx) * (1 - fy) + \
              (t[i0, j0 + 1] * (1 - fx) + t[i0 + 1, j0 + 1] * fx) * fy
        return row[..., :3], row[..., 3]


def _pieces(sigma: np.ndarray, colour: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Attenuated emission ``(..., pieces, 3)`` and optical depth ``(..., pieces)`` of each piece between
    consecutive nodes (last axis of ``sigma``), extinction and colour linear along a piece of this length.

    Gauss-Legendre in each part of a piece: 5 points where a part holds optical depth <= 0.1
    (truncation ~0.1^8 / 8! relative), else 8 points with parts of optical depth <= 1 (~1 / 16!)."""
    s0, s1 = sigma[..., :-1], sigma[..., 1:]
    c0, c1 = colour[..., :-1, :], colour[..., 1:, :]
    deepest = 0.5 * length * float(np.max(s0 + s1, initial=0.0))
    parts = 1 if deepest <= 1.0 else int(np.ceil(deepest))
    x, w = GAUSS[5 if deepest <= 0.1 else 8]
    tau = np.zeros(s0.shape)
    emit = np.zeros(c0.shape)
    for p in range(parts):  # front to back through the piece
        u0 = p / parts
        u = u0 + x / parts                                              # positions in [0, 1]
        sig = s0[..., None] + (s1 - s0)[..., None] * u                  # (..., pieces, q)
        inside = length * ((u - u0) * s0[..., None] + (s1 - s0)[..., None] * (u * u - u0 * u0) / 2.0)
        weights = (length / parts) * w * sig * np.exp(-inside)
        # colour is linear too: the emission is c0 A + (c1 - c0) B with A, B the moments of the weights
        a, b = weights.sum(axis=-1), weights @ u
        emit += np.exp(-tau)[..., None] * (c0 * a[..., None] + (c1 - c0) * b[..., None])
        tau += length / parts * (s0 + (s1 - s0) * (u0 + 0.5 / parts))
    return emit, tau


class _ThinPieces:
    """The same pieces as :func:`_pieces` for optically thin lengths, as a power series in the length.

    With ``u`` the position along a piece of length ``L`` in [0, 1], ``Sigma(u) = s0 u + (s1 - s0) u^2 / 2``
    and ``exp(-L Sigma) = sum_k (-L Sigma)^k / k!``, the emission is
    ``sum_k (-1)^k L^(k+1) / k! (c0 A_k + (c1 - c0) B_k)`` with the moments
    ``A_k = int sigma Sigma^k du`` and ``B_k = int sigma u Sigma^k du``: polynomials, integrated
    exactly once by Gauss-Legendre; each length then costs one Horner evaluation.  Used where
    ``L max(sigma) <= THIN`` (truncation below ``THIN^TERMS / TERMS!`` ~ 5e-13 relative)."""

    THIN, TERMS = 0.5, 12

    def __init__(self, sigma: np.ndarray, colour: np.ndarray):
        self.s0, self.s1 = sigma[..., :-1], sigma[..., 1:]
        self.c0, self.dc = colour[..., :-1, :], colour[..., 1:, :] - colour[..., :-1, :]
        self.sigma_max = float(np.max(sigma, initial=0.0))
        u, w = _gauss(self.TERMS + 2)                          # exact to degree 2 TERMS + 3
        sig = self.s0[..., None] + (self.s1 - self.s0)[..., None] * u
        big_sigma = self.s0[..., None] * u + (self.s1 - self.s0)[..., None] * (u * u / 2.0)
        power = sig * w
        self.a, self.b = [], []
        for _ in range(self.TERMS):
            self.a.append(power.sum(axis=-1))
            self.b.append(power @ u)
            power = power * big_sigma

    def applies(self, length: float) -> bool:
        return length * self.sigma_max <= self.THIN

    def __call__(self, length: float) -> tuple[np.ndarray, np.ndarray]:
        a = np.zeros_like(self.s0)
        b = np.zeros_like(self.s0)
        for k in range(self.TERMS - 1, -1, -1):                # Horner in L, highest order first
            coefficient = (-1.0) ** k / math.factorial(k)
            a = a * length + coefficient * self.a[k]
            b = b * length + coefficient * self.b[k]
        a, b = a * length, b * length
        emit = self.c0 * a[..., None] + self.dc * b[..., None]
        return emit, length * (self.s0 + self.s1) / 2.0


def _compose(a, b):
    """The over operator on (emission (..., 3), optical depth): ``a`` in front of ``b``."""
    return a[0] + np.exp(-a[1])[..., None] * b[0], a[1] + b[1]


def _windows(emit: np.ndarray, tau: np.ndarray, starts: np.ndarray, width: int):
    """Composites of the windows ``[start, start + width)`` of consecutive elements (last axis of ``tau``),
    assembled front to back from power-of-two spans."""
    spans = [(emit, tau)]  # level l: composite of 2^l elements starting at each index
    span = 1
    while 2 * span <= width:
        e, t = spans[-1]
        spans.append(_compose((e[..., :-span, :], t[..., :-span]), (e[..., span:, :], t[..., span:])))
        span *= 2
    acc = (np.zeros(tau.shape[:-1] + (len(starts), 3)), np.zeros(tau.shape[:-1] + (len(starts),)))
    pos = starts.copy()
    for level in range(len(spans) - 1, -1, -1):  # the binary digits of the width, front first
        if width & (1 << level):
            e, t = spans[level]
            acc = _compose(acc, (e[..., pos, :], t[..., pos]))
            pos = pos + (1 << level)
    return acc


def _exact(sigma: np.ndarray, colour: np.ndarray, ratio: int, n: int, d: float) -> np.ndarray:
    """Off-diagonal entries (i < j) of the exact table, both directions at once: ``(2, n, n, 4)`` of
    (C, tau) for segments from node i to node j ([0]) and from node n-1-i to node n-1-j ([1])."""
    sigma = np.stack([sigma, sigma[::-1]])
    colour = np.stack([colour, colour[::-1]])
    out = np.zeros((2, n, n, 4))
    coarse_starts = np.arange(n - 1) * ratio
    thin = _ThinPieces(sigma, colour)
    for delta in range(1, n):
        length = d / (delta * ratio)
        fine = thin(length) if thin.applies(length) else _pieces(sigma, colour, length)
        coarse = _windows(*fine, coarse_starts, ratio)   # node to node, at this piece length
        emit, tau = _windows(*coarse, np.arange(n - delta), delta)
        i = np.arange(n - delta)
        out[:, i, i + delta, :3] = emit
        out[:, i, i + delta, 3] = tau
    return out


def shortened(colour: np.ndarray, depth: np.ndarray, fraction) -> tuple[np.ndarray, np.ndarray]:
    """A table entry for a segment shortened to ``fraction`` of the table's length (the last one of a
    ray): optical depth scaled, colour scaled with the opacity (exact when ``sf == sb``)."""
    depth_short = depth * fraction
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(depth > 0, np.expm1(-depth_short) / np.expm1(-depth), fraction)
    return colour * ratio[..., None], depth_short


def preintegrate(transfer_function, segment_length: float, size: int = 256, method: str = "exact",
                 refinement: int = 4096, reuse: bool = True) -> PreintegrationTable:
    """The pre-integration table of ``transfer_function`` for segments of ``segment_length``.

    ``refinement``: nodes of the underlying 1D table (rounded up to a multiple of ``size - 1``
    plus one, so the table's nodes are among them).  ``reuse``: return a table kept from an earlier call
    with the same values (:data:`KEPT_BYTES`; read-only, shared); False builds it anew (a bench timing the
    build).
    """
    if method not in METHODS:
        raise SceneError(f"preintegration {method!r} is not one of {', '.join(METHODS)}")
    if size < 2:
        raise SceneError(f"preintegration_size must be at least 2, got {size}")
    if not (np.isfinite(segment_length) and segment_length > 0):
        raise SceneError(f"pre-integration needs a positive segment length, got {segment_length}")
    n = int(size)
    check_preintegration_memory(n)
    ratio = max(1, -(-(refinement - 1) // (n - 1)))
    fine = transfer_function.tabulate(ratio * (n - 1) + 1)
    d = float(segment_length)
    key = (method, n, d, tuple(map(float, fine.domain)), fine.table.tobytes())
    with _KEPT_LOCK:
        kept = _KEPT.get(key) if reuse else None
        if kept is not None:
            _KEPT.move_to_end(key)
            return kept
    made = _integrate(fine, ratio, n, d, method)
    made.table.flags.writeable = False  # shared by every caller with the same values
    with _KEPT_LOCK:
        _KEPT[key] = made
        while sum(t.table.nbytes for t in _KEPT.values()) > KEPT_BYTES and len(_KEPT) > 1:
            _KEPT.popitem(last=False)
    return made


#: The tables made last, by the values they were made from (the fine 1D table's bytes, its domain, the segment
#: length, size and method), most recent last: a scene re-made with an equal transfer function (a renderer and
#: its float64 reference, the viewer's next frame, a test's next case) reuses its table; at most this many bytes.
KEPT_BYTES = 64 << 20
_KEPT: OrderedDict = OrderedDict()
_KEPT_LOCK = threading.Lock()


def _integrate(fine, ratio: int, n: int, d: float, method: str) -> PreintegrationTable:
    """The table of the fine 1D table ``fine`` (``ratio (n - 1) + 1`` nodes) for segments of length ``d``."""
    colour, sigma = fine.table[:, :3], fine.table[:, 3]
    if method == "fast":
        return PreintegrationTable(_engel(sigma, colour, fine.domain, ratio, n, d), fine.domain, d, method, fine)
    both = _exact(sigma, colour, ratio, n, d)
    table = both[0]                                                    # front value below back
    back = both[1][::-1, ::-1]                                         # front above back, reindexed
    lower = np.tril_indices(n, -1)
    table[lower] = back[lower]
    nodes_sigma, nodes_colour = sigma[::ratio], colour[::ratio]        # sf == sb: closed form
    diag = np.arange(n)
    table[diag, diag, :3] = nodes_colour * (-np.expm1(-nodes_sigma * d))[:, None]
    table[diag, diag, 3] = nodes_sigma * d
    return PreintegrationTable(table, fine.domain, d, method, fine)


def _engel(sigma, colour, domain, ratio, n, d) -> np.ndarray:
    """The fast table: integral functions of extinction and emission, then the colour normalized.

    Without self-attenuation the emission of a segment is ``E = int sigma c dt``, which grows like
    the optical depth ``tau`` without bound (7 on a thick spike).  The exact colour is
    ``C = int sigma c T dt`` with the transmittance ``T`` in [0, 1] and ``int sigma T dt = 1 - exp(-tau)``,
    so ``C`` is ``alpha = 1 - exp(-tau)`` times a weighted mean of the colours on the segment:
    ``alpha min(c) <= C <= alpha max(c)`` per channel.  The table holds ``E alpha / tau``: the
    extinction-weighted mean colour ``E / tau`` times the exact opacity.  It stays within those
    bounds (so at most 1), is exact wherever the colour is constant along the segment (a thick
    segment of one value: ``c (1 - exp(-sigma d))``, whatever the extinction does) and to first
    order in ``tau`` (``alpha / tau = 1 - tau / 2 + ...``); what it ignores is only that attenuation
    weights the front's colour more than the back's.  Still ``O(N^2)``."""
    h = (domain[1] - domain[0]) / (len(sigma) - 1)        # value step between fine nodes
    s0, s1, c0, c1 = sigma[:-1], sigma[1:], colour[:-1], colour[1:]
    # exact integrals of the linear sigma and the quadratic sigma * c over each piece
    integral_sigma = np.concatenate([[0.0], np.cumsum(h * (s0 + s1) / 2.0)])
    piece_k = h / 6.0 * (2 * s0[:, None] * c0 + s0[:, None] * c1 + s1[:, None] * c0 + 2 * s1[:, None] * c1)
    integral_k = np.concatenate([np.zeros((1, 3)), np.cumsum(piece_k, axis=0)])
    S, K = integral_sigma[::ratio], integral_k[::ratio]
    values = np.arange(n) * (ratio * h)
    dv = values[None, :] - values[:, None]                 # sb - sf, front index first
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = d * (S[None, :] - S[:, None]) / dv
        emit = d * (K[None, :, :] - K[:, None, :]) / dv[..., None]
    diag = np.arange(n)
    tau[diag, diag] = d * sigma[::ratio]
    emit[diag, diag] = d * (sigma[::ratio, None] * colour[::ratio])
    tau = np.maximum(tau, 0.0)   # cancellation in S(sb) - S(sf) can leave -1e-17
    return np.concatenate([emit * _opacity_per_depth(tau)[..., None], tau[..., None]], axis=-1)


def _opacity_per_depth(tau: np.ndarray) -> np.ndarray:
    """``(1 - exp(-tau)) / tau``, 1 at ``tau = 0`` (no 0/0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(tau > 1e-12, -np.expm1(-tau) / tau, 1.0 - tau / 2.0)
