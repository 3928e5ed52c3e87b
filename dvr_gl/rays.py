"""Ray-box intersection, segment placement and per-pixel jitter.

Segments follow the conventions: segments of length ``d`` tile ``[t0, t1]``
from ``t0``; the last is shortened to end at ``t1``.  Segment ``k`` starts at
``t0 + k d``; it is sampled at its midpoint, or with jitter at
``start + j * length`` for the pixel's offset ``j`` in [0, 1).  The GPU
shaders place samples by the same formulas.
"""

from __future__ import annotations

import numpy as np


def intersect_box(origins: np.ndarray, directions: np.ndarray, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit ray parameters of the closed box ``[lo, hi]`` (slab method).

    A ray parallel to a slab is inside it for all t when its origin lies in the
    closed slab (so rays grazing a face count as inside), else it misses.
    Misses have ``t_exit < t_enter``.
    """
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    parallel = d == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        ta = (lo - o) * inv
        tb = (hi - o) * inv
    tmin, tmax = np.minimum(ta, tb), np.maximum(ta, tb)
    if parallel.any():  # (rarely: rays along a slab) inside it for all t, or never
        inside = (o >= lo) & (o <= hi)
        tmin = np.where(parallel, np.where(inside, -np.inf, np.inf), tmin)
        tmax = np.where(parallel, np.where(inside, np.inf, -np.inf), tmax)
    # column by column: numpy's reductions along a short last axis are several times slower
    return (np.maximum(np.maximum(tmin[:, 0], tmin[:, 1]), tmin[:, 2]),
            np.minimum(np.minimum(tmax[:, 0], tmax[:, 1]), tmax[:, 2]))


def segment_counts(t0: np.ndarray, t1: np.ndarray, d: float) -> np.ndarray:
    """Number of segments tiling ``[t0, t1]``: ``ceil((t1 - t0) / d)``, 0 for empty rays."""
    length = np.asarray(t1) - np.asarray(t0)
    n = np.ceil(length / d)
    return np.where(length > 0, np.maximum(n, 1), 0).astype(np.int64)


def segment_bounds(t0, t1, k, d: float) -> tuple[np.ndarray, np.ndarray]:
    """Start and length of segment ``k`` (the last one shortened to end at t1)."""
    start = t0 + k * d
    return start, np.minimum(d, t1 - start)


def pcg_hash(v: np.ndarray) -> np.ndarray:
    """PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano 2020), the same in GLSL with uint."""
    v = np.atleast_1d(np.asarray(v, dtype=np.uint32))
    with np.errstate(over="ignore"):  # uint32 arithmetic wraps modulo 2^32, as in GLSL
        state = v * np.uint32(747796405) + np.uint32(2891336453)
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(277803737)
    return (word >> np.uint32(22)) ^ word


def jitter_offsets(width: int, height: int, seed: int = 0) -> np.ndarray:
    """Per-pixel offsets in [0, 1) (row-major, row 0 at the top), exact in float32:
    ``hash(x + W * y + hash(seed)) >> 8`` over 2^24."""
    x = np.arange(width, dtype=np.uint32)
    y = np.arange(height, dtype=np.uint32)
    idx = (x[None, :] + np.uint32(width) * y[:, None]).reshape(-1)
    h = pcg_hash(idx + pcg_hash(np.uint32(seed)))
    return (h >> np.uint32(8)).astype(np.float64) / 16777216.0


class RayBatch:
    """The rays of an image, clipped to the volume box and the near plane.

    Attributes (one row per pixel, row-major, row 0 at the top):
        origins, directions: ``(R, 3)``, directions unit length.
        t0, t1: the part of each ray inside the box; empty when ``t1 <= t0``.
        offset: where in each segment the sample sits (0.5, or the pixel's jitter).
    """

    def __init__(self, origins, directions, t0, t1, offset):
        self.origins = origins
        self.directions = directions
        self.t0 = t0
        self.t1 = t1
        self.offset = offset

    def __len__(self):
        return len(self.t0)

    @classmethod
    def for_camera(cls, camera, width: int, height: int, box, jitter_seed: int | None = None,
                   clip=None, pixels=None) -> "RayBatch":
        """The pixels' rays inside ``box`` past the near plane, and inside ``clip`` (a
        :class:`dvr_gl.clipping.ClipRegion`) where given; only those of ``pixels`` (flat indices, row-major
        from the top) where given (picking traces one)."""
        o, d = camera.pixel_rays(width, height, pixels)
        t_enter, t_exit = intersect_box(o, d, *box)
        if clip is not None:
            t_enter, t_exit = clip.interval(o, d, t_enter, t_exit)
        t0 = np.maximum(t_enter, camera.near_distance(d))
        hit = t_exit > t0
        t0 = np.where(hit, t0, 0.0)
        t1 = np.where(hit, t_exit, 0.0)
        offset = np.full(len(t0), 0.5) if jitter_seed is None else jitter_offsets(width, height, jitter_seed)
        if pixels is not None and jitter_seed is not None:
            offset = offset[np.asarray(pixels)]
        return cls(o, d, t0, t1, offset)

    def points(self, rows: np.ndarray, t: np.ndarray) -> np.ndarray:
        """World points at parameters ``t`` (``(len(rows), m)``) along rays ``rows``, as ``(-1, 3)``."""
        return (self.origins[rows, None, :] + t[..., None] * self.directions[rows, None, :]).reshape(-1, 3)

