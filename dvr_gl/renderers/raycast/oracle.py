"""The ray caster's oracle: the shared same-discretization judge, as it is.

The fragment loop samples where the conventions put the samples (segments of ``sample_distance``
from each ray's entry, ``docs/conventions.md``) and classifies them through the same
transfer-function table, so the float64 judge of those very segments
(:func:`dvr_gl.reference.discrete.same_discretization`) is the image it must match to float32
rounding; no plan of its own.
"""

from __future__ import annotations

import numpy as np

from ...reference.discrete import same_discretization


def oracle(scene) -> np.ndarray:
    """The float64 image ``(H, W, 4)`` the ray caster must match: the conventions' segments."""
    return same_discretization(scene)
