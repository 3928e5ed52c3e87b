"""Analytic fields for closed-form checks of the reference integrators.

A voxel grid cannot hold a sphere with an exact boundary, so the sphere of
constant material (whose transmittance depends only on chord lengths) is an
analytic field.  It offers what the converged integrator needs of a field:
``sample``, ``gradient``, ``knots`` (where it is not smooth along a ray) and
``degree`` (its polynomial degree between knots).
"""

from __future__ import annotations

import numpy as np


class SphereField:
    """``inside`` within the closed ball ``|p - centre| <= radius``, ``outside`` elsewhere."""

    degree = 0

    def __init__(self, centre, radius: float, inside: float = 1.0, outside: float = 0.0):
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius = float(radius)
        self.inside, self.outside = float(inside), float(outside)

    def sample(self, points: np.ndarray) -> np.ndarray:
        r2 = np.sum((np.asarray(points) - self.centre) ** 2, axis=1)
        return np.where(r2 <= self.radius ** 2, self.inside, self.outside)

    def gradient(self, points: np.ndarray) -> np.ndarray:
        return np.zeros((len(points), 3))

    def chords(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ray parameters where unit-direction rays enter and leave the ball (NaN: miss)."""
        oc = origins - self.centre
        b = np.sum(oc * directions, axis=1)
        disc = b * b - (np.sum(oc * oc, axis=1) - self.radius ** 2)
        with np.errstate(invalid="ignore"):
            root = np.sqrt(np.where(disc > 0, disc, np.nan))
        return -b - root, -b + root

    def knots(self, origins, directions, t0, t1):
        enter, leave = self.chords(origins, directions)
        ray = np.concatenate([np.arange(len(t0))] * 2)
        t = np.concatenate([enter, leave])
        keep = np.isfinite(t) & (t > np.concatenate([t0, t0])) & (t < np.concatenate([t1, t1]))
        return ray[keep], t[keep]
