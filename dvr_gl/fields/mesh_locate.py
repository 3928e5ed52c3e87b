"""Which tetrahedron holds a point: a uniform grid of bins over the mesh's box, each listing the
cells whose bounding boxes overlap it, then barycentric coordinates against those candidates.

Used where a point's cell is not known from a ray's pieces: resampling a mesh onto a grid,
and :meth:`~dvr_gl.fields.mesh.MeshReconstruction.sample` at arbitrary points.
"""

from __future__ import annotations

import numpy as np

from .ragged import ranges, ranks

INSIDE_TOLERANCE = 1e-10  # barycentric slack: points on a shared face belong to both cells
QUERIES_PER_CHUNK = 1 << 16


class CellLocator:
    def __init__(self, points: np.ndarray, tets: np.ndarray, bins_per_cell: float = 0.5):
        """``points (N, 3)``, ``tets (M, 4)`` (non-degenerate: their barycentric maps are inverted)."""
        self.points, self.tets = points, tets
        corners = points[tets]  # (M, 4, 3)
        self.lo, self.hi = points.min(axis=0), points.max(axis=0)
        extent = np.maximum(self.hi - self.lo, 1e-300)
        n = max(1, int(round((len(tets) * bins_per_cell) ** (1.0 / 3.0))))
        self.shape = np.minimum(np.maximum(np.round(n * extent / extent.max()), 1), 256).astype(np.int64)
        self.size = extent / self.shape
        b0 = self._bin(corners.min(axis=1))
        b1 = self._bin(corners.max(axis=1))
        span = b1 - b0 + 1
        count = span.prod(axis=1)
        cell = np.repeat(np.arange(len(tets)), count)
        local = ranks(count)
        sx, sy = np.repeat(span[:, 0], count), np.repeat(span[:, 1], count)
        ix = np.repeat(b0[:, 0], count) + local % sx
        iy = np.repeat(b0[:, 1], count) + (local // sx) % sy
        iz = np.repeat(b0[:, 2], count) + local // (sx * sy)
        key = self._key(np.stack([ix, iy, iz], axis=1))
        order = np.argsort(key, kind="stable")
        self.cells = cell[order]
        self.start = np.searchsorted(key[order], np.arange(self.shape.prod() + 1))
        # barycentric maps: lambda_{1..3} = inv @ (p - p0), lambda_0 = 1 - sum
        edges = (corners[:, 1:] - corners[:, :1]).transpose(0, 2, 1)  # columns p1-p0, p2-p0, p3-p0
        self.inverse = np.linalg.inv(edges)
        self.anchor = corners[:, 0]

    def _bin(self, p):
        return np.clip(np.floor((p - self.lo) / self.size).astype(np.int64), 0, self.shape - 1)

    def _key(self, b):
        return (b[:, 2] * self.shape[1] + b[:, 1]) * self.shape[0] + b[:, 0]

    def locate(self, p: np.ndarray) -> np.ndarray:
        """The cell holding each point ``(N, 3)`` (the first found where several share it), -1
        where none does."""
        out = np.full(len(p), -1, dtype=np.int64)
        for s in range(0, len(p), QUERIES_PER_CHUNK):
            q = p[s:s + QUERIES_PER_CHUNK]
            inbox = np.all((q >= self.lo) & (q <= self.hi), axis=1)
            qi = np.nonzero(inbox)[0]
            key = self._key(self._bin(q[qi]))
            n = self.start[key + 1] - self.start[key]
            which = np.repeat(qi, n)
            cand = self.cells[ranges(self.start[key], n)]
            lam = np.einsum("nij,nj->ni", self.inverse[cand], q[which] - self.anchor[cand])
            inside = (lam.min(axis=1) >= -INSIDE_TOLERANCE) & (lam.sum(axis=1) <= 1.0 + INSIDE_TOLERANCE)
            which, cand = which[inside][::-1], cand[inside][::-1]  # reversed: the first candidate wins
            found = np.full(len(q), -1, dtype=np.int64)
            found[which] = cand
            out[s:s + QUERIES_PER_CHUNK] = found
        return out
