"""Raw voxel files: dims, dtype, endianness and header size given explicitly.

``.gz`` / ``.bz2`` suffixes are decompressed first; the header bytes are
skipped in the decompressed stream.  The file must hold exactly the header
bytes and ``nx * ny * nz`` samples: anything else means a wrong dims or dtype.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .common import RawArray, promised_bytes
from .compression import encoding_from_suffix, read_data

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
    if not (isinstance(dims, (list, tuple)) and len(dims) == 3
            and all(isinstance(d, (int, np.integer)) and not isinstance(d, bool) and d >= 1 for d in dims)):
        raise VolumeError(f"{name}: dims must be three positive integers (nx, ny, nz), got {list(dims)}")
    if not isinstance(header_bytes, (int, np.integer)) or header_bytes < 0:
        raise VolumeError(f"{name}: header_bytes must be an integer >= 0, got {header_bytes}")
    dt = parse_dtype(dtype, endian, name)
    nx, ny, nz = (int(d) for d in dims)
    blob = read_data(Path(path), promised_bytes(dims, dt), name=name, encoding=encoding_from_suffix(Path(path)),
                     skip=int(header_bytes), promise=f"{nx}x{ny}x{nz} {dtype} (dims, dtype and header_bytes)")
    return RawArray(np.frombuffer(blob, dtype=dt).reshape(nz, ny, nx))
