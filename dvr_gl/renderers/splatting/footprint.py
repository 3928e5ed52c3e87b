"""Footprint tables of the Gaussian reconstruction kernel, in float64, for splatting.

A kernel ``K(r)`` radial in voxel units with support radius ``R``, met by a line at distance
``rho`` from its centre, contributes along the line

* its **footprint** ``F(q) = integral K(sqrt(rho^2 + z^2)) dz`` over the whole chord, ``q = rho^2 / R^2``
  in [0, 1] (tabulated in ``q``, as SPLASH tabulates its column-integrated kernel in ``q^2``: no
  square root per pixel);
* the part of it inside a slab, or inside the volume's box: for the Gaussian the kernel along the
  line is a 1D Gaussian of the same width times a constant, so the part between ``z0`` and ``z1``
  (clipped to the chord ``[-c, c]``, ``c = sqrt(R^2 - rho^2)``) is ``F (Phi(z1) - Phi(z0)) /
  (Phi(c) - Phi(-c))`` with ``Phi`` the standard normal's cumulative distribution, in units of
  ``sigma``: the second table.

Both are computed once per truncation and serve every width: with ``R`` a fixed multiple of ``sigma``
(``renderer.kernel_radius``, by default :data:`dvr_gl.scene.model.GAUSSIAN_RADIUS`), ``F`` in voxel units is
``F_1(q) / sigma^2``.  Their sizes come
from the shader's linear interpolation (``tests/test_splatting.py`` measures it): 16384 entries each
(one texture row, GL 4's smallest maximum), at most 7e-8 of the peak for ``F`` and 1.1e-8 for
``Phi``: the sums of many splats carry the relative error of the tables, and a transfer function
feature a fraction of a data step wide at values of 100 (``tests/renderers/test_extremes.py``) needs the field
to 1e-7 of its value.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ...fields.reconstruction import GaussianKernel, _erf

TABLE_SIZE = 16384


class GaussianFootprint:
    """The tables of the truncated Gaussian (:class:`~dvr_gl.fields.reconstruction.GaussianKernel`)."""

    def __init__(self, radius_in_sigmas: float, size: int = TABLE_SIZE):
        self.a = float(radius_in_sigmas)  # R / sigma
        self.unit = GaussianKernel(1.0, self.a)
        self.footprint_table = self.footprint(np.linspace(0.0, 1.0, size), 1.0)
        self.cumulative_table = self.cumulative(np.linspace(-self.a, self.a, size))

    def footprint(self, q, sigma: float) -> np.ndarray:
        """``F(q)`` in voxel units (the line integral, per voxel of length) for standard deviation
        ``sigma`` voxels."""
        return self.unit.footprint(np.asarray(q, dtype=np.float64) * self.unit.radius ** 2) / sigma ** 2

    @staticmethod
    def cumulative(x) -> np.ndarray:
        """``Phi(x)``, the standard normal's share below ``x`` (standard deviations)."""
        return 0.5 * (1.0 + _erf(np.asarray(x, dtype=np.float64) / math.sqrt(2.0)))


#: The M4 tables' sizes: the footprint and the slab mass in one row each (as the Gaussian's); the
#: chord shares (rows: q, columns: the point along the chord) and the sub-pixel box integrals (a
#: quadrant's share of the footprint) in 2D, interpolated bilinearly; measured in tests/test_particles.py.
M4_CHORD_SIZE = (256, 1024)
M4_BOX_SIZE = 513
_BOX_FINE = 4  # the box table is summed on a grid this much finer, cell by cell, then subsampled


