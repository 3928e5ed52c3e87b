"""Renderers: one package each, registered as plugins (:mod:`.registry`), behind one interface
(:class:`Renderer`: a scene in, an image out).

Each renderer's package holds everything that is only its own (its plugin declaration in
``__init__.py``, code, ``shaders/``, ``oracle.py``, bench, ``tests/``, ``README.md``); the kits its
users share live beside them (:mod:`.grid` for renderers that sample grids, :mod:`.mesh` for those
of meshes, :mod:`.judge` for the CPU references), and everything else asks the registry for what
a renderer declares, never for a name (``dvr info`` lists them).
"""

from ..scene.plugin import RendererPlugin
from . import registry
from .base import Renderer, available_renderers, create_renderer, render, renderer_class

__all__ = ["Renderer", "RendererPlugin", "available_renderers", "create_renderer", "registry", "render",
           "renderer_class"]
