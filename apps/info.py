"""Print versions, the volume readers, the registered renderers (what each renders and reads), and
what the OpenGL context offers."""

from __future__ import annotations

import importlib
import platform

from dvr_gl import __version__
from dvr_gl.gl.context import create_context, gl_info
from dvr_gl.gl.selftest import selftest
from dvr_gl.renderers import registry

HELP = "show versions, volume readers, renderers and the OpenGL context"

READERS = [("NRRD", "nrrd", "pynrrd", "nrrd"), ("NIfTI", "nibabel", "nibabel", "nifti"),
           ("meshes", "meshio", "meshio", "mesh"), ("HDF5 SPH", "h5py", "h5py", "particles")]


def add_arguments(p):
    pass


def renderer_lines() -> list[str]:
    """Each registered renderer: what it renders, the choices it supports, the settings it reads."""
    lines = []
    for name, p in registry.plugins().items():
        kinds = "any field" if p.data_kinds is None else ", ".join(p.data_kinds)
        traits = [kinds, "OpenGL" if p.needs_gl else "CPU"] + (["fixed voxel planes"] if p.fixed_planes else [])
        lines.append(f"{name}: {p.description} [{'; '.join(traits)}]")
        for key in ("compositing", "classification", "filter"):
            lines.append(f"    {key}: {', '.join(map(str, p.choices(key)))}")
        own = [s.name for s in p.settings if s.name not in ("compositing", "classification", "filter")]
        lines.append(f"    settings: {', '.join(own)}")
    for name, reason in registry.broken().items():
        lines.append(f"{name}: NOT AVAILABLE: {reason}")
    return lines


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
    print("volume readers: raw, npy, MetaImage, VTK structured points, TIFF stacks (OpenImageIO), PLOT3D, SPH "
          "particle tables (CSV, npz) built in;")
    for fmt, module, package, extra in READERS:
        v = _version(module)
        print(f"  {fmt:10s} {(package + ' ' + v) if v else f'not available: pip install dvr-gl[{extra}]'}")
    print("renderers (plugins in the entry-point group dvr_gl.renderers):")
    for line in renderer_lines():
        print("  " + line)
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
