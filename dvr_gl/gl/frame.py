"""The GL frame kit: what every GL renderer does around its own drawing.

A :class:`GLFrame` holds one moderngl context (its own, made here, or one it borrows: the viewer's
window, a test's shared context) and everything it makes in it:

* **cached resources**: textures and host data kept under a name with the key they were made from
  (objects by identity, plain values by value, :func:`same_key`), so an orbit re-renders without
  uploads and a transfer-function edit re-makes only what depends on it (:meth:`GLFrame._cached`);
* **render targets**: framebuffers kept per name while their size and shape hold (:meth:`GLFrame.target`);
* **read-back**: a target's float32 texels as an image, row 0 at the top (:meth:`GLFrame.read`);
* **binding**: uniforms and textures to a program, each texture on its own unit (:meth:`GLFrame.bind`);
* **the lifecycle**: :meth:`GLFrame.activate` first in every GL entry point (two renderers alive each
  have a context, and GL calls go to the current one), :meth:`GLFrame.close` releases everything, and
  the context and its programs where the frame made them.

Every GL renderer is a :class:`dvr_gl.renderers.base.GLRenderer` (this kit with the renderer interface);
the kits above it add what only some need: grid sampling (:mod:`dvr_gl.renderers.grid.sampling`), meshes
(:mod:`dvr_gl.renderers.mesh.textures`).  The light volume's pass (:mod:`.scattering`) draws with a frame.
"""

from __future__ import annotations

import numpy as np

from .context import create_context, make_current, release_context
from .lights import set_uniform
from .shaders import release_programs

# Plain values: cache keys compare these by value, everything else by identity.
PLAIN = (int, float, str, bool, type(None), np.integer, np.floating, np.bool_)


def same_key(a, b) -> bool:
    """Cache keys match: objects by identity, plain values (numbers, strings, and tuples of them) by value."""
    if a is b:
        return True
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(map(same_key, a, b))
    return isinstance(a, PLAIN) and isinstance(b, PLAIN) and a == b


def release_entry(value):
    """Release what a cache entry holds on the GPU: a GL object, or an object holding one in ``texture``
    or releasing its own in ``release()`` (host data holds nothing)."""
    target = getattr(value, "texture", value)
    if hasattr(target, "release"):
        target.release()


class GLFrame:
    """One context and the GL resources a renderer keeps in it (see the module doc).  ``ctx``: a
    moderngl context to draw with, borrowed (never released here); None makes a headless one, owned."""

    def __init__(self, ctx=None):
        self.ctx = ctx or create_context()
        self._owns_context = ctx is None
        self._cache: dict = {}         # what -> (key objects, texture or host data)
        self._targets: dict = {}       # name -> (textures, framebuffer)
        self._target_shapes: dict = {}  # name -> the (size, shape) its target was made for

    def activate(self):
        """Make this frame's context current (see :func:`make_current`); first in every GL entry point."""
        make_current(self.ctx)

    # --- cached resources ---

    def _cached(self, what: str, key: tuple, make):
        """``make()``, unless the entry ``what`` was made from the same key (:func:`same_key`); the
        entry it replaces is released."""
        entry = self._cache.get(what)
        if entry is not None and same_key(entry[0], key):
            return entry[1]
        if entry is not None:
            release_entry(entry[1])
        value = make()
        self._cache[what] = (key, value)
        return value

    # --- render targets and read-back ---

    def target(self, name: str, width: int, height: int, components=(4,), depth: bool = False):
        """``(textures, framebuffer)``: float32 colour textures, one per entry of ``components`` (and a
        depth texture, last, with ``depth``), kept under ``name`` while size and shape hold."""
        components = tuple(components)

        def make(size):
            colours = [self.ctx.texture(size, c, dtype="f4") for c in components]
            depths = [self.ctx.depth_texture(size)] if depth else []
            return colours + depths, self.ctx.framebuffer(colours, *depths)

        return self.framebuffer(name, width, height, make, (components, depth))

    def framebuffer(self, name: str, width: int, height: int, make, shape=None):
        """``make((width, height)) -> (textures, framebuffer)`` (every GL object it made in
        ``textures``), kept under ``name`` while the size and ``shape`` (what else ``make`` depends on)
        hold: a target of another kind than :meth:`target`'s."""
        entry = self._targets.get(name)
        if entry is None or self._target_shapes[name] != ((width, height), shape):
            if entry is not None:
                self._release_target(name)
            entry = self._targets[name] = make((width, height))
            self._target_shapes[name] = ((width, height), shape)
        return entry

    def _release_target(self, name: str):
        textures, fbo = self._targets.pop(name)
        for obj in (*textures, fbo):
            obj.release()
        del self._target_shapes[name]

    @staticmethod
    def read(fbo, width: int, height: int, components: int = 4, attachment: int = 0,
             flip: bool = True) -> np.ndarray:
        """A colour attachment's float32 texels, ``(height, width, components)``.  GL rows run bottom up:
        ``flip`` turns them top down (row 0 at the top, the renderers' convention); a pass whose
        fragment row ``j`` already is the image's row ``j`` from the top reads them as stored.  A fresh,
        writable array either way, read into numpy's own array and turned over in place (a few rows at
        a time): no second whole-image array.  ``fbo.read``'s bytes and a flipped copy took a 512x512
        RGBA frame 4-5 ms of CPU against 2 ms (a fresh 4 MB block's page faults each; measured on a
        busy machine, 2026-11-28)."""
        data = np.empty((height, width, components), np.float32)
        fbo.read_into(data, components=components, dtype="f4", attachment=attachment)
        return _flip_rows(data) if flip else data

    # --- binding ---

    set_uniform = staticmethod(set_uniform)

    def bind(self, program, uniforms: dict, textures: dict):
        """Set ``uniforms`` (:func:`set_uniform`: those the program lacks are skipped) and bind each of
        ``textures`` to its own unit, in order.  A texture is a GL texture or an object holding one in
        ``texture``; one with a ``uniforms()`` method brings the uniforms that read it (a volume's
        value scale, a table's domain), set after its sampler."""
        for name, value in uniforms.items():
            self.set_uniform(program, name, value)
        for unit, (name, tex) in enumerate(textures.items()):
            getattr(tex, "texture", tex).use(location=unit)
            self.set_uniform(program, name, unit)
            for key, value in (tex.uniforms() if hasattr(tex, "uniforms") else {}).items():
                self.set_uniform(program, key, value)

    # --- the end ---

    def close(self):
        """Release the cached resources and targets, and the context with its programs if it is this
        frame's own."""
        self.activate()
        for _, value in self._cache.values():
            release_entry(value)
        self._cache.clear()
        for name in list(self._targets):
            self._release_target(name)
        if self._owns_context:
            release_programs(self.ctx)
            release_context(self.ctx)


def _flip_rows(data: np.ndarray, rows: int = 8) -> np.ndarray:
    """``data`` with its rows (first axis) in reverse order, in place, ``rows`` at a time on each side."""
    height = len(data)
    half = height // 2
    for top in range(0, half, rows):
        n = min(rows, half - top)
        upper = data[top:top + n].copy()
        data[top:top + n] = data[height - top - n:height - top][::-1]
        data[height - top - n:height - top] = upper[::-1]
    return data
