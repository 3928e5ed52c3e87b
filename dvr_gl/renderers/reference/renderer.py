"""The same-discretization reference as a renderer: ``dvr_gl.reference.discrete``, float64 on the CPU.

The conventions' samples and the transfer-function table, as the GPU uses them: "is the GPU
code right?".
"""

from __future__ import annotations

from ... import limits
from ...reference.depth import depth_image
from ...reference.discrete import DiscreteReference
from ..judge import ReferenceRenderer


class DiscreteReferenceRenderer(ReferenceRenderer):
    name = "reference"
    description = "CPU float64, same discretization as the GPU (samples, LUT)"
    integrator = DiscreteReference

    def check_resources(self, scene):
        super().check_resources(scene)
        limits.check_lut_memory(scene.renderer.lut_size)

    def draw(self, scene):
        image = super().draw(scene)
        if self.want_depth:  # the judge of depth images: dvr_gl.reference.depth
            self.depth = depth_image(self.integrated)
        return image

    def work(self, scene):
        return limits.ray_samples(scene, "cpu samples")
