"""The same-discretization reference as a renderer: ``dvr_gl.reference.discrete``, float64 on the CPU.

The conventions' samples and the transfer-function table, as the GPU uses them: "is the GPU
code right?".
"""

from __future__ import annotations

import time

import numpy as np

from ... import limits
from ...reference.discrete import DiscreteReference
from ..base import Renderer


class ReferenceRenderer(Renderer):
    """A float64 integrator (``integrator(scene).render()``) behind the renderer interface."""

    integrator: type

    def check_resources(self, scene):
        super().check_resources(scene)
        limits.check_image_memory(scene, "cpu")

    def draw(self, scene) -> np.ndarray:
        start = time.perf_counter()
        ref = self.integrator(scene)
        ref.progress = self.report
        image = ref.render()
        self.stats = {"seconds": time.perf_counter() - start, **ref.stats}
        return image


class DiscreteReferenceRenderer(ReferenceRenderer):
    name = "reference"
    description = "CPU float64, same discretization as the GPU (samples, LUT)"
    integrator = DiscreteReference

    def check_resources(self, scene):
        super().check_resources(scene)
        limits.check_lut_memory(scene.renderer.lut_size)

    def work(self, scene):
        return limits.ray_samples(scene, "cpu samples")
