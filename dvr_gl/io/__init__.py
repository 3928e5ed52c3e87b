"""Volume readers: one entry point, :func:`load_volume`, choosing the reader by format.

=========  ====================================  ==========================
format     files                                 read with
=========  ====================================  ==========================
raw        any (dims, dtype, endian, header)     numpy (+ gzip/bz2 by suffix)
nrrd       ``.nrrd``, ``.nhdr``                   built-in fields, pynrrd vectors
nifti      ``.nii``, ``.nii.gz``                  nibabel (extra ``nifti``)
metaimage  ``.mhd``, ``.mha``                     built-in reader (see its module)
vtk        ``.vtk`` STRUCTURED_POINTS             built-in parser
npy        ``.npy``                               numpy
tiff       ``.tif`` pages, a folder, a glob;      OpenImageIO
           ImageJ and OME-TIFF hyperstacks
dicom      a folder, a list of files, a glob      pydicom (extra ``dicom``)
vti        ``.vti`` VTK XML image data            built-in reader (see its module)
zarr       ``.zarr``, OME-Zarr (a chosen level)   zarr (extra ``zarr``)
(series)   a glob of 3D files, one a time step    the files' format (:mod:`.series`)
vtk        ``.vtk`` UNSTRUCTURED_GRID (a mesh)    built-in strict reader (:mod:`.mesh_vtk`)
vtu        ``.vtu`` (a mesh)                      built-in strict reader (:mod:`.mesh_vtk`)
plot3d     ``.xyz`` grid + ``q`` solution (mesh)   built-in reader
csv        ``.csv`` SPH particle table            built-in reader (csv module)
npz        ``.npz`` SPH particle arrays           numpy
hdf5       ``.h5``, ``.hdf5`` GADGET/SWIFT        h5py (extra ``particles``)
=========  ====================================  ==========================

:func:`load_field` reads any of them (a grid as a :class:`Volume`, a mesh as a
:class:`~dvr_gl.fields.mesh.TetMesh`: :mod:`.mesh`; particles as a
:class:`~dvr_gl.fields.particles.ParticleSet`: :mod:`.particles`); :func:`load_volume` only grids.

Channels and time steps (:mod:`.channels`): a file with channels read with no ``channel`` chosen gives a
:class:`~dvr_gl.fields.layers.FieldSet` of scalar members, one a channel; ``channel=k`` that channel's
:class:`Volume`; ``time=k`` reads step ``k`` alone (default 0); :func:`time_steps` says how many steps a
file holds, unread.

Readers are strict: a malformed header or data file is one :class:`VolumeError` naming
the file, the field as the format writes it and what is valid.  They are bounded:
every file goes through :func:`dvr_gl.sandbox.check_input_path`, and the bytes a header
promises are checked against the memory budget (and the file's size) before anything
is allocated or decompressed (see :mod:`.compression`).
"""

from __future__ import annotations

import importlib
import os
import warnings
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..fields.grid import Volume, replace_non_finite
from ..sandbox import check_input_path, check_path_name
from .channels import Axes, RawChannels, pick_step
from .common import RawArray, check_spacing
from .compression import exists_or_split
from .series import VOLUME_FORMATS, check_matches, is_pattern, series_axes, series_format, step_file

FORMATS = ("raw", "nrrd", "nifti", "metaimage", "vtk", "npy", "tiff", "dicom", "vti", "zarr", "vtu", "plot3d", "csv",
           "npz", "hdf5")
PARTICLE_FORMATS = ("csv", "npz", "hdf5")
GRID_FORMATS = FORMATS[:10]

_SUFFIXES = {
    ".nrrd": "nrrd", ".nhdr": "nrrd", ".nii": "nifti", ".nii.gz": "nifti", ".mhd": "metaimage",
    ".mha": "metaimage", ".vtk": "vtk", ".npy": "npy", ".tif": "tiff", ".tiff": "tiff",
    ".vtu": "vtu", ".vti": "vti", ".dcm": "dicom", ".zarr": "zarr", ".xyz": "plot3d", ".csv": "csv", ".npz": "npz",
    ".h5": "hdf5", ".hdf5": "hdf5",
    ".raw": "raw", ".raw.gz": "raw", ".raw.bz2": "raw", ".bin": "raw", ".dat": "raw", ".den": "raw",
}


