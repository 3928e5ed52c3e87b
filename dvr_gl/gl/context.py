"""The one OpenGL context factory.

* ``egl``: a headless standalone context through EGL; on machines without a GPU
  that is Mesa's llvmpipe.
* ``osmesa``: a headless context through Mesa's OSMesa (:mod:`dvr_gl.gl.osmesa`),
  llvmpipe too, for machines where EGL gives none.
* ``window``: attach to the context current in this thread (one a GLFW window
  created), for the interactive viewer.

The headless backend is the environment variable ``DVR_GL_BACKEND`` (``egl``,
``osmesa`` or ``auto``; ``dvr --gl-backend`` sets it); ``auto`` (or unset) tries
EGL and, when EGL cannot give a context, says so once and uses OSMesa from then
on (it sets ``DVR_GL_BACKEND=osmesa``, so that worker processes started later
do not try EGL again).  One process uses one headless backend: both are Mesa
and share its dispatch library.

Failures become one line naming what is missing and the Debian package that
provides it.
"""

from __future__ import annotations

import ctypes
import functools
import logging
import os
import weakref

import moderngl

from ..errors import GLUnavailableError
from ..limits import gl_limits

log = logging.getLogger(__name__)

MIN_GL_VERSION = 330  # 3.3 core: 3D and float textures, texelFetch, float render targets

EGL_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri"
BACKEND_VARIABLE = "DVR_GL_BACKEND"
HEADLESS_BACKENDS = ("auto", "egl", "osmesa")


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


def chosen_backend() -> str:
    """The headless backend ``DVR_GL_BACKEND`` names: ``auto`` (unset or empty), ``egl`` or ``osmesa``."""
    name = os.environ.get(BACKEND_VARIABLE, "").strip().lower() or "auto"
    if name not in HEADLESS_BACKENDS:
        raise GLUnavailableError(f"{BACKEND_VARIABLE}={os.environ[BACKEND_VARIABLE]!r} is no OpenGL backend; "
                                 f"use one of {', '.join(HEADLESS_BACKENDS)}")
    return name


def create_context(backend: str | None = None, **kwargs) -> moderngl.Context:
    """A moderngl context of at least OpenGL 3.3 core; ``backend`` ``egl``, ``osmesa``, ``auto`` or
    ``window`` (see the module doc); None: :func:`chosen_backend`.  ``kwargs`` go to EGL's loader."""
    backend = backend or chosen_backend()
    if backend != "auto":
        return _checked(_create(backend, **kwargs), backend)
    try:
        return _checked(_create("egl", **kwargs), "egl")
    except GLUnavailableError as exc:
        egl_failure = str(exc)
    try:
        ctx = _checked(_create("osmesa"), "osmesa")
    except GLUnavailableError as osmesa_failure:
        raise GLUnavailableError(f"{egl_failure}; nor through OSMesa: {osmesa_failure}") from osmesa_failure
    log.warning("OpenGL through EGL is unavailable (%s); rendering through OSMesa (set %s=osmesa to skip EGL)",
                egl_failure, BACKEND_VARIABLE)
    os.environ[BACKEND_VARIABLE] = "osmesa"  # this process and the workers it starts: said once
    return ctx


def _create(backend: str, **kwargs) -> moderngl.Context:
    try:
        if backend == "egl":
            ctx = moderngl.create_standalone_context(backend="egl", **kwargs)
        elif backend == "osmesa":
            from .osmesa import OSMesaContext, OSMesaError

            try:
                ctx = moderngl.create_context(standalone=True, require=MIN_GL_VERSION, context=OSMesaContext())
            except OSMesaError as exc:
                raise GLUnavailableError(f"cannot create an OpenGL context through OSMesa: {exc}") from None
        elif backend == "window":
            ctx = moderngl.create_context(**kwargs)
        else:
            raise ValueError(f"unknown context backend {backend!r}; use 'egl', 'osmesa', 'auto' or 'window'")
    except (ValueError, GLUnavailableError):
        raise
    except Exception as exc:  # glcontext raises bare Exceptions for loader failures
        raise GLUnavailableError(_explain(exc, backend)) from exc
    _BACKENDS[ctx] = backend
    return ctx


def _checked(ctx: moderngl.Context, backend: str) -> moderngl.Context:
    if ctx.version_code < MIN_GL_VERSION:
        version = ctx.info.get("GL_VERSION", ctx.version_code)
        ctx.release()
        package = "libosmesa6" if backend == "osmesa" else EGL_PACKAGES
        raise GLUnavailableError(f"OpenGL 3.3 or newer is needed, this context offers {version}; "
                                 f"update Mesa (Debian: apt install {package}) or the GPU driver")
    return ctx


_BACKENDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # each context created here -> its backend


def backend_of(ctx: moderngl.Context) -> str:
    """How ``ctx`` was created: ``egl``, ``osmesa``, ``window``, or ``unknown`` (a context made elsewhere)."""
    return _BACKENDS.get(ctx, "unknown")


def release_context(ctx: moderngl.Context) -> None:
    """Release a context this process created, and leave no EGL context current on this thread.

    moderngl's release leaves the thread bound to EGL; libglvnd then refuses to make a GLX
    context current on it (BadAccess), so a window opened after a headless render (``dvr view
    --tolerance E``, whose check renders before the window opens) would fail."""
    backend = _BACKENDS.get(ctx)
    ctx.release()
    if backend == "osmesa":  # releasing the OSMesa context unbound it; EGL was never used
        return
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
        "backend": backend_of(ctx),
        "max_3d_texture_size": limits.texture_3d_size,
        "max_texture_size": limits.texture_size,
    }
