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

Both are computed once and serve every width: with ``R`` a fixed multiple of ``sigma``
(:data:`dvr_gl.model.GAUSSIAN_RADIUS`), ``F`` in voxel units is ``F_1(q) / sigma^2``.  Their sizes come
from the shader's linear interpolation (``tests/test_splatting.py`` measures it): 16384 entries each
(one texture row, GL 4's smallest maximum), at most 7e-8 of the peak for ``F`` and 1.1e-8 for
``Phi``: the sums of many splats carry the relative error of the tables, and a transfer function
feature a fraction of a data step wide at values of 100 (``tests/test_extremes.py``) needs the field
to 1e-7 of its value.
"""

from __future__ import annotations

import math

import numpy as np

from ...fields.reconstruction import GaussianKernel, _erf

TABLE_SIZE = 16384


class GaussianFootprint:
    """The tables of the truncated Gaussian (:class:`~dvr_gl.fields.reconstruction.GaussianKernel`)."""

    def __init__(self, radius_in_sigmas: float, size: int = TABLE_SIZE):
        self.a = float(radius_in_sigmas)  # R / sigma
        self.unit = GaussianKernel(1.0)
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
