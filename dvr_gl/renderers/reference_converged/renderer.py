"""The converged reference as a renderer: ``dvr_gl.reference.converged``, float64 on the CPU.

The exact transfer function, integrated along each ray until refining changes the image by
less than ``renderer.converged_tolerance``: "how accurate is this setting?".
"""

from __future__ import annotations

from ... import limits
from ...reference.converged import ConvergedReference
from ..judge import ReferenceRenderer


class ConvergedReferenceRenderer(ReferenceRenderer):
    name = "reference-converged"
    description = "CPU float64, exact transfer function, integrated to a tolerance"
    integrator = ConvergedReference

    def work(self, scene):
        return limits.converged_pieces(scene)
