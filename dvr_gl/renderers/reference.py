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


class DiscreteReferenceRenderer(Renderer):
    name = "reference"
    description = "CPU float64, same discretization as the GPU (samples, LUT)"

    def render(self, scene) -> np.ndarray:
        start = time.perf_counter()
        ref = DiscreteReference(scene)
        image = ref.render()
        self.stats = {"samples": ref.samples, "seconds": time.perf_counter() - start}
        return image


class ConvergedReferenceRenderer(Renderer):
    name = "reference-converged"
    description = "CPU float64, exact transfer function, integrated to a tolerance"

    def render(self, scene) -> np.ndarray:
        start = time.perf_counter()
        ref = ConvergedReference(scene)
        image = ref.render()
        self.stats = {"seconds": time.perf_counter() - start, **ref.stats}
        return image
