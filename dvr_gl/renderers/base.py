"""The one interface every renderer implements: a scene in, an image out.

A renderer returns premultiplied, linear, float32 RGBA ``(H, W, 4)`` with
row 0 at the top and the background not yet applied (conventions).  After
``render`` its ``stats`` dict describes the last frame: ``seconds``, and
``samples``, the number of volume samples taken, where that is meaningful.

Subclasses implement :meth:`Renderer.draw`; :meth:`Renderer.render` first asks the
registry whether this renderer can render the scene (:func:`.registry.check`), so a
refusal is the same one-line reason whether it comes from here, the CLI or the viewer;
then :meth:`Renderer.check_resources` refuses what would exceed a GL limit, the memory
budget or the work bound (:mod:`dvr_gl.limits`), before anything is allocated or drawn.
Renderers that work in steps (the CPU references) report them to :attr:`Renderer.progress`.

Every GL renderer is a :class:`GLRenderer`: the GL frame kit (:class:`dvr_gl.gl.frame.GLFrame`: the
context, cached resources, render targets, read-back, binding, release) with this interface, and the
limits every GL frame shares (the image as a render target, its memory) checked before the renderer's
own (:meth:`GLRenderer.check_textures`).
"""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from .. import limits
from ..gl.frame import GLFrame
from ..orientation import volume_frame_scene
from ..sandbox import current, time_limit_error
from . import registry


class Renderer:
    name: ClassVar[str] = ""
    description: ClassVar[str] = ""

    progress = None   # progress(done, total) after each step of a frame (a progress bar), or None
    # A depth image beside the colour (RendererPlugin.depth_output renderers; docs/picking.md): asked for by
    # setting want_depth before render(), left in depth: (H, W) float32, the distance along the view axis
    # (world units), inf where the ray has no depth
    want_depth = False
    depth = None
    _started = 0.0    # when the frame began (perf_counter seconds), for the sandbox's time budget

    def __init__(self):
        self.stats: dict = {}

    @property
    def plugin(self) -> "registry.RendererPlugin":
        return registry.plugin(self.name)

    def render(self, scene) -> np.ndarray:
        """The image of ``scene`` (SceneError with the reason if this renderer cannot render it).
        ``stats["seconds"]`` is the frame's wall time, unless ``draw`` measured it itself."""
        return self.in_volume_frame(scene, self.draw)

    def in_volume_frame(self, scene, draw) -> np.ndarray:
        """``draw(local)`` of ``scene`` checked and turned into the volume's frame, its columns turned back
        (what :meth:`render` does around :meth:`draw`; a renderer's other frames, e.g. partial states)."""
        registry.check(scene, self.name)
        self.check_resources(scene)
        self.stats = {}
        self.depth = None
        start = self._started = time.perf_counter()
        # the camera is stated in the patient frame; renderers draw in the volume's own (dvr_gl.orientation)
        local, mirrored = volume_frame_scene(scene)
        image = draw(local)
        if mirrored:
            image = np.ascontiguousarray(image[:, ::-1])
            if self.depth is not None:
                self.depth = np.ascontiguousarray(self.depth[:, ::-1])
        self.stats.setdefault("seconds", time.perf_counter() - start)
        return image

    def draw(self, scene) -> np.ndarray:
        raise NotImplementedError

    def check_resources(self, scene):
        """Refuse, in one line, a scene whose frame would exceed a GL limit, the memory budget or the
        work bound (:mod:`dvr_gl.limits`)."""
        limits.check_work(self.work(scene), self.name)

    def work(self, scene) -> "limits.Work | None":
        """The estimated work of one frame (None: bounded by the data, nothing to check)."""
        return None

    def report(self, done: int, total: int):
        """A step of the frame is done: tell :attr:`progress`, and stop at the sandbox's time budget
        (a KeyboardInterrupt raised by ``progress`` ends the render the same way: nothing is written)."""
        if self.progress is not None:
            self.progress(done, total)
        seconds = current().max_seconds
        if seconds is not None and time.perf_counter() - self._started > seconds:
            raise time_limit_error(seconds, f" in {self.name}, {done} of {total} steps done")

    def close(self):
        """Release GPU resources (nothing for CPU renderers)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class GLRenderer(GLFrame, Renderer):
    """A renderer that draws with OpenGL: ``ctx``, a moderngl context to draw with (borrowed), or None
    for a headless one of its own (see :class:`GLFrame`)."""

    def __init__(self, ctx=None):
        Renderer.__init__(self)
        GLFrame.__init__(self, ctx)

    def check_resources(self, scene):
        """The work bound, then the image against the render-target limit and the memory budget, then
        what the renderer puts on the GPU (:meth:`check_textures`)."""
        super().check_resources(scene)
        limits.check_float32_frame(scene, self.name)
        self.activate()
        gl = limits.gl_limits(self.ctx)
        limits.check_image(scene, gl)
        limits.check_image_memory(scene, "gpu")
        self.check_textures(scene, gl)

    def check_textures(self, scene, gl: "limits.GLLimits"):
        """Refuse, in one line, textures (tables, volumes, meshes) beyond the GL limits ``gl`` or the memory
        budget, before anything is made; nothing to check by default."""


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
