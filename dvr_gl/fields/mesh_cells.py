"""Cells of unstructured grids split into linear tetrahedra (VTK's cell types and vertex orders).

* ``tetra``: kept.
* ``hexahedron``, ``voxel``, ``wedge``: a point is added at the cell's centroid (its value the mean
  of the corners', which is the trilinear value at a parallelepiped's centre) and every face is
  coned to it: triangles as they are, quadrilaterals split in two along the diagonal through their
  vertex with the smallest global index.  The split of a shared quadrilateral depends only on its
  four global indices, so the two cells sharing it split it the same way and the tetrahedra meet
  face to face (no cracks: ``tests/fields/test_mesh_field.py``).  12 tetrahedra per hexahedron, 8 per
  wedge.  (Splits without the added point, Dompierre et al. 1999, use 5 or 6 but need special
  cases where no consistent split exists; the cone needs none.)
* ``pyramid``: its base split by the same rule, each half coned to the apex (2 tetrahedra).
* ``tetra10`` (VTK_QUADRATIC_TETRA): eight linear tetrahedra through the mid-edge nodes: one at
  each corner and four around the inner octahedron's diagonal from mid(0,2) to mid(1,3).

Cell scalars are inherited by a cell's tetrahedra; point scalars stay at the points (the added
centroids get the mean of their cell's corners).
"""

from __future__ import annotations

import numpy as np

# the volume cells that are split (meshio's names for VTK's types) and their vertex counts
CORNERS = {"tetra": 4, "voxel": 8, "hexahedron": 8, "wedge": 6, "pyramid": 5, "tetra10": 10}

# faces, outward or not (orientation is fixed afterwards from signed volumes)
HEX_QUADS = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
WEDGE_QUADS = ((0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5))
WEDGE_TRIANGLES = ((0, 2, 1), (3, 4, 5))
VOXEL_TO_HEX = (0, 1, 3, 2, 4, 5, 7, 6)
TETRA10_CHILDREN = ((0, 4, 6, 7), (4, 1, 5, 8), (6, 5, 2, 9), (7, 8, 9, 3),
                    (6, 8, 4, 5), (6, 8, 5, 9), (6, 8, 9, 7), (6, 8, 7, 4))


def split_quads(quads: np.ndarray) -> np.ndarray:
    """Two triangles ``(2N, 3)`` per quadrilateral ``(N, 4)`` (global indices, in cyclic order),
    split along the diagonal through the vertex with the smallest index: a rule of the four
    indices alone, so every cell sharing a quadrilateral splits it the same way."""
    quads = np.asarray(quads)
    first = np.argmin(quads, axis=1)
    k = (first[:, None] + np.arange(4)[None, :]) % 4
    q = np.take_along_axis(quads, k, axis=1)
    return np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1).reshape(-1, 3)


def _coned(cells: np.ndarray, quads, triangles, centre: np.ndarray) -> np.ndarray:
    """Tetrahedra ``(N * per_cell, 4)``: every face of every cell coned to its ``centre`` index;
    rows grouped by cell (cell i's tetrahedra are contiguous)."""
    n = len(cells)
    parts = []
    for quad in quads:
        tri = split_quads(cells[:, quad]).reshape(n, 2, 3)
        parts.append(tri)
    for tri in triangles:
        parts.append(cells[:, tri][:, None, :])
    faces = np.concatenate(parts, axis=1)  # (n, f, 3)
    apex = np.broadcast_to(centre[:, None, None], faces.shape[:2] + (1,))
    return np.concatenate([faces, apex], axis=2).reshape(-1, 4)


def tetrahedralize(points: np.ndarray, blocks, point_values=None):
    """Split cells into linear tetrahedra.

    Args:
        points: ``(N, 3)`` float64.
        blocks: ``[(type_name, cells (M, k) int)]`` in :data:`CORNERS`' names.
        point_values: ``(N,)`` or None; extended to the added centroids.

    Returns:
        ``(points, tets (T, 4) int64, parent (T,) int64, point_values)``: ``parent[i]`` is the
        index of tetrahedron i's cell in the concatenation of ``blocks`` (for cell scalars).
    """
    points = np.asarray(points, dtype=np.float64)
    values = None if point_values is None else np.asarray(point_values, dtype=np.float64)
    new_points, new_values, tets, parents = [points], [values], [], []
    n_points, first_cell = len(points), 0
    for name, cells in blocks:
        cells = np.asarray(cells, dtype=np.int64)
        ids = np.arange(first_cell, first_cell + len(cells))
        first_cell += len(cells)
        if not len(cells):
            continue
        if name == "voxel":
            cells, name = cells[:, VOXEL_TO_HEX], "hexahedron"
        if name == "tetra":
            tets.append(cells[:, :4])
            parents.append(ids)
        elif name == "tetra10":
            tets.append(cells[:, TETRA10_CHILDREN].reshape(-1, 4))
            parents.append(np.repeat(ids, len(TETRA10_CHILDREN)))
        elif name == "pyramid":
            tri = split_quads(cells[:, :4]).reshape(-1, 2, 3)
            apex = np.broadcast_to(cells[:, 4, None, None], (len(cells), 2, 1))
            tets.append(np.concatenate([tri, apex], axis=2).reshape(-1, 4))
            parents.append(np.repeat(ids, 2))
        elif name in ("hexahedron", "wedge"):
            quads, triangles = (HEX_QUADS, ()) if name == "hexahedron" else (WEDGE_QUADS, WEDGE_TRIANGLES)
            centre = np.arange(n_points, n_points + len(cells))
            n_points += len(cells)
            new_points.append(points[cells].mean(axis=1))
            if values is not None:
                new_values.append(values[cells].mean(axis=1))
            per_cell = 2 * len(quads) + len(triangles)
            tets.append(_coned(cells, quads, triangles, centre))
            parents.append(np.repeat(ids, per_cell))
        else:
            raise ValueError(f"cell type {name!r} cannot be split into tetrahedra")
    if not tets:
        return points, np.zeros((0, 4), np.int64), np.zeros(0, np.int64), values
    out_values = None if values is None else np.concatenate(new_values)
    return np.concatenate(new_points), np.concatenate(tets), np.concatenate(parents), out_values


def hexahedra_of_grid(ni: int, nj: int, nk: int) -> np.ndarray:
    """The hexahedra ``(M, 8)`` of a curvilinear grid whose points are numbered i fastest, in VTK's
    vertex order (corners (i,j,k), (i+1,j,k), (i+1,j+1,k), (i,j+1,k), then the same at k+1)."""
    i, j, k = np.meshgrid(np.arange(ni - 1), np.arange(nj - 1), np.arange(nk - 1), indexing="ij")
    i, j, k = (a.transpose(2, 1, 0).reshape(-1) for a in (i, j, k))
    idx = lambda a, b, c: a + ni * (b + nj * c)  # noqa: E731
    return np.stack([idx(i, j, k), idx(i + 1, j, k), idx(i + 1, j + 1, k), idx(i, j + 1, k),
                     idx(i, j, k + 1), idx(i + 1, j, k + 1), idx(i + 1, j + 1, k + 1), idx(i, j + 1, k + 1)],
                    axis=1).astype(np.int64)
