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
vtk        ``.vtk`` UNSTRUCTURED_GRID (a mesh)    meshio (extra ``mesh``)
vtu        ``.vtu`` (a mesh)                      meshio (extra ``mesh``)
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

FORMATS = ("raw", "nrrd", "nifti", "metaimage", "vtk", "npy", "tiff", "vtu", "plot3d", "csv", "npz", "hdf5")
PARTICLE_FORMATS = ("csv", "npz", "hdf5")
GRID_FORMATS = FORMATS[:7]

_SUFFIXES = {
    ".nrrd": "nrrd", ".nhdr": "nrrd", ".nii": "nifti", ".nii.gz": "nifti", ".mhd": "metaimage",
    ".mha": "metaimage", ".vtk": "vtk", ".npy": "npy", ".tif": "tiff", ".tiff": "tiff",
    ".vtu": "vtu", ".xyz": "plot3d", ".csv": "csv", ".npz": "npz", ".h5": "hdf5", ".hdf5": "hdf5",
    ".raw": "raw", ".raw.gz": "raw", ".raw.bz2": "raw", ".bin": "raw", ".dat": "raw", ".den": "raw",
}


def detect_format(path: Path) -> str:
    """The format a path's suffix (or being a folder or glob) names."""
    name = path.name.lower()
    if path.is_dir() or any(c in str(path) for c in "*?["):
        return "tiff"
    for suffix in sorted(_SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return _SUFFIXES[suffix]
    raise VolumeError(f"{path}: cannot tell the format from the suffix; set volume.format to one of "
                      f"{', '.join(FORMATS)}")


# format -> (module, reader function); modules load on first use
_READERS = {
    "raw": (".raw", "read_raw"), "nrrd": (".nrrd", "read_nrrd"), "nifti": (".nifti", "read_nifti"),
    "metaimage": (".metaimage", "read_metaimage"), "vtk": (".vtk_legacy", "read_vtk_structured_points"),
    "npy": (".npy", "read_npy"), "tiff": (".tiff", "read_tiff_stack"),
}


def _read(path: Path, fmt: str, raw_options: dict) -> RawArray:
    if fmt in ("vtu", "plot3d") or fmt in PARTICLE_FORMATS:
        kind = "a mesh" if fmt in ("vtu", "plot3d") else "SPH particles"
        raise VolumeError(f"{path}: a {fmt} file holds {kind}, not a regular grid; read it with load_field")
    if fmt not in _READERS:
        raise VolumeError(f"{path}: unknown format {fmt!r}; use one of {', '.join(FORMATS)} or auto")
    module, function = _READERS[fmt]
    reader = getattr(importlib.import_module(module, __name__), function)
    if fmt == "raw":
        return reader(path, **raw_options)
    if raw_options.get("dims") is not None or raw_options.get("dtype") is not None:
        raise VolumeError(f"{path}: dims and dtype apply to raw files only; this is {fmt}")
    return reader(path)


def load_field(path, format: str = "auto", *, array: str | None = None, solution=None, **grid_options):
    """Load a grid (:func:`load_volume`, with ``grid_options``) or a mesh (``.vtu``, a legacy ``.vtk``
    UNSTRUCTURED_GRID, PLOT3D): ``array`` names a mesh's scalar array, ``solution`` a PLOT3D q file."""
    from . import mesh

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
            if value is not None:
                raise VolumeError(f"{path}: volume.{key} applies to meshes (.vtu, unstructured .vtk, PLOT3D); "
                                  "this is a regular grid: remove it")
        return load_volume(path, format, **grid_options)
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
                header_bytes: int = 0, spacing=None, origin=None, nan_value: float | None = None) -> Volume:
    """Load a volume file.

    Args:
        path: the file (for TIFF stacks also a folder or a glob pattern).
        format: one of :data:`FORMATS`, or ``auto`` to choose by suffix.
        dims, dtype, endian, header_bytes: the layout of a raw file, ``dims = (nx, ny, nz)``.
        spacing, origin: override what the file states (world units, x first; spacing finite, > 0).
        nan_value: replace NaN and Inf by this value; without it they are an error.
    """
    path = Path(os.path.expanduser(str(path)))
    is_pattern = any(c in str(path) for c in "*?[")
    if not is_pattern and not path.is_dir() and not exists_or_split(path):
        raise VolumeError(f"{path}: file not found")
    if not is_pattern and os.path.lexists(path) and not path.is_dir():
        check_input_path(path, "volume file")  # before its suffix is judged: a FIFO, a path outside the roots
    fmt = detect_format(path) if format == "auto" else format
    options = {"dims": dims, "dtype": dtype}
    if fmt == "raw":
        options.update(endian=endian, header_bytes=header_bytes)
    if spacing is not None:
        spacing = check_spacing(spacing, str(path), "spacing (volume.spacing)")
    # Libraries warn about headers they repair, numpy about values it casts: the readers'
    # own checks say what matters in one line, and nothing else may reach the terminal.
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        raw = _read(path, fmt, options)
        data = raw.data
        if nan_value is not None:
            data = replace_non_finite(data, float(nan_value))
        return Volume(
            data,
            spacing=spacing if spacing is not None else (raw.spacing or (1.0, 1.0, 1.0)),
            origin=origin if origin is not None else (raw.origin or (0.0, 0.0, 0.0)),
            name=path.name,
            direction=raw.direction,
        )
