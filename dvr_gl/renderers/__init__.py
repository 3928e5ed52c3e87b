"""Renderers: one package each, registered as plugins (:mod:`.registry`), behind one interface
(:class:`Renderer`: a scene in, an image out).

Built in: ``raycast``, ``slicing3d``, ``slicing2d``, ``shearwarp`` (GL, regular grids; their
shared grid machinery in :mod:`.grid`), and the float64 CPU references ``reference`` and
``reference-converged`` (any field).
"""

from ..scene.plugin import RendererPlugin
from . import registry
from .base import Renderer, available_renderers, create_renderer, render, renderer_class

__all__ = ["Renderer", "RendererPlugin", "available_renderers", "create_renderer", "registry", "render",
           "renderer_class"]
