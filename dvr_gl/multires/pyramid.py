"""Pyramids: the levels of a volume in memory (:func:`build_levels`) and on disk as an OME-Zarr image
(:func:`write_pyramid`, NGFF 0.4), each level one halving of the last (:mod:`.downsample`).

The store is written level by level in z-slabs one chunk thick, tiled in y and x so that the fine block
a tile reads stays under :data:`BLOCK_BYTES` (float64): memory stays bounded whatever the volume's
size.  Level 0 is read from the source through ``read(lo, dims)`` (an in-memory
:class:`~dvr_gl.fields.grid.Volume` and a volume read out of core alike); each coarser level is read
back from the level just written.  The store is built under a temporary name beside ``out_path`` and
renamed at the end, so a failure leaves nothing behind and nothing is ever overwritten.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..errors import VolumeError, install_hint
from ..fields.grid import IDENTITY, Volume
from .downsample import TENT, Kernel, downsample, downsample_block, fine_span, level_geometry, to_type

#: build_levels stops at a level whose largest side is at most this many samples.
COARSEST_SIDE = 32
#: The float64 bytes of the fine block one output tile reads (bounds the memory a write takes).
BLOCK_BYTES = 64 * 2 ** 20
#: NGFF 0.4's space units (UDUNITS-2 names), for ``unit``.
SPACE_UNITS = ("angstrom", "attometer", "centimeter", "decimeter", "exameter", "femtometer", "foot", "gigameter",
               "hectometer", "inch", "kilometer", "megameter", "meter", "micrometer", "mile", "millimeter",
               "nanometer", "parsec", "petameter", "picometer", "terameter", "yard", "yoctometer", "yottameter",
               "zeptometer", "zettameter")


def level_plan(dims, spacing, origin, levels: int | None = None, kernel: Kernel = TENT) -> list[tuple]:
    """``(dims, spacing, origin, halved)`` of each level, level 0 first: ``levels`` of them, or until a
    level's largest side is at most :data:`COARSEST_SIDE` (or no axis can be halved).  A count the
    grid cannot reach is refused."""
    plan = [(tuple(dims), tuple(spacing), tuple(origin), (False, False, False))]
    if levels is not None and (isinstance(levels, bool) or int(levels) != levels or levels < 1):
        raise VolumeError(f"the level count must be a whole number of at least 1 (1: full resolution only), "
                          f"got {levels}")
    while (len(plan) < levels) if levels is not None else max(plan[-1][0]) > COARSEST_SIDE:
        step = level_geometry(*plan[-1][:3], kernel)
        if not any(step[3]):
            if levels is None:
                break
            raise VolumeError(f"a grid of {_dims(dims)} samples has at most {len(plan)} levels (an axis needs 3 "
                              f"samples to be halved); ask for {len(plan)} or fewer")
        plan.append(step)
    return plan


def build_levels(volume, count: int | None = None, kernel: Kernel = TENT) -> tuple[Volume, ...]:
    """The coarser levels of an in-memory ``volume``, fine to coarse (level 0, the volume, not
    included): ``count`` of them, or until a level's largest side is at most :data:`COARSEST_SIDE`.
    ``volume.with_levels(build_levels(volume))`` attaches them."""
    total = None if count is None else count + 1
    if count is not None and (isinstance(count, bool) or int(count) != count or count < 0):
        raise VolumeError(f"the count of coarser levels must be a whole number of at least 0, got {count}")
    plan = level_plan(volume.dims, volume.spacing, volume.origin, total, kernel)
    levels, level = [], volume
    for _ in plan[1:]:
        level = downsample(level, kernel)
        levels.append(level)
    return tuple(levels)


def write_pyramid(source, out_path, levels: int | None = None, chunks: int = 64, unit: str | None = None,
                  kernel: Kernel = TENT) -> list[tuple]:
    """Write ``source`` (a volume with ``read(lo, dims)``, or a path any dvr reader opens) to ``out_path``
    as an OME-Zarr image (NGFF 0.4): ``levels`` levels in all (level 0 the full resolution; default:
    until the largest side is at most :data:`COARSEST_SIDE`), chunks of ``chunks`` samples a side,
    axes ``z, y, x`` in ``unit`` (an NGFF space unit such as ``millimeter``; none if not given).  Each
    level's ``scale`` is its spacing and its ``translation`` its origin (the position of its sample 0,
    as :mod:`dvr_gl.io.zarr` reads it).  Returns the plan (:func:`level_plan`)."""
    zarr = _zarr()
    out_path = Path(os.path.expanduser(str(out_path)))
    if os.path.lexists(out_path):
        raise VolumeError(f"{out_path}: already exists; choose a new name for the pyramid (it is never overwritten)")
    if not out_path.parent.is_dir():
        raise VolumeError(f"{out_path.parent}: no such folder for the pyramid; create it first")
    if isinstance(chunks, bool) or int(chunks) != chunks or not 4 <= chunks <= 1024:
        raise VolumeError(f"the chunk size must be a whole number of samples from 4 to 1024, got {chunks}")
    if unit is not None and unit not in SPACE_UNITS:
        raise VolumeError(f"unit {unit!r} is not an OME-Zarr space unit; use one of {', '.join(SPACE_UNITS)}")
    volume = open_source(source)
    plan = level_plan(volume.dims, volume.spacing, volume.origin, levels, kernel)
    work = Path(tempfile.mkdtemp(prefix=f".{out_path.name}.", suffix=".partial", dir=out_path.parent))
    try:
        store = work / "image.zarr"
        group = _open_group(zarr, store)
        reader = volume
        for index, (dims, spacing, origin, halved) in enumerate(plan):
            array = _create(group, str(index), dims, volume.dtype, int(chunks))
            _write_level(reader, array, dims, halved, kernel)
            reader = _ArrayReader(array)
        group.attrs["multiscales"] = [_multiscale(volume, plan, unit, kernel)]
        if os.path.lexists(out_path):  # appeared while we wrote
            raise VolumeError(f"{out_path}: appeared while the pyramid was written; it was left alone")
        os.rename(store, out_path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return plan


def open_source(source, **options):
    """A volume to read from: ``source`` itself when it has ``read``, an array as a volume, else the file
    opened by :func:`dvr_gl.out_of_core.open_volume` with ``out_of_core="auto"``: read block by block where
    its voxels exceed the memory budget and the format can be read in part (raw, NRRD with raw encoding,
    MetaImage, zarr), else loaded whole.  ``options``: the reader's (``dims``, ``dtype``, ``level`` ...)."""
    if hasattr(source, "read") and hasattr(source, "dims"):
        return source
    if isinstance(source, np.ndarray):
        return Volume(source)
    from ..out_of_core import open_volume

    # no sidecar of block ranges beside the input: dvr pyramid writes nothing but its output
    return open_volume(source, out_of_core="auto", sidecar=False,
                       **{k: v for k, v in options.items() if v is not None})


