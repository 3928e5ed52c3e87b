"""The tetrahedral mesh (data kind ``"mesh"``): :class:`TetMesh`, an unstructured grid as a field.

* ``points (N, 3)`` world positions, ``tets (M, 4)`` vertex indices (other cell types are split into
  tetrahedra when read: :mod:`.mesh_cells`);
* scalars per point (``association = "point"``: linear in each tetrahedron, the barycentric
  interpolation of its four corners) or per cell (``"cell"``: constant in each tetrahedron);
* tetrahedra are oriented positively (two vertices swapped where the signed volume is negative);
* **degenerate** tetrahedra, whose volume is at most :data:`DEGENERATE_VOLUME` of the cube of
  their longest edge (the blunt fin has 77 of zero volume), bound no volume: they are counted
  (``degenerate``, :meth:`describe`) and left out of everything that follows (rays, sorting,
  location), so they can break nothing;
* "one voxel" (``sample_spacing``, the unit of sample distances in voxels) is the median edge
  length of the tetrahedra (over their six edges each).

The reconstruction is the mesh's own (linear per cell); a scene asking for another filter is
refused.  Rays are cut into exact per-cell pieces (:mod:`.mesh_rays`), so the references integrate
each piece knowing its cell and never locate points; :meth:`MeshReconstruction.sample` at
arbitrary points locates them (:mod:`.mesh_locate`) and is NaN outside the mesh.
"""

from __future__ import annotations

import functools

import numpy as np

from ..checks import WORLD_RANGE
from ..errors import SceneError, VolumeError
from .mesh_locate import CellLocator
from .mesh_rays import FacePlanes, ray_pieces

DEGENERATE_VOLUME = 1e-9  # of the longest edge cubed (a regular tetrahedron has 0.118)
ASSOCIATIONS = ("point", "cell")


class TetMesh:
    """A tetrahedral mesh with scalars; a :class:`~dvr_gl.fields.Field` of kind ``"mesh"``."""

    kind = "mesh"

    def __init__(self, points, tets, values, association: str = "point", name: str = "mesh",
                 array: str = "scalars", source: str = ""):
        points = np.asarray(points, dtype=np.float64)
        tets = np.asarray(tets, dtype=np.int64)
        values = np.asarray(values, dtype=np.float64).reshape(-1)
        self.name, self.array, self.source = name, array, source
        if association not in ASSOCIATIONS:
            raise VolumeError(f"{name}: scalars must be per point or per cell, got {association!r}")
        if points.ndim != 2 or points.shape[1] != 3 or not len(points):
            raise VolumeError(f"{name}: expected points (N, 3), got shape {points.shape}")
        if tets.ndim != 2 or tets.shape[1] != 4 or not len(tets):
            raise VolumeError(f"{name}: no tetrahedra (after splitting its cells); a mesh needs volume cells")
        if not np.isfinite(points).all():
            raise VolumeError(f"{name}: {int((~np.isfinite(points)).any(axis=1).sum())} points have NaN or Inf "
                              "coordinates; fix the file")
        if tets.min() < 0 or tets.max() >= len(points):
            raise VolumeError(f"{name}: cells refer to points outside 0..{len(points) - 1}; the file is corrupt")
        check_reach(name, points[np.unique(tets)])
        expected = len(points) if association == "point" else len(tets)
        if len(values) != expected:
            raise VolumeError(f"{name}: array {array!r} has {len(values)} values for {expected} "
                              f"{'points' if association == 'point' else 'cells'}")
        if not np.isfinite(values).all():
            raise VolumeError(f"{name}: array {array!r} has {int((~np.isfinite(values)).sum())} NaN or Inf "
                              f"values; choose another array (volume.array)")
        self.association = association
        self.points = points
        corners = points[tets]
        edges = corners[:, 1:] - corners[:, :1]
        volume6 = np.einsum("ni,ni->n", edges[:, 0], np.cross(edges[:, 1], edges[:, 2]))
        flip = volume6 < 0
        tets = tets.copy()
        tets[flip, 1], tets[flip, 2] = tets[flip, 2], tets[flip, 1].copy()
        longest = np.sqrt(max_edge_squared(corners))
        self.degenerate = np.abs(volume6) / 6.0 <= DEGENERATE_VOLUME * longest ** 3
        keep = ~self.degenerate
        self.tets = tets[keep]  # the cells that bound volume (all later indices refer to these)
        if not len(self.tets):
            raise VolumeError(f"{name}: all {len(tets)} tetrahedra have zero volume")
        self.values = values if association == "point" else values[keep]
        lo, hi = float(self.values.min()), float(self.values.max())
        self.value_range = (lo, hi)
        self.sample_spacing = float(np.median(edge_lengths(points, self.tets)))
        used = np.zeros(len(points), bool)
        used[self.tets] = True
        self._bounds = (points[used].min(axis=0), points[used].max(axis=0))

    @property
    def bounds(self):
        """The box of the points the cells use (world units)."""
        return self._bounds

    @property
    def n_degenerate(self) -> int:
        return int(self.degenerate.sum())

    def describe(self) -> str:
        lo, hi = self.value_range
        extra = f" ({self.n_degenerate} of zero volume, left out)" if self.n_degenerate else ""
        return (f"{self.name}: mesh, {len(self.points)} points, {len(self.tets) + self.n_degenerate} tetrahedra"
                f"{extra}, {self.association} scalars {self.array!r} {lo:g}..{hi:g}")

    def __repr__(self) -> str:
        return f"TetMesh({self.describe()})"

    def resampled(self, samples: int):
        """This mesh on a grid of ``samples`` points along its longest axis, for the grid renderers
        (:func:`~dvr_gl.fields.mesh_resample.resample`; scene key ``volume.resample``)."""
        from .mesh_resample import resample

        return resample(self, samples)

    def reconstruct(self, filter: str = "linear") -> "MeshReconstruction":
        if filter != "linear":
            raise SceneError(f"{self.name}: a mesh is interpolated linearly in each tetrahedron; set "
                             f"renderer.filter = \"linear\" (got {filter!r})")
        return self._reconstruction

    @functools.cached_property
    def _reconstruction(self) -> "MeshReconstruction":
        return MeshReconstruction(self)


