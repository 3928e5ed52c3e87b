"""The voxels' normal codes and gradient-opacity factors compiled with numba (the optional extra
``numba``): :class:`.shading.VoxelNormals`'s numpy passes (central differences, unit normals, the
octahedral code, the factor) as one loop over the voxels, value for value the same float64 operations in
the same order, so the codes are equal (``tests/test_shearwarp.py`` checks both paths on random data).

The numpy passes cost about 240 ns a voxel (23 s on the 512x512x361 CT bunny, once per volume for a shaded
first frame; measured 2026-11-28 on the shared two-core machine); this loop keeps no float64 temporaries.

Imported only through :func:`.shading.compiled`, which falls back to the numpy code where numba is not
installed.  ``njit(cache=True)``: the first call of a fresh install compiles (a few seconds, once).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, parallel=True)
def voxel_codes(data, spacing, epsilon, grid, no_normal, reference, codes, factor, with_factor):
    """Fill ``codes`` (int16 ``(nz, ny, nx)``) with each voxel's octahedral normal code on a
    ``grid``-cell side (``no_normal`` where the gradient is at most ``epsilon``) and, when
    ``with_factor``, ``factor`` (float32, same shape) with ``min(1, |g| / reference)`` (NaN kept, as
    ``np.minimum`` keeps it); ``data`` the
    voxels ``[z, y, x]``, ``spacing`` (x, y, z) world units per voxel.  Central differences one voxel
    apart, clamped at the edges."""
    nz, ny, nx = data.shape
    sx, sy, sz = 2.0 * spacing[0], 2.0 * spacing[1], 2.0 * spacing[2]
    cells = float(grid)
    for k in numba.prange(nz):
        k0, k1 = max(k - 1, 0), min(k + 1, nz - 1)
        for j in range(ny):
            j0, j1 = max(j - 1, 0), min(j + 1, ny - 1)
            for i in range(nx):
                i0, i1 = max(i - 1, 0), min(i + 1, nx - 1)
                gx = (np.float64(data[k, j, i1]) - np.float64(data[k, j, i0])) / sx
                gy = (np.float64(data[k, j1, i]) - np.float64(data[k, j0, i])) / sy
                gz = (np.float64(data[k1, j, i]) - np.float64(data[k0, j, i])) / sz
                magnitude = np.sqrt(gx * gx + gy * gy + gz * gz)
                if with_factor:
                    q = magnitude / reference
                    factor[k, j, i] = np.float32(q if not q >= 1.0 else 1.0)
                if not magnitude > epsilon:
                    codes[k, j, i] = no_normal
                    continue
                m = max(magnitude, 1e-300)
                x, y, z = -gx / m, -gy / m, -gz / m
                norm1 = abs(x) + abs(y) + abs(z)
                if norm1 == 0.0:
                    codes[k, j, i] = no_normal
                    continue
                px, py, pz = x / norm1, y / norm1, z / norm1
                if pz < 0.0:  # the lower hemisphere folded over the diagonals
                    fx = (1.0 - abs(py)) * (1.0 if px >= 0.0 else -1.0)
                    fy = (1.0 - abs(px)) * (1.0 if py >= 0.0 else -1.0)
                else:
                    fx, fy = px, py
                col = min(max(np.floor((fx + 1.0) * 0.5 * cells), 0.0), cells - 1.0)
                row = min(max(np.floor((fy + 1.0) * 0.5 * cells), 0.0), cells - 1.0)
                codes[k, j, i] = int(row) * grid + int(col)
