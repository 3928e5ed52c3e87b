"""TIFF stacks through OpenImageIO: a multi-page TIFF, a folder of slices, or a glob.

Each page (or file, in natural sort order) is one z slice; all must have the
same size and one channel.  Every file is checked (a FIFO named ``x.tif`` is refused)
and each page's size counts against the memory budget before it is read.  TIFF resolution tags rarely hold the voxel
spacing, so spacing defaults to 1 and is set in the scene (``volume.spacing``).
"""

from __future__ import annotations

import glob
import re
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path
from .common import RawArray


def _natural_key(p: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


def stack_files(path: Path) -> list[Path]:
    """The slice files that ``path`` names: itself, the TIFFs in a folder, or a glob's matches."""
    text = str(path)
    if any(c in text for c in "*?["):
        files = [Path(p) for p in glob.glob(text)]
    elif path.is_dir():
        files = [p for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff")]
    else:
        files = [path]
    if not files:
        raise VolumeError(f"{path}: no TIFF files found (nor DICOM files, which are found by content)")
    return [check_input_path(f, "TIFF file") for f in sorted(files, key=_natural_key)]


def _read_pages(path: Path, budget: list[int]) -> list[np.ndarray]:
    """The pages of one file; ``budget[0]`` counts the bytes of all pages read so far."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise VolumeError(f"{path}: cannot open as TIFF ({oiio.geterror().strip()})")
    pages = []
    try:
        sub = 0
        while inp.seek_subimage(sub, 0):
            spec = inp.spec()
            if spec.nchannels != 1:
                raise VolumeError(f"{path}: page {sub} has {spec.nchannels} channels; "
                                  f"a volume slice needs 1 (grey)")
            budget[0] += spec.image_bytes()
            check_bytes(budget[0], f"{path}: the TIFF pages up to page {sub}",
                        "read fewer slices, or raise the memory budget")
            pixels = inp.read_image(sub, 0, 0, 1, oiio.UNKNOWN)
            if pixels is None:
                raise VolumeError(f"{path}: page {sub} is truncated or corrupt ({inp.geterror().strip()})")
            pages.append(np.asarray(pixels).reshape(spec.height, spec.width))
            sub += 1
    finally:
        inp.close()
    return pages


def read_tiff_stack(path: Path) -> RawArray:
    path = Path(path)
    slices: list[np.ndarray] = []
    budget = [0]
    for f in stack_files(path):
        slices.extend(_read_pages(f, budget))
    shapes = {s.shape for s in slices}
    if len(shapes) != 1:
        raise VolumeError(f"{path}: slices differ in size {sorted(shapes)}; all slices must match")
    types = {s.dtype for s in slices}
    if len(types) != 1:
        raise VolumeError(f"{path}: slices differ in pixel type {sorted(map(str, types))}")
    return RawArray(np.stack(slices, axis=0))