def check_reach(name: str, used: np.ndarray) -> None:
    """The points the cells use lie within the world range (:data:`dvr_gl.checks.WORLD_RANGE`) and
    span more than its least length: beyond it the volumes and edge lengths that judge degenerate
    cells overflow or underflow (a point at 1e300 made every cell touching it 'of zero volume', left
    out without a word; a mesh scaled by 1e-300 was 'all zero volume')."""
    small, large = WORLD_RANGE
    reach = float(np.abs(used).max())
    if reach > large:
        raise VolumeError(f"{name}: points lie {reach:.3g} world units from the origin, beyond {large:g}; rescale "
                          "or move the mesh")
    span = float(np.ptp(used, axis=0).max())
    if 0 < span < small:
        raise VolumeError(f"{name}: the mesh spans {span:.3g} world units, below {small:g}; rescale it")


def max_edge_squared(corners: np.ndarray) -> np.ndarray:
    """The longest edge squared of each tetrahedron ``(M, 4, 3)``."""
    pairs = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
    return np.max([((corners[:, i] - corners[:, j]) ** 2).sum(axis=1) for i, j in pairs], axis=0)


def edge_lengths(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """The lengths of the six edges of every tetrahedron (a shared edge once per cell: a median
    over cells, not over distinct edges)."""
    return np.concatenate([np.linalg.norm(points[tets[:, i]] - points[tets[:, j]], axis=1)
                           for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))])


class MeshReconstruction:
    """The mesh's scalar as a continuous field: ``value(p) = v0 + g . (p - p0)`` in each cell
    (``p0``, ``v0``: its first corner and the value there; ``g`` its constant gradient, zero for cell
    scalars)."""

    def __init__(self, mesh: TetMesh):
        self.mesh = mesh
        tets, points = mesh.tets, mesh.points
        self.degree = 1 if mesh.association == "point" else 0
        self.anchor = points[tets[:, 0]]
        if mesh.association == "point":
            v = mesh.values[tets]
            edges = (points[tets[:, 1:]] - self.anchor[:, None, :])  # rows p_k - p0
            self.gradients = np.linalg.solve(edges, (v[:, 1:] - v[:, :1])[..., None])[..., 0]
            self.base = v[:, 0]
        else:
            self.gradients = np.zeros((len(tets), 3))
            self.base = mesh.values

    @functools.cached_property
    def planes(self) -> FacePlanes:
        return FacePlanes(self.mesh.points, self.mesh.tets)

    @functools.cached_property
    def corners(self) -> np.ndarray:
        """Each cell's four vertices ``(M, 4, 3)``."""
        return self.mesh.points[self.mesh.tets]

    @functools.cached_property
    def locator(self) -> CellLocator:
        return CellLocator(self.mesh.points, self.mesh.tets)

    # --- along rays: exact pieces, each in a known cell ----------------------------------------

    def pieces(self, origins, directions, t0, t1):
        """``(ray, a, b, cell)``: the part of each ray inside each cell it crosses, sorted along rays."""
        return ray_pieces(self.corners, self.planes, origins, directions, t0, t1)

    def sample_cells(self, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Values at points known to lie in ``cells``."""
        return self.base[cells] + np.einsum("ni,ni->n", self.gradients[cells], points - self.anchor[cells])

    def gradient_cells(self, cells: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        return self.gradients[cells]

    def knots(self, origins, directions, t0, t1):
        """Where rays cross cell faces (the ends of their pieces)."""
        ray, a, b, _ = self.pieces(origins, directions, t0, t1)
        return np.concatenate([ray, ray]), np.concatenate([a, b])

    # --- anywhere: located first ----------------------------------------------------------------

    def sample(self, points: np.ndarray) -> np.ndarray:
        """Values at world points; NaN outside the mesh."""
        cells = self.locator.locate(points)
        out = np.full(len(points), np.nan)
        inside = cells >= 0
        out[inside] = self.sample_cells(cells[inside], points[inside])
        return out

    def gradient(self, points: np.ndarray) -> np.ndarray:
        cells = self.locator.locate(points)
        out = np.zeros((len(points), 3))
        out[cells >= 0] = self.gradients[cells[cells >= 0]]
        return out
