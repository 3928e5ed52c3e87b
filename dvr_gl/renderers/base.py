"""The one interface every renderer implements: a scene in, an image out.

A renderer returns premultiplied, linear, float32 RGBA ``(H, W, 4)`` with
row 0 at the top and the background not yet applied (conventions).  After
``render`` its ``stats`` dict describes the last frame (at least
``samples``, the number of volume samples taken, where that is meaningful).
"""

from __future__ import annotations

import importlib
from typing import ClassVar

import numpy as np

from ..errors import SceneError


class Renderer:
    name: ClassVar[str] = ""
    description: ClassVar[str] = ""

    def __init__(self):
        self.stats: dict = {}

    def render(self, scene) -> np.ndarray:
        raise NotImplementedError

    def close(self):
        """Release GPU resources (nothing for CPU renderers)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# name -> "module:Class": adding a renderer is one line here; modules load on first use.
RENDERERS = {
    "raycast": "dvr_gl.renderers.raycast:RayCastRenderer",
    "slicing3d": "dvr_gl.renderers.slicing:Slicing3DRenderer",
    "slicing2d": "dvr_gl.renderers.slicing:Slicing2DRenderer",
    "shearwarp": "dvr_gl.renderers.shearwarp:ShearWarpRenderer",
    "reference": "dvr_gl.renderers.reference:DiscreteReferenceRenderer",
    "reference-converged": "dvr_gl.renderers.reference:ConvergedReferenceRenderer",
}


def available_renderers() -> list[str]:
    return list(RENDERERS)


def renderer_class(name: str) -> type[Renderer]:
    if name not in RENDERERS:
        raise SceneError(f"unknown renderer {name!r}; available: {', '.join(RENDERERS)}")
    module, cls = RENDERERS[name].split(":")
    return getattr(importlib.import_module(module), cls)


def create_renderer(name: str, **kwargs) -> Renderer:
    return renderer_class(name)(**kwargs)


def render(scene) -> np.ndarray:
    """Render with the scene's own renderer (``scene.renderer.name``)."""
    with create_renderer(scene.renderer.name) as renderer:
        return renderer.render(scene)
