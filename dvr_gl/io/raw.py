"""Raw voxel files: dims, dtype, endianness and header size given explicitly.

``.gz`` / ``.bz2`` suffixes are decompressed first; the header bytes are
skipped in the decompressed stream.  The file must hold exactly the header
bytes and ``nx * ny * nz`` samples: anything else means a wrong dims or dtype.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_input_path, current
from .common import RawArray, promised_bytes
from .compression import encoding_from_suffix, read_data, split_parts

DTYPES = {
    "uint8": "u1", "int8": "i1", "uint16": "u2", "int16": "i2",
    "uint32": "u4", "int32": "i4", "float32": "f4", "float64": "f8",
}
ENDIANS = {"little": "<", "big": ">"}


def parse_dtype(dtype: str, endian: str, name: str) -> np.dtype:
    if dtype not in DTYPES:
        raise VolumeError(f"{name}: unknown dtype {dtype!r}; use one of {', '.join(DTYPES)}")
    if endian not in ENDIANS:
        raise VolumeError(f"{name}: unknown endian {endian!r}; use 'little' or 'big'")
    return np.dtype(ENDIANS[endian] + DTYPES[dtype])


@dataclass(frozen=True)
class RawLayout:
    """Where a file's voxels lie, for reading them in part (:mod:`dvr_gl.out_of_core`) rather than whole.

    ``path``: the file holding the voxels (a detached header's data file); ``offset``: bytes before the
    first voxel; ``dims = (nx, ny, nz)``; ``dtype``: as stored (its byte order included), x fastest;
    spacing, origin, direction: what the header states (None: not stated).  ``refusal``: None when the
    voxels can be read in part, else why not and what to do (a compressed or ASCII encoding)."""

    path: Path
    offset: int
    dims: tuple[int, int, int]
    dtype: np.dtype
    spacing: tuple | None = None
    origin: tuple | None = None
    direction: tuple | None = None
    refusal: str | None = None


def stored_layout(path: Path, offset: int, dims, dtype: np.dtype, name: str, promise: str, what: str = "data file",
                  **geometry) -> RawLayout:
    """The layout of uncompressed voxels in one file, its size checked as :func:`.compression.read_data`
    checks it (exactly ``offset + nbytes`` bytes; ``offset`` -1: the voxels are the file's last bytes);
    a file split into parts is refused (it cannot be read in part): join the parts."""
    path = Path(path)
    if not current().allows(path):  # before its folder is listed for parts
        check_input_path(path, what)
    if not os.path.lexists(path) and split_parts(path):
        return RawLayout(path, 0, dims, dtype, refusal=f"{name}: its {what} is split into parts ({path.name}.part1, "
                         f"...), which are not read in part; join them (cat {path.name}.part* > {path.name})")
    if not os.path.lexists(path):
        raise VolumeError(f"{name}: its {what} {path} was not found; put it next to the header or fix its name")
    check_input_path(path, what)
    nbytes = promised_bytes(dims, dtype)
    stored = path.stat().st_size
    offset = stored - nbytes if offset < 0 else offset
    if offset < 0 or stored != offset + nbytes:
        raise VolumeError(f"{name}: the {what} holds {stored} bytes, but {promise} needs {nbytes} bytes after "
                          f"{max(offset, 0)}; the data file is truncated or the header is wrong")
    return RawLayout(path, int(offset), tuple(int(d) for d in dims), dtype, **geometry)


def raw_layout(path: Path, dims, dtype: str | None, endian: str = "little", header_bytes: int = 0) -> RawLayout:
    """Where the voxels of a raw file lie (:class:`RawLayout`), checked as :func:`read_raw` checks them."""
    name = str(path)
    dt = _check_layout(name, dims, dtype, endian, header_bytes)
    if encoding_from_suffix(Path(path)) != "raw":
        return RawLayout(Path(path), 0, tuple(dims), dt, refusal=f"{name}: compressed raw data cannot be read in "
                         f"part; decompress it (e.g. gunzip) or convert it to zarr")
    nx, ny, nz = (int(d) for d in dims)
    return stored_layout(path, int(header_bytes), dims, dt, name, f"{nx}x{ny}x{nz} {dtype} (dims, dtype and "
                         f"header_bytes)")


def read_raw(path: Path, dims, dtype: str | None, endian: str = "little", header_bytes: int = 0) -> RawArray:
    """Read ``dims = (nx, ny, nz)`` samples of ``dtype`` after ``header_bytes`` bytes."""
    name = str(path)
    dt = _check_layout(name, dims, dtype, endian, header_bytes)
    nx, ny, nz = (int(d) for d in dims)
    blob = read_data(Path(path), promised_bytes(dims, dt), name=name, encoding=encoding_from_suffix(Path(path)),
                     skip=int(header_bytes), promise=f"{nx}x{ny}x{nz} {dtype} (dims, dtype and header_bytes)")
    return RawArray(np.frombuffer(blob, dtype=dt).reshape(nz, ny, nx))


def _check_layout(name: str, dims, dtype, endian, header_bytes) -> np.dtype:
    if dims is None or dtype is None:
        raise VolumeError(f"{name}: a raw file needs dims and dtype (scene keys volume.dims, volume.dtype; "
                          f"or --dims NX NY NZ --dtype TYPE)")
    if not (isinstance(dims, (list, tuple)) and len(dims) == 3
            and all(isinstance(d, (int, np.integer)) and not isinstance(d, bool) and d >= 1 for d in dims)):
        raise VolumeError(f"{name}: dims must be three positive integers (nx, ny, nz), got {list(dims)}")
    if not isinstance(header_bytes, (int, np.integer)) or header_bytes < 0:
        raise VolumeError(f"{name}: header_bytes must be an integer >= 0, got {header_bytes}")
    return parse_dtype(dtype, endian, name)
