"""Legacy VTK ``STRUCTURED_POINTS`` files (ASCII or BINARY), read directly.

No well-kept small library reads this dataset type: meshio reads only
unstructured legacy files and the VTK wheel is hundreds of MB, so this is a
short parser for the frozen legacy format (header lines, then one SCALARS
array; binary data is big-endian by definition of the format).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .common import RawArray

VTK_TYPES = {
    "bit": None, "unsigned_char": "u1", "char": "i1", "unsigned_short": "u2", "short": "i2",
    "unsigned_int": "u4", "int": "i4", "unsigned_long": "u8", "long": "i8", "float": "f4",
    "double": "f8", "vtktypeint64": "i8", "vtktypeuint64": "u8",
}


def _header_lines(blob: bytes):
    """Yield (stripped line, offset just after it) for each non-empty line."""
    pos = 0
    while pos < len(blob):
        end = blob.find(b"\n", pos)
        if end < 0:
            end = len(blob)
        line = blob[pos:end].decode("latin-1").strip()
        pos = end + 1
        if line:
            yield line, pos


def read_vtk_structured_points(path: Path) -> RawArray:
    path = Path(path)
    name = str(path)
    blob = path.read_bytes()
    lines = _header_lines(blob)
    try:
        magic, _ = next(lines)
        _title, _ = next(lines)
        mode, _ = next(lines)
    except StopIteration:
        raise VolumeError(f"{name}: truncated legacy VTK header") from None
    if not magic.startswith("# vtk DataFile"):
        raise VolumeError(f"{name}: not a legacy VTK file (first line {magic[:40]!r})")
    mode = mode.upper()
    if mode not in ("ASCII", "BINARY"):
        raise VolumeError(f"{name}: expected ASCII or BINARY on line 3, got {mode[:20]!r}")
    dims = spacing = origin = None
    scalar_type = None
    ncomp = 1
    data_offset = None
    for line, after in lines:
        fields = line.split()
        key = fields[0].upper()
        if key == "DATASET" and (len(fields) < 2 or fields[1].upper() != "STRUCTURED_POINTS"):
            raise VolumeError(f"{name}: dataset {' '.join(fields[1:])} is not STRUCTURED_POINTS; "
                              f"only regular grids are volumes")
        elif key == "DIMENSIONS":
            dims = tuple(int(v) for v in fields[1:4])
        elif key in ("SPACING", "ASPECT_RATIO"):
            spacing = tuple(float(v) for v in fields[1:4])
        elif key == "ORIGIN":
            origin = tuple(float(v) for v in fields[1:4])
        elif key == "SCALARS":
            scalar_type = fields[2].lower() if len(fields) > 2 else None
            ncomp = int(fields[3]) if len(fields) > 3 else 1
        elif key == "LOOKUP_TABLE" and scalar_type is not None:
            data_offset = after
            break
    if dims is None or scalar_type is None or data_offset is None:
        raise VolumeError(f"{name}: no DIMENSIONS or no SCALARS/LOOKUP_TABLE point data in the header")
    code = VTK_TYPES.get(scalar_type)
    if code is None:
        raise VolumeError(f"{name}: unsupported VTK scalar type {scalar_type!r}")
    if ncomp != 1:
        raise VolumeError(f"{name}: SCALARS has {ncomp} components; a volume needs 1")
    count = int(np.prod(dims, dtype=np.int64))
    if mode == "BINARY":
        dt = np.dtype(">" + code)
        if len(blob) - data_offset < count * dt.itemsize:
            raise VolumeError(f"{name}: binary data is truncated: {len(blob) - data_offset} bytes for "
                              f"{count} values of {scalar_type}")
        data = np.frombuffer(blob, dtype=dt, count=count, offset=data_offset)
    else:
        values = blob[data_offset:].split()
        if len(values) < count:
            raise VolumeError(f"{name}: ASCII data is truncated: {len(values)} of {count} values")
        data = np.array(values[:count], dtype=np.float64).astype(np.dtype(code))
    nx, ny, nz = dims
    return RawArray(data.reshape(nz, ny, nx), spacing, origin)