class _ArrayReader:
    """``read(lo, dims)`` over a ``[z, y, x]`` zarr array (the level just written)."""

    def __init__(self, array):
        self.array = array

    def read(self, lo, dims) -> np.ndarray:
        (x0, y0, z0), (nx, ny, nz) = lo, dims
        return np.asarray(self.array[z0:z0 + nz, y0:y0 + ny, x0:x0 + nx])


def _write_level(reader, array, dims, halved, kernel):
    """Fill ``array`` (``dims``, x y z) from ``reader``'s finer level (``halved`` axes; none: a copy)."""
    nz, ny, nx = array.shape
    cz, cy, cx = array.chunks
    fine = _fine_dims(reader)
    # tiles of whole chunks in y and x, as many as keep the float64 fine block under BLOCK_BYTES
    rows = (2 * cz + 4) if halved[2] else cz
    side = math.sqrt(BLOCK_BYTES / 8 / rows)  # fine samples along y and x
    per_tile = max(1, int((side - 4) / (2 if any(halved[:2]) else 1)) // max(cy, cx))
    ty, tx = min(ny, cy * per_tile), min(nx, cx * per_tile)
    for z0 in range(0, nz, cz):
        for y0 in range(0, ny, ty):
            for x0 in range(0, nx, tx):
                out_lo = (x0, y0, z0)
                out_dims = (min(tx, nx - x0), min(ty, ny - y0), min(cz, nz - z0))
                if not any(halved):
                    block = reader.read(out_lo, out_dims)
                else:
                    spans = [fine_span(a, a + d, n, kernel) if h else (a, a + d)
                             for a, d, n, h in zip(out_lo, out_dims, fine, halved)]
                    lo = tuple(a for a, _ in spans)
                    data = reader.read(lo, tuple(b - a for a, b in spans))
                    block = to_type(downsample_block(data, lo, fine, out_lo, out_dims, halved, kernel), array.dtype)
                array[z0:z0 + out_dims[2], y0:y0 + out_dims[1], x0:x0 + out_dims[0]] = block


def _fine_dims(reader):
    if isinstance(reader, _ArrayReader):
        nz, ny, nx = reader.array.shape
        return (nx, ny, nz)
    return tuple(reader.dims)


def _multiscale(volume, plan, unit, kernel) -> dict:
    axes = [{"name": a, "type": "space", **({"unit": unit} if unit else {})} for a in ("z", "y", "x")]
    datasets = [{"path": str(i), "coordinateTransformations": [
        {"type": "scale", "scale": [float(s) for s in spacing[::-1]]},
        {"type": "translation", "translation": [float(o) for o in origin[::-1]]}]}
        for i, (_, spacing, origin, _) in enumerate(plan)]
    metadata = {"method": "dvr_gl.multires.downsample", "kernel": kernel.name,
                "placement": "node-centred: sample i of a level at translation + i * scale; a halved axis's "
                             "coarse sample j on fine sample 2j",
                "edges": "taps beyond an edge reflected through the edge sample"}
    if tuple(map(tuple, volume.direction)) != IDENTITY:  # NGFF 0.4 has no rotation: kept for the record
        metadata["direction"] = [list(r) for r in volume.direction]
    return {"version": "0.4", "name": str(getattr(volume, "name", "volume")), "axes": axes,
            "datasets": datasets, "type": kernel.key, "metadata": metadata}


def _zarr():
    try:
        import zarr
    except ImportError:
        raise VolumeError(f"writing an OME-Zarr pyramid needs the zarr package: {install_hint('zarr')}") from None
    return zarr


def _open_group(zarr, store: Path):
    try:  # zarr 3 writes the version-2 layout NGFF 0.4 asks for when told to
        return zarr.open_group(store=str(store), mode="w-", zarr_format=2)
    except TypeError:  # zarr 2
        return zarr.open_group(store=str(store), mode="w-")


def _create(group, name, dims, dtype, chunks):
    shape = tuple(int(n) for n in dims[::-1])
    chunk_shape = tuple(min(chunks, n) for n in shape)
    if hasattr(group, "create_array"):  # zarr 3; NGFF 0.4 wants "/" between the chunk indices
        return group.create_array(name, shape=shape, chunks=chunk_shape, dtype=dtype,
                                  chunk_key_encoding={"name": "v2", "separator": "/"})
    return group.create_dataset(name, shape=shape, chunks=chunk_shape, dtype=dtype, dimension_separator="/")


def _dims(dims) -> str:
    return "x".join(str(int(n)) for n in dims)
