"""What the CPU references share as renderers: a float64 integrator of :mod:`dvr_gl.reference` behind
the renderer interface (the judges: ``RendererPlugin.reference``), so that no reference renderer's
package imports another's."""

from __future__ import annotations

import time

import numpy as np

from .. import limits
from .base import Renderer


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
        self.integrated = ref  # what a renderer may read beyond the image (the reference's depth)
        self.stats = {"seconds": time.perf_counter() - start, **ref.stats}
        return image
