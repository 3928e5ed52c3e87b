"""Print versions, the volume readers, the registered renderers (what each renders and reads), and
what the OpenGL context offers; with a FILE (or a folder, a glob, several DICOM files), what the data
holds: its channels (names) and time steps, dims, type, spacing, origin, orientation, the value range, a
histogram and a transfer function to start from (each channel's)."""

from __future__ import annotations

import importlib
import platform
from pathlib import Path

from dvr_gl import __version__
from dvr_gl.errors import install_hint
from dvr_gl.gl.context import chosen_backend, create_context, gl_info, release_context
from dvr_gl.gl.selftest import selftest
from dvr_gl.renderers import registry

HELP = "show versions, readers, renderers and the OpenGL context; or a data file's facts (dvr info FILE)"

READERS = [("NRRD", "nrrd", "pynrrd", "nrrd"), ("NIfTI", "nibabel", "nibabel", "nifti"),
           ("DICOM", "pydicom", "pydicom", "dicom"), ("zarr", "zarr", "zarr", "zarr"),
           ("meshes", "meshio", "meshio", "mesh"), ("HDF5 SPH", "h5py", "h5py", "particles")]


def add_arguments(p):
    p.add_argument("file", nargs="*", metavar="FILE",
                   help="a volume, mesh or particle file, a folder of slices or a glob (several files: a DICOM "
                        "series); without it: versions, readers, renderers, OpenGL")
    v = p.add_argument_group("file options (as dvr render's)")
    file_options(v, "reader (default: by suffix, a folder by its files)", "meshes, particles, .vti, zarr: the array")
    v.add_argument("--series", metavar="N|UID", help="DICOM: the series, when a folder holds several")
    v.add_argument("--level", type=int, metavar="L", help="OME-Zarr: the resolution level (0: full)")


def file_options(group, format_help: str, array_help: str):
    """The options that say how to read a volume file (``dvr info``, ``dvr pyramid``): reader, raw layout,
    array; defaults as the readers take them (``dvr render`` has its own, as scene-key overrides)."""
    group.add_argument("--format", help=format_help)
    group.add_argument("--dims", type=int, nargs=3, metavar=("NX", "NY", "NZ"), help="raw files")
    group.add_argument("--dtype", help="raw files: the sample type")
    group.add_argument("--endian", choices=("little", "big"), default="little", help="raw files")
    group.add_argument("--header-bytes", type=int, default=0, help="raw files")
    group.add_argument("--array", metavar="NAME", help=array_help)


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
    if getattr(args, "file", None):
        return file_info(args)
    print(f"dvr-gl {__version__}, Python {platform.python_version()}")
    for module in ("numpy", "moderngl", "OpenImageIO", "glfw"):
        print(f"  {module:12s} {_version(module) or 'missing'}")
    print("volume readers: raw, npy, MetaImage, VTK structured points, TIFF stacks (OpenImageIO), PLOT3D, SPH "
          "particle tables (CSV, npz) built in;")
    for fmt, module, package, extra in READERS:
        v = _version(module)
        print(f"  {fmt:10s} {(package + ' ' + v) if v else f'not available: {install_hint(extra)}'}")
    print("renderers (plugins in the entry-point group dvr_gl.renderers):")
    for line in renderer_lines():
        print("  " + line)
    chosen = chosen_backend()  # before creating: an automatic fall back to OSMesa sets DVR_GL_BACKEND
    ctx = create_context()
    try:
        gl = gl_info(ctx)
        how = "automatic: EGL, else OSMesa" if chosen == "auto" else f"DVR_GL_BACKEND={chosen}"
        print(f"OpenGL backend:  {gl['backend']} ({how}; dvr --gl-backend or DVR_GL_BACKEND chooses)")
        print(f"OpenGL vendor:   {gl['vendor']}")
        print(f"OpenGL renderer: {gl['renderer']}")
        print(f"OpenGL version:  {gl['version']}")
        print(f"max 3D texture size: {gl['max_3d_texture_size']}")
        print(f"max 2D texture size: {gl['max_texture_size']}")
        problem = selftest(ctx)
        print("GL self-test (shaders, float32 target, read-back): " + (f"FAILED: {problem}" if problem else "ok"))
    finally:
        release_context(ctx)
    return 1 if problem else 0


def file_info(args) -> int:
    """``dvr info FILE``: the data's facts (:func:`dvr_gl.io.summary.summary_lines`)."""
    from dvr_gl.fields.layers import FieldSet
    from dvr_gl.io import file_axes, load_field
    from dvr_gl.io.summary import summary_lines

    files = args.file
    source = files if len(files) > 1 else files[0]
    options = dict(array=args.array, dims=args.dims, dtype=args.dtype, endian=args.endian,
                   header_bytes=args.header_bytes, level=args.level)
    field = None
    if len(files) == 1 and args.series is None:  # a volume over renderer.memory_budget_mb's default: out of core
        field = open_for_info(source, args.format or "auto", options)
    if field is None:
        field = load_field(source, args.format or "auto", series=args.series, **options)
    shown = " ".join(_quoted(f) for f in files)
    axes = file_axes(source, args.format or "auto", array=args.array, level=args.level) if len(files) == 1 else None
    for line in axes_lines(axes, shown):
        print(line)
    if not isinstance(field, FieldSet):
        for line in summary_lines(field, shown):
            print(line)
        return 0
    for k, member in enumerate(field.members):  # each channel's facts, its suggestion for it alone
        print(f"channel {k} ({member.name}):")
        for line in summary_lines(member.field, f"{shown} --channel {k}"):
            print("  " + line)
    return 0


def axes_lines(axes, shown: str) -> list[str]:
    """What a file holds beyond its three space axes (:class:`dvr_gl.io.channels.Axes`): its channels with
    their names, and its time steps with their interval; nothing for a file of one 3D field."""
    if axes is None:
        return []
    lines = []
    if axes.channels:
        names = ", ".join(axes.names) if axes.names else "unnamed"
        lines.append(f"channels: {axes.channels} ({names}); each a field composited per sample "
                     f"(dvr render {shown} --channel K renders channel K alone)")
    if axes.steps > 1:
        every = f", every {axes.interval:g} s" if axes.interval else ""
        lines.append(f"time steps: {axes.steps}{every}; the facts below are step 0's (dvr render {shown} --time K "
                     f"renders step K; --animate time every step)")
    return lines


def open_for_info(path, fmt: str, options: dict):
    """The volume at ``path`` as ``dvr render`` opens it where its format can be read in part: out of core
    when larger than renderer.memory_budget_mb's default, else in memory; None: another format."""
    from dvr_gl.errors import DvrError
    from dvr_gl.io import PARTIAL_FORMATS, detect_format
    from dvr_gl.out_of_core import MEMORY_BUDGET_MB, open_volume

    try:
        partial = (detect_format(Path(path)) if fmt == "auto" else fmt) in PARTIAL_FORMATS
    except DvrError:
        return None
    if not partial:
        return None
    return open_volume(path, "auto", MEMORY_BUDGET_MB, fmt, **options)


def _quoted(text: str) -> str:
    import shlex

    return shlex.quote(str(text))
