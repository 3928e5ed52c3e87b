"""The one interface every renderer implements: a scene in, an image out.

A renderer returns premultiplied, linear, float32 RGBA ``(H, W, 4)`` with
row 0 at the top and the background not yet applied (conventions).  After
``render`` its ``stats`` dict describes the last frame: ``seconds``, and
``samples``, the number of volume samples taken, where that is meaningful.

Subclasses implement :meth:`Renderer.draw`; :meth:`Renderer.render` first asks the
registry whether this renderer can render the scene (:func:`.registry.check`), so a
refusal is the same one-line reason whether it comes from here, the CLI or the viewer.
"""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from . import registry


class Renderer:
    name: ClassVar[str] = ""
    description: ClassVar[str] = ""

    def __init__(self):
        self.stats: dict = {}

    @property
    def plugin(self) -> "registry.RendererPlugin":
        return registry.plugin(self.name)

    def render(self, scene) -> np.ndarray:
        """The image of ``scene`` (SceneError with the reason if this renderer cannot render it).
        ``stats["seconds"]`` is the frame's wall time, unless ``draw`` measured it itself."""
        registry.check(scene, self.name)
        self.stats = {}
        start = time.perf_counter()
        image = self.draw(scene)
        self.stats.setdefault("seconds", time.perf_counter() - start)
        return image

    def draw(self, scene) -> np.ndarray:
        raise NotImplementedError

    def close(self):
        """Release GPU resources (nothing for CPU renderers)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def available_renderers() -> list[str]:
    return registry.names()


def renderer_class(name: str) -> type[Renderer]:
    return registry.plugin(name).renderer_class()


def create_renderer(name: str, **kwargs) -> Renderer:
    """A renderer by name; ``ctx=`` (a moderngl context) is passed to those that draw with GL only."""
    p = registry.plugin(name)
    if not p.needs_gl:
        kwargs.pop("ctx", None)
    return p.create(**kwargs)


def render(scene) -> np.ndarray:
    """Render with the scene's own renderer (``scene.renderer.name``)."""
    with create_renderer(scene.renderer.name) as renderer:
        return renderer.render(scene)
