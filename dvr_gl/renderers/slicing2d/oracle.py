"""The 2D-stack slicer's oracle: the shared same-discretization judge sampling the voxel planes.

The stack drawn is the voxel planes across the axis that faces the eye most squarely, clipped by the
near plane; the float64 judge (:class:`~dvr_gl.reference.discrete.DiscreteReference`) samples each
ray where it crosses those very planes (:func:`dvr_gl.renderers.grid.slicing.voxel_planes`), so what
is left is float32 rounding.
"""

from __future__ import annotations

import numpy as np

from ..grid.slicing import reference, voxel_planes


def oracle(scene) -> np.ndarray:
    """The float64 image ``(H, W, 4)`` of the same voxel planes."""
    return reference(scene, voxel_planes).render_float64()
