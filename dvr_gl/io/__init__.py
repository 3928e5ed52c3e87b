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
tiff       ``.tif`` pages, a folder, a glob       OpenImageIO
dicom      a folder, a list of files, a glob      pydicom (extra ``dicom``)
vti        ``.vti`` VTK XML image data            built-in reader (see its module)
zarr       ``.zarr``, OME-Zarr (a chosen level)   zarr (extra ``zarr``)
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
from ..sandbox import check_input_path
from .common import RawArray, check_spacing
from .compression import exists_or_split

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
    """The format a path's suffix names; a folder or a glob by its files' content (DICOM, else TIFF
    slices), a folder holding zarr metadata as zarr; a list of files is a DICOM series."""
    if isinstance(path, (list, tuple)):
        return "dicom"
    path = Path(path)
    name = path.name.lower()
    if path.is_dir() and (name.endswith(".zarr") or any((path / m).is_file() for m in ZARR_METADATA)):
        return "zarr"
    if path.is_dir() or any(c in str(path) for c in "*?["):
        from .dicom import folder_holds_dicom

        return "dicom" if folder_holds_dicom(path) else "tiff"
    for suffix in sorted(_SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return _SUFFIXES[suffix]
    raise VolumeError(f"{path}: cannot tell the format from the suffix; set volume.format to one of "
                      f"{', '.join(FORMATS)}")


# format -> (module, reader function); modules load on first use
_READERS = {
    "raw": (".raw", "read_raw"), "nrrd": (".nrrd", "read_nrrd"), "nifti": (".nifti", "read_nifti"),
    "metaimage": (".metaimage", "read_metaimage"), "vtk": (".vtk_legacy", "read_vtk_structured_points"),
    "npy": (".npy", "read_npy"), "tiff": (".tiff", "read_tiff_stack"), "dicom": (".dicom", "read_dicom_series"),
    "vti": (".vti", "read_vti"), "zarr": (".zarr", "read_zarr"),
}
ZARR_METADATA = ("zarr.json", ".zarray", ".zgroup")
# the options a reader takes beyond the path (the scene's volume.<key>)
_OPTIONS = {"dicom": ("series",), "vti": ("array",), "zarr": ("array", "level")}


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
    if fmt == "raw" and not chosen:
        return reader(path, **{k: v for k, v in raw_options.items() if k in layout})
    if fmt != "raw" and (raw_options.get("dims") is not None or raw_options.get("dtype") is not None):
        raise VolumeError(f"{path}: dims and dtype apply to raw files only; this is {fmt}")
    for key in chosen:
        if key not in _OPTIONS.get(fmt, ()):
            users = ", ".join(f for f, keys in _OPTIONS.items() if key in keys)
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
    path = Path(os.path.expanduser(str(path)))
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
                channel: int | None = None, time: int | None = None) -> Volume:
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
            :class:`~dvr_gl.fields.layers.FieldSet`) and the step (default 0) to read.
    """
    if isinstance(path, (list, tuple)):
        return _load_series(list(path), format, spacing=spacing, origin=origin, nan_value=nan_value,
                            series=series, dims=dims, dtype=dtype, array=array, level=level, channel=channel,
                            time=time)
    path = Path(os.path.expanduser(str(path)))
    is_pattern = any(c in str(path) for c in "*?[")
    if not is_pattern and not path.is_dir() and not exists_or_split(path):
        raise VolumeError(f"{path}: file not found")
    if not is_pattern and os.path.lexists(path) and not path.is_dir():
        check_input_path(path, "volume file")  # before its suffix is judged: a FIFO, a path outside the roots
    fmt = detect_format(path) if format == "auto" else format
    options = {"dims": dims, "dtype": dtype, "array": array, "series": series, "level": level, "channel": channel,
               "time": time}
    if fmt == "raw":
        options.update(endian=endian, header_bytes=header_bytes)
    if spacing is not None:
        spacing = check_spacing(spacing, str(path), "spacing (volume.spacing)")
    # Libraries warn about headers they repair, numpy about values it casts: the readers'
    # own checks say what matters in one line, and nothing else may reach the terminal.
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        return _volume(_read(path, fmt, options), path.name, spacing, origin, nan_value)


def _volume(raw: RawArray, name: str, spacing, origin, nan_value) -> Volume:
    data = raw.data
    if nan_value is not None:
        data = replace_non_finite(data, float(nan_value))
    return Volume(
        data,
        spacing=spacing if spacing is not None else (raw.spacing or (1.0, 1.0, 1.0)),
        origin=origin if origin is not None else (raw.origin or (0.0, 0.0, 0.0)),
        name=name,
        direction=raw.direction,
    )


def _load_series(files: list, format: str, *, spacing, origin, nan_value, series, **others) -> Volume:
    """A DICOM series given as a list of files."""
    from .dicom import read_dicom_series

    if format not in ("auto", "dicom"):
        raise VolumeError(f"a list of files is read as a DICOM series; format {format!r} takes one path")
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