class M4Footprint:
    """The tables of the SPH cubic spline (:mod:`dvr_gl.fields.sph`), in units of its support ``R = 2h``:

    * ``footprint_table``: ``f(q) = h^2 F``, the line integral at ``q = rho^2 / R^2`` in [0, 1];
    * ``chord_table`` ``(rows, columns)``: the share of a line's integral below the point ``xi`` of its
      chord (``xi`` in [-1, 1] across the chord ``[-c, c]``, ``c = R sqrt(1 - q)``), rows over ``q``;
    * ``box_table`` ``(n, n)``: ``G(X, Y)``, the footprint's share over ``(-1, X) x (-1, Y)`` (``X, Y`` in
      [-1, 1], units of ``R``): a pixel's integral of a sub-pixel particle's footprint is
      ``G(x1, y1) - G(x0, y1) - G(x1, y0) + G(x0, y0)``, and the sum over the pixels a particle
      covers telescopes to ``G(1, 1) = 1``: its integral is kept exactly;
    * ``slab_table``: the kernel's mass below the plane ``Z`` (units of ``R``, in [-1, 1]).
    """

    def __init__(self, size: int = TABLE_SIZE):
        from ...fields import sph

        self.size = size
        q = np.linspace(0.0, 1.0, size)
        self.footprint_table = sph.footprint(sph.SUPPORT * np.sqrt(q))

    # made when first read: the host's X-ray reads the footprint alone, and the quadrant table only where a
    # particle is under 2 pixels (0.3 s less each)
    @functools.cached_property
    def box_table(self) -> np.ndarray:
        return self._box(np.linspace(0.0, 1.0, self.size), self.footprint_table)

    @functools.cached_property
    def slab_table(self) -> np.ndarray:
        from ...fields import sph

        return sph.slab_mass(sph.SUPPORT * np.linspace(-1.0, 1.0, self.size))

    @functools.cached_property
    def chord_table(self) -> np.ndarray:
        from ...fields import sph

        rows, columns = M4_CHORD_SIZE
        qr = np.linspace(0.0, 1.0, rows)
        b = sph.SUPPORT * np.sqrt(qr)[:, None]
        c = np.sqrt(np.maximum(sph.SUPPORT ** 2 - b * b, 0.0))
        xi = np.linspace(-1.0, 1.0, columns)[None, :]
        # each column step of each chord by 4-point Gauss-Legendre, summed along the row (a hundredth of the
        # time of integrating every entry from the chord's end, the same entries to 1.5e-14)
        edges = xi * c
        half = 0.5 * np.diff(edges, axis=1)
        nodes, weights = np.polynomial.legendre.leggauss(4)
        s = 0.5 * (edges[:, 1:] + edges[:, :-1])[..., None] + half[..., None] * nodes
        steps = (sph.w(np.sqrt(b[..., None] ** 2 + s * s)) @ weights) * half
        part = np.concatenate([np.zeros((rows, 1)), np.cumsum(steps, axis=1)], axis=1)
        whole = part[:, -1:]
        # at q = 1 the chord closes: there w(r) ~ (2 - r)^3 ~ (c^2 - x^2)^3, whose cumulative is the limit row
        limit = (xi - xi ** 3 + 0.6 * xi ** 5 - xi ** 7 / 7.0 + 16.0 / 35.0) / (32.0 / 35.0)
        return np.where(whole > 0, part / np.where(whole > 0, whole, 1.0), limit)

    @staticmethod
    def _box(q, table) -> np.ndarray:
        n = (M4_BOX_SIZE - 1) * _BOX_FINE
        centres = -1.0 + (np.arange(n) + 0.5) * (2.0 / n)
        r2 = centres[:, None] ** 2 + centres[None, :] ** 2
        cells = np.where(r2 < 1.0, np.interp(r2, q, table), 0.0)
        g = np.zeros((n + 1, n + 1))
        g[1:, 1:] = np.cumsum(np.cumsum(cells, axis=0), axis=1)
        g /= g[-1, -1]  # the midpoint rule's O(cell^2) error in the total, removed: G(1, 1) = 1 exactly
        return g[::_BOX_FINE, ::_BOX_FINE]  # [y, x] order is [x, y] too: the footprint is symmetric
