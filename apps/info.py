"""Print versions, the volume readers available, and what the OpenGL context offers."""

from __future__ import annotations

import importlib
import platform

from dvr_gl import __version__
from dvr_gl.gl.context import create_context, gl_info
from dvr_gl.gl.selftest import selftest
from dvr_gl.renderers import RENDERERS, renderer_class

HELP = "show versions, volume readers, renderers and the OpenGL context"

READERS = [("NRRD", "nrrd", "pynrrd", "nrrd"), ("NIfTI", "nibabel", "nibabel", "nifti")]


def add_arguments(p):
    pass


def _version(module: str) -> str | None:
    try:
        m = importlib.import_module(module)
    except ImportError:
        return None
    return getattr(m, "__version__", None) or getattr(m, "VERSION_STRING", None) or "installed"


def run(args) -> int:
    print(f"dvr-gl {__version__}, Python {platform.python_version()}")
    for module in ("numpy", "moderngl", "OpenImageIO", "glfw"):
        print(f"  {module:12s} {_version(module) or 'missing'}")
    print("volume readers: raw, npy, MetaImage, VTK structured points, TIFF stacks (OpenImageIO) built in;")
    for fmt, module, package, extra in READERS:
        v = _version(module)
        print(f"  {fmt:10s} {(package + ' ' + v) if v else f'not available: pip install dvr-gl[{extra}]'}")
    print("renderers: " + ", ".join(f"{n} ({renderer_class(n).description})" for n in RENDERERS))
    ctx = create_context()
    try:
        gl = gl_info(ctx)
        print(f"OpenGL vendor:   {gl['vendor']}")
        print(f"OpenGL renderer: {gl['renderer']}")
        print(f"OpenGL version:  {gl['version']}")
        print(f"max 3D texture size: {gl['max_3d_texture_size']}")
        print(f"max 2D texture size: {gl['max_texture_size']}")
        problem = selftest(ctx)
        print("GL self-test (shaders, float32 target, read-back): " + (f"FAILED: {problem}" if problem else "ok"))
    finally:
        ctx.release()
    return 1 if problem else 0
