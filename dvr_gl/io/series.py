"""A time series as a glob of 3D volume files: ``volume.path = "run/step_*.nrrd"``, one file a step.

How a glob is told from a glob of slices: by its files' suffix.  A glob whose every match has the suffix
of a format that holds a whole 3D volume in one file (NRRD, NIfTI, MetaImage, legacy VTK, ``.npy``,
``.vti``, zarr; raw with ``volume.dims``), all the same format, is a time series; a glob of TIFF files
stays a stack of slices (each file's pages the next z slices) and one of DICOM files a series of slices,
as before.  The steps are the matches in natural order (``step_2`` before ``step_10``); ``volume.time = k``
reads file ``k`` alone, through that format's reader with the table's other keys (a chosen channel too),
so a series larger than memory plays one step at a time.  The steps need not share a grid: each is read
as its file states it.
"""

from __future__ import annotations

import glob
import os
import re
from pathlib import Path

from ..errors import VolumeError
from ..sandbox import check_input_path
from .channels import MAX_COUNT, Axes

#: The formats of which one file holds a whole 3D volume: a glob of them is a time series.
VOLUME_FORMATS = ("raw", "nrrd", "nifti", "metaimage", "vtk", "npy", "vti", "zarr")


def natural_key(p: Path):
    """Sort key: the digits in a name compared as numbers (``s2`` before ``s10``)."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


def is_pattern(path) -> bool:
    """Whether a path is read as a glob: it holds ``*``, ``?`` or ``[`` and names nothing itself.  A file
    (or folder) named ``scan[1].nrrd`` is that file, never the glob that would match ``scan1.nrrd``."""
    text = str(path)
    return any(c in text for c in "*?[") and not os.path.lexists(text)


def check_matches(path) -> None:
    """Refuse a glob that matches no file, naming it: else the readers of globs of slices would say
    that no TIFF (or DICOM) files were found, about a path the user may have meant as a file name."""
    if is_pattern(path) and not _matches(path):
        raise VolumeError(f"{path}: no such file, and read as a glob pattern it matches no file; "
                          f"check the name (or the pattern)")


def series_format(path, suffix_format) -> str | None:
    """The format of a glob's files when they make a time series (see the module doc), else None.
    ``suffix_format(path)`` is the format a file's suffix names (None: no known suffix)."""
    if not is_pattern(path):
        return None
    found = {suffix_format(Path(p)) for p in _matches(path)}
    if len(found) == 1 and (fmt := found.pop()) in VOLUME_FORMATS:
        return fmt
    return None


def _matches(path) -> list[str]:
    return glob.glob(str(path))


def series_files(path) -> list[Path]:
    """The steps of a series glob, in natural order, each checked against the sandbox; a glob of more than
    :data:`MAX_COUNT` files is refused before any is checked."""
    files = [Path(p) for p in _matches(path)]
    if not files:
        raise VolumeError(f"{path}: no files match; give a glob of the series' files (e.g. 'run/step_*.nrrd')")
    if len(files) > MAX_COUNT:
        raise VolumeError(f"{path}: matches {len(files)} files, over {MAX_COUNT} time steps; narrow the glob")
    return sorted(files, key=natural_key)


def series_axes(path) -> Axes:
    return Axes(steps=len(series_files(path)))


def step_file(path, time) -> Path:
    """The file of step ``time`` (default 0) of a series glob, checked (a FIFO, a file outside the roots)."""
    files = series_files(path)
    step = 0 if time is None else int(time)
    if not 0 <= step < len(files):
        raise VolumeError(f"{path}: volume.time = {time} is past the end; the glob matches {len(files)} files "
                          f"(time steps 0 to {len(files) - 1})")
    chosen = files[step]
    if not chosen.is_dir():  # a zarr store is a folder: its reader checks its every file
        check_input_path(chosen, "volume file")
    return chosen
