"""The SPH sum at many points at once, scattered from the particles through uniform grids of the points
(compiled with numba, the optional extra ``numba``).

``sum_j W(|x - x_j|, h_j) carried_j`` at every point ``x`` of a large set (the particles themselves: the
scene's value range, a reader's density) is each particle's kernel scattered onto the points inside its
support.  The particles are taken in levels by size, as :class:`.particles.CellIndex` (radii one to two
times the level's smallest); a level's points (those its supports can reach) are counting-sorted into cubic
cells of a half to one of its radii, and each particle visits the cells of each row that its
support's chord through the row meets.  No neighbour index of the particles is made (the levels of
:class:`.particles.CellIndex` took 20 s for a million particles, and the gather through them 40 s); every
thread scatters a share of the particles into its own sums, added at the end.

Where a level's grid would be too large (points far apart), :func:`plan` says no and the caller gathers
through its sparse index as before.  The pairs summed are the same; only the order of the additions
differs (float64 rounding, about 1e-15 relative).
"""

from __future__ import annotations

import numpy as np

from ..sandbox import check_bytes

#: Most grid cells per point a level's grid holds (its cells' starts are int64), plus :data:`FEW_CELLS`:
#: beyond, the points are too spread out for a uniform grid and the caller's sparse index serves.
CELLS_PER_POINT = 8
FEW_CELLS = 4096
#: Cells across the smallest support radius of a level (whose radii are one to two of its smallest).  A
#: particle visits the cells of each row that its support's chord through the row meets, and a row's loop
#: vectorizes, so long rows pay: the Plummer sphere's 200,000 particles test 210 points a particle (for 59
#: neighbours) in 13 rows with cells of a half to one radius, 0.35 s on one core, against 120 points in 38
#: rows and 0.73 s with cells half as wide (0.44 s twice as wide).
CELLS_PER_RADIUS = 1


class Level:
    """The particles ``members`` whose support's radius is one to two times ``radius``, and a grid of ``dims``
    cubes of ``size`` from ``lo`` over the points their supports can reach."""

    def __init__(self, lo: np.ndarray, size: float, dims: np.ndarray, members: np.ndarray):
        self.lo, self.size, self.dims, self.members = lo, size, dims, members


def plan(points: np.ndarray, centres: np.ndarray, radius: np.ndarray) -> list[Level] | None:
    """The levels for scattering kernels of support ``radius`` (world units, positive) about ``centres``
    onto ``points`` (finite), or ``None`` where a uniform grid does not suit a level (points far apart).
    A particle is in the level whose smallest radius is one to two times its own, as
    :class:`.particles.CellIndex`, in cells of a half to one of its radius (:data:`CELLS_PER_RADIUS`),
    and each level's grid covers only the points its particles' supports can reach."""
    if not len(points) or not len(centres):
        return []
    size0 = float(radius.min())
    level = np.floor(np.log2(np.maximum(radius / size0, 1.0))).astype(np.int64)
    low, high = points.min(axis=0), points.max(axis=0)
    levels = []
    for k in np.unique(level):
        members = np.flatnonzero(level == k)
        size = size0 * 2.0 ** int(k) / CELLS_PER_RADIUS
        reach = radius[members, None]
        lo = np.maximum((centres[members] - reach).min(axis=0), low)
        hi = np.minimum((centres[members] + reach).max(axis=0), high)
        if not (hi >= lo).all():
            continue  # no point within reach
        extent = np.floor((hi - lo) / size) + 1.0
        if not float(np.prod(extent)) <= CELLS_PER_POINT * len(points) + FEW_CELLS:
            return None
        levels.append(Level(lo, size, extent.astype(np.int64), members))
    return levels


def compiled():
    """:mod:`.particle_scatter_compiled` (numba) where numba is installed, else ``None``."""
    try:
        from . import particle_scatter_compiled
    except ImportError:
        return None
    return particle_scatter_compiled


def scatter_sum(levels: list[Level], points: np.ndarray, centres: np.ndarray, h: np.ndarray,
                carried: np.ndarray) -> np.ndarray | None:
    """The sum ``sum_j W(|x - x_j|, h_j) carried[j]`` at every point ``x`` of ``points`` ``(M, 3)``, ``(M,
    C)`` float64, through :func:`plan`'s ``levels``; ``carried`` ``(N, C)``; None without numba."""
    module = compiled()
    if module is None:
        return None
    threads = module.numba.get_num_threads()
    # a level at most: the threads' sums, the points sorted (coordinates, order, cells) and their cells' starts
    check_bytes(len(points) * (8.0 * (threads + 1) * carried.shape[1] + 48.0 + 8.0 * CELLS_PER_POINT)
                + 48.0 * len(centres), "the SPH sum at the points", "use fewer particles")
    p = [np.ascontiguousarray(points[:, a], dtype=np.float64) for a in range(3)]
    out = np.zeros((len(points), carried.shape[1]))
    for g in levels:
        m = g.members
        module.level_sums(*p, *(np.ascontiguousarray(centres[m, a]) for a in range(3)), h[m],
                          np.ascontiguousarray(carried[m]), g.lo, g.size, g.dims, threads, out)
    return out
