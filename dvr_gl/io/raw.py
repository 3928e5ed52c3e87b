"""Raw voxel files: dims, dtype, endianness and header size given explicitly.

``.gz`` / ``.bz2`` suffixes are decompressed first; the header bytes are
skipped in the decompressed stream.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .compression import read_bytes
from .common import RawArray

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


def read_raw(path: Path, dims, dtype: str | None, endian: str = "little", header_bytes: int = 0) -> RawArray:
    """Read ``dims = (nx, ny, nz)`` samples of ``dtype`` after ``header_bytes`` bytes."""
    name = str(path)
    if dims is None or dtype is None:
        raise VolumeError(f"{name}: a raw file needs dims and dtype (scene keys volume.dims, volume.dtype; "
                          f"or --dims NX NY NZ --dtype TYPE)")
    dims = tuple(int(d) for d in dims)
    if len(dims) != 3 or min(dims) < 1:
        raise VolumeError(f"{name}: dims must be three positive integers (nx, ny, nz), got {list(dims)}")
    if header_bytes < 0:
        raise VolumeError(f"{name}: header_bytes must be >= 0, got {header_bytes}")
    dt = parse_dtype(dtype, endian, name)
    blob = read_bytes(Path(path))
    expected = int(np.prod(dims, dtype=np.int64)) * dt.itemsize
    available = len(blob) - header_bytes
    if available != expected:
        nx, ny, nz = dims
        raise VolumeError(f"{name}: holds {available} bytes after the {header_bytes}-byte header, but "
                          f"{nx}x{ny}x{nz} {dtype} needs {expected}; check dims, dtype and header_bytes")
    data = np.frombuffer(blob, dtype=dt, count=expected // dt.itemsize, offset=header_bytes)
    nx, ny, nz = dims
    return RawArray(data.reshape(nz, ny, nx))
