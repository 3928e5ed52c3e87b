"""The one OpenGL context factory.

* ``egl`` (default): a headless standalone context through EGL; on machines
  without a GPU that is Mesa's llvmpipe.
* ``window``: attach to the context current in this thread (one a GLFW window
  created), for the interactive viewer.

Failures become one line naming what is missing and the Debian package that
provides it.
"""

from __future__ import annotations

import ctypes
import functools

import moderngl

from ..errors import GLUnavailableError
from ..limits import gl_limits

MIN_GL_VERSION = 330  # 3.3 core: 3D and float textures, texelFetch, float render targets

EGL_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri"


def _explain(exc: Exception, backend: str) -> str:
    text = " ".join(str(exc).split())
    if "not loaded" in text or "cannot open shared object" in text:
        lib = text.split()[0] if text else "libEGL"
        return (f"cannot create an OpenGL context: {lib} could not be loaded; install the EGL loader "
                f"and Mesa's driver (Debian: apt install {EGL_PACKAGES})")
    if backend == "window":
        return (f"cannot use the window's OpenGL context ({text}); create a window and make its "
                f"context current first")
    return (f"cannot create an OpenGL context through EGL ({text}); install Mesa's EGL driver "
            f"(Debian: apt install {EGL_PACKAGES}) or check the GPU driver")


def create_context(backend: str = "egl", **kwargs) -> moderngl.Context:
    """A moderngl context of at least OpenGL 3.3 core (see module doc for ``backend``)."""
    try:
        if backend == "egl":
            ctx = moderngl.create_standalone_context(backend="egl", **kwargs)
        elif backend == "window":
            ctx = moderngl.create_context(**kwargs)
        else:
            raise ValueError(f"unknown context backend {backend!r}; use 'egl' or 'window'")
    except ValueError:
        raise
    except Exception as exc:  # glcontext raises bare Exceptions for loader failures
        raise GLUnavailableError(_explain(exc, backend)) from exc
    if ctx.version_code < MIN_GL_VERSION:
        version = ctx.info.get("GL_VERSION", ctx.version_code)
        ctx.release()
        raise GLUnavailableError(f"OpenGL 3.3 or newer is needed, this context offers {version}; "
                                 f"update Mesa (Debian: apt install {EGL_PACKAGES}) or the GPU driver")
    return ctx


def release_context(ctx: moderngl.Context) -> None:
    """Release a context this process created, and leave no EGL context current on this thread.

    moderngl's release leaves the thread bound to EGL; libglvnd then refuses to make a GLX
    context current on it (BadAccess), so a window opened after a headless render (``dvr view
    --tolerance E``, whose check renders before the window opens) would fail."""
    ctx.release()
    egl = _libegl()
    if egl is not None:
        egl.eglReleaseThread()


@functools.cache
def _libegl():
    try:
        return ctypes.CDLL("libEGL.so.1")
    except OSError:  # no EGL library: no EGL context can have been current
        return None


def make_current(ctx: moderngl.Context) -> moderngl.Context:
    """Make ``ctx`` this thread's current context, and leave it current.

    Creating a context makes it current, so with two renderers alive (each with its
    own context) the older one would issue its calls into the newer one's context:
    wrong objects, empty images.  Every GL entry point of a renderer calls this
    first.  (``with ctx:`` is not used: leaving it unbinds every context.)"""
    ctx.__enter__()
    return ctx


def gl_info(ctx: moderngl.Context) -> dict:
    """What ``dvr info`` prints: vendor, renderer, version and texture limits (read where the renderers
    read them: :func:`dvr_gl.limits.gl_limits`)."""
    info, limits = ctx.info, gl_limits(ctx)
    return {
        "vendor": info["GL_VENDOR"],
        "renderer": info["GL_RENDERER"],
        "version": info["GL_VERSION"],
        "max_3d_texture_size": limits.texture_3d_size,
        "max_texture_size": limits.texture_size,
    }
