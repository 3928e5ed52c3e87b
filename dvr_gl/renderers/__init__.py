"""Renderers behind one interface (:class:`Renderer`); see :data:`RENDERERS`."""

from .base import RENDERERS, Renderer, available_renderers, create_renderer, render, renderer_class

__all__ = ["RENDERERS", "Renderer", "available_renderers", "create_renderer", "render", "renderer_class"]