def detect_format(path) -> str:
    """The format a path's suffix names; a glob of 3D volume files (all of one format, not TIFF or DICOM)
    their format, read as a time series (:mod:`.series`); another folder or glob by its files' content
    (DICOM, else TIFF slices), a folder holding zarr metadata as zarr; a list of files is a DICOM series."""
    if isinstance(path, (list, tuple)):
        return "dicom"
    path = check_path_name(path, "volume file")
    name = path.name.lower()
    if path.is_dir() and (name.endswith(".zarr") or any((path / m).is_file() for m in ZARR_METADATA)):
        return "zarr"
    series = series_format(path, _suffix_format)
    if series is not None:
        return series
    if path.is_dir() or is_pattern(path):
        from .dicom import folder_holds_dicom

        return "dicom" if folder_holds_dicom(path) else "tiff"
    fmt = _suffix_format(path)
    if fmt is not None:
        return fmt
    raise VolumeError(f"{path}: cannot tell the format from the suffix; set volume.format to one of "
                      f"{', '.join(FORMATS)}")


def _suffix_format(path: Path) -> str | None:
    """The format a file's suffix names, None for none known."""
    name = path.name.lower()
    for suffix in sorted(_SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return _SUFFIXES[suffix]
    return None


# format -> (module, reader function); modules load on first use
_READERS = {
    "raw": (".raw", "read_raw"), "nrrd": (".nrrd", "read_nrrd"), "nifti": (".nifti", "read_nifti"),
    "metaimage": (".metaimage", "read_metaimage"), "vtk": (".vtk_legacy", "read_vtk_structured_points"),
    "npy": (".npy", "read_npy"), "tiff": (".tiff", "read_tiff_stack"), "dicom": (".dicom", "read_dicom_series"),
    "vti": (".vti", "read_vti"), "zarr": (".zarr", "read_zarr"),
}
ZARR_METADATA = ("zarr.json", ".zarray", ".zgroup")
# the options a reader takes beyond the path (the scene's volume.<key>)
_OPTIONS = {"dicom": ("series",), "vti": ("array",), "zarr": ("array", "level", "channel", "time"),
            "tiff": ("channel", "time", "color"), "nifti": ("channel", "time", "fourth_axis", "color"),
            "nrrd": ("color",), "npy": ("color",)}
# format -> (module, function) telling a file's channels and time steps without reading its voxels
_AXES = {"tiff": (".tiff", "tiff_axes"), "zarr": (".zarr", "zarr_axes"), "nifti": (".nifti", "nifti_axes")}


# format -> (module, function) telling where the voxels lie without reading them (dvr_gl.out_of_core)
_LAYOUTS = {"raw": (".raw", "raw_layout"), "nrrd": (".nrrd", "nrrd_layout"),
            "metaimage": (".metaimage", "metaimage_layout"), "zarr": (".zarr", "zarr_layout")}
#: The formats whose voxels can be read in part (raw encodings; zarr by chunks).
PARTIAL_FORMATS = tuple(_LAYOUTS)


def voxel_layout(path: Path, fmt: str, raw_options: dict):
    """Where a grid file's voxels lie, unread, for :mod:`dvr_gl.out_of_core`: a :class:`.raw.RawLayout` (raw,
    NRRD, MetaImage; its ``refusal`` says why one cannot be read in part) or the chosen zarr array with its
    axes, transforms, name and coarser levels (:func:`.zarr.open_zarr`); the options as :func:`load_volume`
    checks them."""
    if fmt in _READERS and fmt not in _LAYOUTS:
        raise VolumeError(f"{path}: {fmt} files are read whole, not in part; convert the volume to raw, NRRD (raw "
                          f"encoding) or zarr to read it out of core")
    return _read(path, fmt, raw_options, _LAYOUTS)


def _read(path: Path, fmt: str, raw_options: dict, readers: dict = _READERS) -> RawArray:
    if fmt in ("vtu", "plot3d") or fmt in PARTICLE_FORMATS:
        kind = "a mesh" if fmt in ("vtu", "plot3d") else "SPH particles"
        raise VolumeError(f"{path}: a {fmt} file holds {kind}, not a regular grid; read it with load_field")
    if fmt not in _READERS:
        raise VolumeError(f"{path}: unknown format {fmt!r}; use one of {', '.join(FORMATS)} or auto")
    module, function = readers[fmt]
    reader = getattr(importlib.import_module(module, __name__), function)
    layout = ("dims", "dtype", "endian", "header_bytes")
    chosen = {k: v for k, v in raw_options.items() if k not in layout and v is not None}
    if "time" in chosen and "time" not in _OPTIONS.get(fmt, ()):
        pick_step(chosen.pop("time"), Axes(), str(path))  # a file without time is one step: 0 reads it
    if fmt == "raw" and not chosen:
        return reader(path, **{k: v for k, v in raw_options.items() if k in layout})
    if fmt != "raw" and (raw_options.get("dims") is not None or raw_options.get("dtype") is not None):
        raise VolumeError(f"{path}: dims and dtype apply to raw files only; this is {fmt}")
    for key in chosen:
        if key not in _OPTIONS.get(fmt, ()):
            users = ", ".join(f for f, keys in _OPTIONS.items() if key in keys)
            if key == "color":  # volume.role = "rgb" (dvr_gl.fields.color)
                raise VolumeError(f"{path}: volume.role = rgb: colour volumes are read from {users} files; this "
                                  f"{fmt} file holds scalars: give the field role scalar or label")
            if key in ("channel", "time"):
                what = "channels" if key == "channel" else "time steps"
                raise VolumeError(f"{path}: volume.{key}: this {fmt} file has no {what}"
                                  + (f" ({users} files may)" if users else "") + ": remove it")
            raise VolumeError(f"{path}: volume.{key} applies to {users}; this is {fmt}: remove it")
    return reader(path, **chosen)


def load_field(path, format: str = "auto", *, array: str | None = None, solution=None, **grid_options):
    """Load a grid (:func:`load_volume`, with ``grid_options``) or a mesh (``.vtu``, a legacy ``.vtk``
    UNSTRUCTURED_GRID, PLOT3D): ``array`` names a mesh's scalar array, ``solution`` a PLOT3D q file."""
    from . import mesh

    if isinstance(path, (list, tuple)):  # the files of a DICOM series
        return load_volume(path, format, array=array, **grid_options)
    path = check_path_name(os.path.expanduser(str(path)), "volume file")
    try:
        fmt = detect_format(path) if format == "auto" else format
    except VolumeError:  # no known suffix: the grid reader's checks (the sandbox's first) say what is wrong
        return load_volume(path, format, **grid_options)
    if fmt in PARTICLE_FORMATS:
        return _load_particles(path, fmt, array, solution, grid_options)
    if fmt == "vtk" and os.path.lexists(path):
        check_input_path(path, "volume file")  # before its header is read: a FIFO, a path outside the roots
    is_mesh = fmt in ("vtu", "plot3d") or (fmt == "vtk" and path.is_file() and mesh.is_legacy_unstructured(path))
    if not is_mesh:
        for key, value in (("array", array), ("solution", solution)):
            if value is not None and not (key == "array" and fmt in ("vti", "zarr")):
                raise VolumeError(f"{path}: volume.{key} applies to meshes (.vtu, unstructured .vtk, PLOT3D), "
                                  ".vti and zarr; this is a regular grid: remove it")
        return load_volume(path, format, array=array, **grid_options)
    if not path.exists():
        raise VolumeError(f"{path}: file not found")
    given = [k for k, v in grid_options.items() if v is not None and k not in ("endian", "header_bytes")]
    if given:
        raise VolumeError(f"{path}: volume.{given[0]} applies to regular grids; a mesh's points are its geometry: "
                          "remove it")
    if solution is not None and fmt != "plot3d":
        raise VolumeError(f"{path}: volume.solution applies to PLOT3D grids; remove it")
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        if fmt == "plot3d":
            return mesh.read_plot3d(path, None if solution is None else Path(os.path.expanduser(str(solution))),
                                    array)
        return mesh.read_mesh(path, array)


def _load_particles(path: Path, fmt: str, array, solution, grid_options):
    from .particles import read_particles

    if not os.path.lexists(path):
        raise VolumeError(f"{path}: file not found")
    given = [k for k, v in grid_options.items() if v is not None and k not in ("endian", "header_bytes")]
    if given or solution is not None:
        key = given[0] if given else "solution"
        raise VolumeError(f"{path}: volume.{key} does not apply to SPH particles (their positions are their "
                          "geometry): remove it")
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        return read_particles(path, fmt, array)


def load_volume(path, format: str = "auto", *, dims=None, dtype=None, endian: str = "little",
                header_bytes: int = 0, spacing=None, origin=None, nan_value: float | None = None,
                array: str | None = None, series: str | None = None, level: int | None = None,
                channel: int | None = None, time: int | None = None, fourth_axis: str | None = None,
                role: str | None = None):
    """Load a volume file.

    Args:
        path: the file (for TIFF stacks and DICOM series also a folder or a glob pattern; a list of
            files is a DICOM series).
        format: one of :data:`FORMATS`, or ``auto`` to choose by suffix (a folder by its files' content).
        dims, dtype, endian, header_bytes: the layout of a raw file, ``dims = (nx, ny, nz)``.
        spacing, origin: override what the file states (world units, x first; spacing finite, > 0).
        nan_value: replace NaN and Inf by this value; without it they are an error.
        array: ``.vti``: the point-data array (default the first); zarr: the array's path in a group.
        series: DICOM: the SeriesInstanceUID or SeriesNumber when the files hold several series.
        level: OME-Zarr: the resolution level (0, the default, is the full resolution).
        channel, time: a file with channels or time steps: the channel (default: every channel, a
            :class:`~dvr_gl.fields.layers.FieldSet`) and the step (default 0) to read (:mod:`.channels`);
            a glob of 3D volume files is a series of steps (:mod:`.series`).
        fourth_axis: NIfTI 4D: ``"auto"`` (the header's intent: channels for a vector, else time),
            ``"channel"`` or ``"time"``.
        role: ``"rgb"``: the file holds colour, a :class:`~dvr_gl.fields.color.ColorVolume` (NRRD: a first
            axis of 3 or 4 components; ``.npy``: ``[z, y, x, 3|4]``; TIFF: pages of 3 or 4 samples; NIfTI: RGB24,
            RGBA32 or a vector of 3 or 4 components); an NRRD
            whose kinds say RGB-color or RGBA-color is colour without it.  Other roles are the scene's
            (:mod:`dvr_gl.fields.layers`).

    Returns:
        a :class:`Volume`, or a :class:`~dvr_gl.fields.layers.FieldSet` for a file of several channels
        read with none chosen.
    """
    if nan_value is not None and not isinstance(nan_value, (int, float, np.integer, np.floating)):
        raise VolumeError(f"nan_value must be a number, got {nan_value!r}")
    if isinstance(path, (list, tuple)):
        return _load_series(list(path), format, spacing=spacing, origin=origin, nan_value=nan_value,
                            series=series, dims=dims, dtype=dtype, array=array, level=level, channel=channel,
                            time=time, fourth_axis=fourth_axis)
    path = check_path_name(os.path.expanduser(str(path)), "volume file")
    pattern = is_pattern(path)
    check_matches(path)
    if not pattern and not path.is_dir() and not exists_or_split(path):
        raise VolumeError(f"{path}: file not found")
    if not pattern and os.path.lexists(path) and not path.is_dir():
        check_input_path(path, "volume file")  # before its suffix is judged: a FIFO, a path outside the roots
    fmt = detect_format(path) if format == "auto" else format
    if pattern and fmt in VOLUME_FORMATS:  # a time series: step `time`'s file alone
        return load_volume(step_file(path, time), fmt, dims=dims, dtype=dtype, endian=endian,
                           header_bytes=header_bytes, spacing=spacing, origin=origin, nan_value=nan_value,
                           array=array, series=series, level=level, channel=channel, fourth_axis=fourth_axis,
                           role=role)
    options = {"dims": dims, "dtype": dtype, "array": array, "series": series, "level": level, "channel": channel,
               "time": time, "fourth_axis": fourth_axis, "color": True if role == "rgb" else None}
    if fmt == "raw":
        options.update(endian=endian, header_bytes=header_bytes)
    if spacing is not None:
        spacing = check_spacing(spacing, str(path), "spacing (volume.spacing)")
    # Libraries warn about headers they repair, numpy about values it casts: the readers'
    # own checks say what matters in one line, and nothing else may reach the terminal.
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        return _volume(_read(path, fmt, options), path.name, spacing, origin, nan_value)


def _volume(raw, name: str, spacing, origin, nan_value):
    """The reader's result as a :class:`Volume`; every channel of a :class:`.channels.RawChannels` a scalar
    member of a :class:`~dvr_gl.fields.layers.FieldSet` (one alone: a Volume)."""
    if isinstance(raw, RawChannels):
        from ..fields.layers import Member, as_data

        return as_data(Member(_volume(a, f"{name} [{n}]", spacing, origin, nan_value), "scalar", n)
                       for a, n in zip(raw.arrays, raw.names))
    data = raw.data
    if nan_value is not None:
        data = replace_non_finite(data, float(nan_value))
    if data.ndim == 4:  # colour components last (volume.role = "rgb", an NRRD of kind RGB-color)
        from ..fields.color import ColorVolume

        return ColorVolume.from_stored(data, name=name, direction=raw.direction,
                                       spacing=spacing if spacing is not None else (raw.spacing or (1.0, 1.0, 1.0)),
                                       origin=origin if origin is not None else (raw.origin or (0.0, 0.0, 0.0)))
    return Volume(
        data,
        spacing=spacing if spacing is not None else (raw.spacing or (1.0, 1.0, 1.0)),
        origin=origin if origin is not None else (raw.origin or (0.0, 0.0, 0.0)),
        name=name,
        direction=raw.direction,
    )


def file_axes(path, format: str = "auto", **options) -> Axes:
    """A grid file's channels and time steps (:class:`.channels.Axes`), its voxels unread: ``options`` as
    :func:`load_volume` takes them (those that choose the array: ``array``, ``level``, ``fourth_axis``;
    others are ignored).  A file without channels or time: ``Axes()`` (one step)."""
    if isinstance(path, (list, tuple)):
        return Axes()  # a DICOM series: one volume
    path = check_path_name(os.path.expanduser(str(path)), "volume file")
    pattern = is_pattern(path)
    check_matches(path)
    if not pattern and os.path.lexists(path) and not path.is_dir():
        check_input_path(path, "volume file")
    fmt = detect_format(path) if format == "auto" else format
    if pattern and fmt in VOLUME_FORMATS:
        return series_axes(path)
    if fmt not in _AXES:
        return Axes()
    if not pattern and not path.exists():
        raise VolumeError(f"{path}: file not found")
    module, function = _AXES[fmt]
    describe = getattr(importlib.import_module(module, __name__), function)
    chosen = {k: v for k, v in options.items() if v is not None and k in _OPTIONS[fmt] and k not in ("channel",
                                                                                                      "time")}
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        return describe(path, **chosen)


def time_steps(path, format: str = "auto", **options) -> tuple[int, float | None]:
    """How many time steps a grid file holds and the seconds between them (None: not stated), its voxels
    unread: 1 for a file without time (a 3D file is a series of one step).  For the animation of time
    (``dvr render --animate time``) and the viewer's player; ``options`` as :func:`file_axes` takes them."""
    axes = file_axes(path, format, **options)
    return axes.steps, axes.interval


def _load_series(files: list, format: str, *, spacing, origin, nan_value, series, **others) -> Volume:
    """A DICOM series given as a list of files."""
    from .dicom import read_dicom_series

    if format not in ("auto", "dicom"):
        raise VolumeError(f"a list of files is read as a DICOM series; format {format!r} takes one path")
    if others.get("time") is not None:
        pick_step(others.pop("time"), Axes(), "a DICOM series")  # one volume: step 0 alone
    given = [k for k, v in others.items() if v is not None]
    if given:
        raise VolumeError(f"volume.{given[0]} does not apply to a DICOM series: remove it")
    if not files:
        raise VolumeError("an empty list of files; give the files of a DICOM series")
    files = [Path(os.path.expanduser(str(f))) for f in files]
    for f in files:
        if not f.is_file():
            raise VolumeError(f"{f}: file not found")
    if spacing is not None:
        spacing = check_spacing(spacing, str(files[0]), "spacing (volume.spacing)")
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        raw = read_dicom_series(files, series)
        return _volume(raw, f"{files[0].parent.name or files[0].name} ({len(files)} files)", spacing, origin,
                       nan_value)
