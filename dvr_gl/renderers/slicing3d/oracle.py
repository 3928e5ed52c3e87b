"""The 3D-texture slicer's oracle: the shared same-discretization judge sampling the slicer's planes.

The slices are planes ``sample_distance`` apart facing the eye (half-way to the light under
half-angle slicing), clipped by the near plane; the float64 judge
(:class:`~dvr_gl.reference.discrete.DiscreteReference`) samples each ray where it crosses those very
planes (:func:`dvr_gl.renderers.grid.slicing.view_planes`), so what is left is float32 rounding and
the interpolation of positions across the slice polygons.
"""

from __future__ import annotations

import numpy as np

from ..grid.slicing import reference, view_planes


def oracle(scene) -> np.ndarray:
    """The float64 image ``(H, W, 4)`` of the same view-aligned planes."""
    return reference(scene, view_planes).render_float64()
