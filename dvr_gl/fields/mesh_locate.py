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
#: (point, candidate cell) pairs tested at once: each holds about :data:`BYTES_PER_CANDIDATE` of
#: temporaries (the gathered 3x3 map, anchor, offsets, coordinates, indices), so a chunk is ~120 MiB
#: however many cells a bin lists (a bin of the blunt fin lists hundreds: 1.7 GB for 65536 points).
CANDIDATES_PER_CHUNK = 1 << 19
BYTES_PER_CANDIDATE = 240


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

    def candidates_on_grid(self, axes) -> float:
        """The (point, cell) pairs :meth:`locate` tests for the points of the grid ``axes[0] x axes[1] x
        axes[2]`` (world coordinates along x, y, z): each point tests the cells its bin lists.  The grid
        is separable, so this is the bins' counts weighted by how many grid points fall in each."""
        counts = np.diff(self.start).reshape(self.shape[2], self.shape[1], self.shape[0]).astype(np.float64)
        per_axis = []
        for i in range(3):
            a = np.asarray(axes[i], dtype=np.float64)
            a = a[(a >= self.lo[i]) & (a <= self.hi[i])]
            bins = np.clip(np.floor((a - self.lo[i]) / self.size[i]).astype(np.int64), 0, self.shape[i] - 1)
            per_axis.append(np.bincount(bins, minlength=self.shape[i]).astype(np.float64))
        return float(np.einsum("zyx,z,y,x->", counts, per_axis[2], per_axis[1], per_axis[0]))

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
            found = np.full(len(q), -1, dtype=np.int64)
            ends = np.cumsum(n)
            a = 0
            while a < len(qi):  # points in groups of at most CANDIDATES_PER_CHUNK candidates
                before = ends[a - 1] if a else 0
                b = max(int(np.searchsorted(ends, before + CANDIDATES_PER_CHUNK, side="right")), a + 1)
                which = np.repeat(qi[a:b], n[a:b])
                cand = self.cells[ranges(self.start[key[a:b]], n[a:b])]
                lam = np.einsum("nij,nj->ni", self.inverse[cand], q[which] - self.anchor[cand])
                inside = (lam.min(axis=1) >= -INSIDE_TOLERANCE) & (lam.sum(axis=1) <= 1.0 + INSIDE_TOLERANCE)
                which, cand = which[inside][::-1], cand[inside][::-1]  # reversed: the first candidate wins
                found[which] = cand
                a = b
            out[s:s + QUERIES_PER_CHUNK] = found
        return out
