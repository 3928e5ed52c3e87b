"""Analytic fields (data kind ``"analytic"``) for closed-form checks.

A voxel grid cannot hold a sphere with an exact boundary, so the sphere of
constant material (whose transmittance depends only on chord lengths) is an
analytic field.  It is a :class:`~dvr_gl.fields.Field` (any filter reconstructs it
exactly: it is its own reconstruction), so the references render it as they
render a grid.
"""

from __future__ import annotations

import numpy as np


class SphereField:
    """``inside`` within the closed ball ``|p - centre| <= radius``, ``outside`` elsewhere.

    ``bounds``: the box the field is rendered in (default: the ball's own box); ``sample_spacing``:
    the unit of distances in voxels (default: a 64th of the diameter)."""

    kind = "analytic"
    degree = 0

    def __init__(self, centre, radius: float, inside: float = 1.0, outside: float = 0.0, bounds=None,
                 sample_spacing: float | None = None, name: str = "sphere"):
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius = float(radius)
        self.inside, self.outside = float(inside), float(outside)
        if bounds is None:
            bounds = (self.centre - self.radius, self.centre + self.radius)
        self._bounds = (np.asarray(bounds[0], dtype=np.float64), np.asarray(bounds[1], dtype=np.float64))
        self._spacing = float(sample_spacing) if sample_spacing else self.radius / 32.0
        self.name = name

    @property
    def bounds(self):
        return self._bounds

    @property
    def value_range(self) -> tuple[float, float]:
        return (min(self.inside, self.outside), max(self.inside, self.outside))

    @property
    def sample_spacing(self) -> float:
        return self._spacing

    def reconstruct(self, filter: str = "linear") -> "SphereField":
        return self

    def describe(self) -> str:
        return f"{self.name}: ball of radius {self.radius:g} at {self.centre.tolist()}, {self.inside:g} inside"

    def __repr__(self) -> str:
        return f"SphereField(centre={self.centre.tolist()}, radius={self.radius:g}, inside={self.inside:g})"

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
