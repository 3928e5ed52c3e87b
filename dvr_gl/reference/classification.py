"""Classification for the reference: from a point to (non-associated colour, extinction).

* post-classification: reconstruct the scalar, then look it up (the LUT, as the
  GPU does, or the exact transfer function for the converged reference);
* pre-classification: classify every voxel exactly, reconstruct the classified
  volume.  With ``associated`` colours the volume holds ``(sigma c, sigma)``
  (emission and extinction), so a transparent voxel adds no colour; the
  non-associated variant interpolates ``(c, sigma)`` and lets the colour of
  invisible voxels bleed into edges (kept to show that artefact).
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError


class PostClassifier:
    def __init__(self, scalar, table):
        """``table``: a :class:`TransferFunctionLUT` or a :class:`TransferFunction` (exact)."""
        self.scalar = scalar
        self.lookup = table.lookup if hasattr(table, "lookup") else table.evaluate

    def __call__(self, points: np.ndarray, scalars: np.ndarray | None = None):
        """Colour and extinction; none where the scalar is NaN (outside a mesh: no material there)."""
        s = self.scalar.sample(points) if scalars is None else scalars
        outside = np.isnan(s)
        if not outside.any():
            return self.lookup(s)
        colour, sigma = self.lookup(np.where(outside, 0.0, s))
        return np.where(outside[:, None], 0.0, colour), np.where(outside, 0.0, sigma)


class PreClassifier:
    def __init__(self, field, tf, filter_kind: str, associated: bool = True, **parameters):
        """Classify the field's own samples, reconstruct the classified values as the field's
        (``parameters``: the filter's, as :func:`dvr_gl.fields.filter_parameters`)."""
        if not hasattr(field, "reconstruct_values"):
            raise SceneError(f"pre-classification classifies samples, and {field.kind} data has none; "
                             f"use classification post")
        classified = tf.classify_voxels(field.samples, associated)
        self.field = field.reconstruct_values(classified, filter_kind, **parameters)
        self.associated = associated

    def __call__(self, points: np.ndarray, scalars: np.ndarray | None = None):
        rgba = self.field.sample(points)
        sigma = np.maximum(rgba[:, 3], 0.0)
        first = np.maximum(rgba[:, :3], 0.0)  # cubic filters may overshoot below zero
        if not self.associated:
            return first, sigma
        with np.errstate(invalid="ignore", divide="ignore"):
            colour = np.where(sigma[:, None] > 0, first / sigma[:, None], 0.0)
        return colour, sigma


class GradientClassifier:
    def __init__(self, scalar, table):
        """Post-classification by a 2D transfer function (:mod:`dvr_gl.transfer_function_2d`): the scalar and
        its gradient magnitude (central differences one voxel apart, value units per world unit: the ray
        caster's) looked up in ``table``, a :class:`~dvr_gl.transfer_function_2d.TransferFunction2DLUT` (as the
        GPU) or the :class:`~dvr_gl.transfer_function_2d.TransferFunction2D` itself (exact)."""
        self.scalar = scalar
        self.lookup = table.lookup if hasattr(table, "lookup") else table.evaluate_2d

    def __call__(self, points: np.ndarray, scalars: np.ndarray | None = None):
        s = self.scalar.sample(points) if scalars is None else scalars
        return self.lookup(s, np.linalg.norm(self.scalar.gradient(points), axis=1))
