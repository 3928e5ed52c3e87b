"""The CPU reference renderers (float64): the judges of every other renderer.

* ``reference``: the same-discretization reference (``dvr_gl.reference.discrete``):
  the conventions' samples and the transfer-function table, as the GPU uses them.
* ``reference-converged``: the converged reference (``dvr_gl.reference.converged``):
  the exact transfer function, integrated along each ray until refining
  changes the image by less than ``renderer.converged_tolerance``.
"""

from __future__ import annotations

import time

import numpy as np

from ..reference.converged import ConvergedReference
from ..reference.discrete import DiscreteReference
from .base import Renderer


class _ReferenceRenderer(Renderer):
    integrator: type

    def render(self, scene) -> np.ndarray:
        start = time.perf_counter()
        ref = self.integrator(scene)
        image = ref.render()
        self.stats = {"seconds": time.perf_counter() - start, **ref.stats}
        return image


class DiscreteReferenceRenderer(_ReferenceRenderer):
    name = "reference"
    description = "CPU float64, same discretization as the GPU (samples, LUT)"
    integrator = DiscreteReference


class ConvergedReferenceRenderer(_ReferenceRenderer):
    name = "reference-converged"
    description = "CPU float64, exact transfer function, integrated to a tolerance"
    integrator = ConvergedReference
