"""The splats of an SPH particle set (:class:`~dvr_gl.fields.particles.ParticleSet`), on the host: one per
particle, its own kernel (the cubic spline of its smoothing length) and weight ``m / rho``.

Post-classified each splat carries the particle's quantity; pre-classified its ``(sigma c, sigma)``
(the quantity classified), and particles the transfer function makes transparent are left out.  No
region culling: a transparent particle still moves the interpolant around it, and particles are no
lattice to bound that on.  Sorted by the view depth of their centres, a slab's splats are those
within the largest support of it (:func:`particle_slab_reach`); the vertex shader drops the rest.
"""

from __future__ import annotations

import numpy as np

from ...fields import sph
from ...sandbox import check_bytes

#: A particle whose support's radius is under this many pixels has its footprint averaged over the pixels
#: it covers (shaders/m4.glsl): sampled at pixel centres, a footprint's sum over the pixels errs
#: from its integral by up to 90 % at 1 pixel, 6 % at 1.5, 5.5e-4 at 2 and 1e-3 at 3 (measured over random
#: offsets, dvr_gl/renderers/splatting/README.md), so from 2 on the pixels' own rays serve.
SUBPIXEL_RADIUS = 2.0


class ParticleSplats:
    """Splats of ``particles``, world positions relative to ``centre`` (float64 until uploaded)."""

    def __init__(self, particles, centre: np.ndarray, optics: np.ndarray | None = None):
        self.total = len(particles)
        check_bytes(self.total * (24 + 40 + (32 if optics is not None else 0)), "the particle splats",
                    "use fewer particles")
        keep = slice(None) if optics is None else optics[:, 3] > 0
        self.positions = particles.positions[keep] - centre
        self.values = particles.values[keep]
        self.h = particles.smoothing_lengths[keep]
        self.weights = particles.weights[keep]
        self.optics = None if optics is None else np.ascontiguousarray(optics[keep], dtype=np.float32)
        self._column_weights = None
        self._view = (None, None)

    def __len__(self) -> int:
        return len(self.values)

    def depths(self, eye, forward) -> np.ndarray:
        return (self.positions - eye) @ forward

    def attributes(self, order: np.ndarray) -> list[tuple[str, int, np.ndarray]]:
        """The instance attributes in ``order``: (name, floats, float32 rows)."""
        first = np.empty((len(order), 4), np.float32)
        first[:, :3] = self.positions[order]
        first[:, 3] = self.values[order]
        particle = np.stack([self.h[order], self.weights[order]], axis=1).astype(np.float32)
        out = [("in_splat", 4, first), ("in_particle", 2, particle)]
        if self.optics is not None:
            out.append(("in_optics", 4, self.optics[order]))
        return out

    def column_weights(self, same_colour: float) -> tuple[np.ndarray, np.ndarray | None]:
        """The X-ray's weights per particle, float64, kept between frames (they depend on no view):
        ``(m / rho) (sigma c, sigma)`` ``(N, 4)``, or ``(m / rho) sigma`` ``(N, 1)`` and the one colour
        ``c`` where every particle's colour is within ``same_colour`` of the first's (relative to its
        sigma; else the colour is None).  Pre-classified splats only."""
        if self._column_weights is None:
            optics = self.optics.astype(np.float64) * self.weights[:, None]  # (m / rho) (sigma c, sigma)
            sigma = optics[:, 3:]
            colour = optics[:1, :3] / sigma[:1]
            one = bool(np.all(np.abs(optics[:, :3] - sigma * colour) <= same_colour * sigma))
            self._column_weights = (sigma, colour[0]) if one else (optics, None)
        return self._column_weights

    def cached_view(self, key, make):
        """``make()``, kept for the next call with the same ``key`` (the viewer's frames of one view: what
        :mod:`.column` projects once per view)."""
        if self._view[0] != key:
            self._view = (key, make())
        return self._view[1]

    def forget_view(self):
        """Drop the kept view (a benchmark timing whole frames of one view)."""
        self._view = (None, None)

    def bounding_radii(self) -> np.ndarray:
        """Each splat's bounding sphere (world units): its support."""
        return sph.SUPPORT * self.h

    @property
    def reach(self) -> float:
        """How far the widest support reaches from its centre (world units)."""
        return float(self.bounding_radii().max()) if len(self) else 0.0
