"""MetaImage (``.mhd`` with a data file, ``.mha`` with the data after the header), read directly.

SimpleITK, the obvious library, was tried and rejected: version 2.5.7 trusts the
header's ``CompressedDataSize``, and where that is short of the real stream (it is
in ``shared/data/large/frogtissue.mhd``: 260020 of 262087 bytes) it returns about a
million uninitialized voxels, different on every read, without any error.  This
reader decompresses the whole zlib stream and checks that it holds exactly the
voxels the header promises.  Only the voxel grid, spacing and origin are used; a
``TransformMatrix`` other than the identity is not applied.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .common import RawArray
from .compression import decompress, read_stored_bytes

ELEMENT_TYPES = {
    "MET_UCHAR": "u1", "MET_CHAR": "i1", "MET_USHORT": "u2", "MET_SHORT": "i2", "MET_UINT": "u4",
    "MET_INT": "i4", "MET_ULONG": "u4", "MET_LONG": "i4", "MET_ULONG_LONG": "u8", "MET_LONG_LONG": "i8",
    "MET_FLOAT": "f4", "MET_DOUBLE": "f8",
}


def _parse_header(blob: bytes, name: str) -> tuple[dict, int]:
    """Header fields and the offset just after the ``ElementDataFile`` line."""
    fields: dict[str, str] = {}
    pos = 0
    while pos < len(blob):
        end = blob.find(b"\n", pos)
        end = len(blob) if end < 0 else end
        line = blob[pos:end].decode("latin-1").strip()
        pos = end + 1
        if not line:
            continue
        key, sep, value = line.partition("=")
        if not sep:
            raise VolumeError(f"{name}: header line {line[:40]!r} is not 'Key = Value'")
        fields[key.strip()] = value.strip()
        if key.strip() == "ElementDataFile":
            return fields, pos
    raise VolumeError(f"{name}: no ElementDataFile line; not a MetaImage header or truncated")


def _numbers(fields: dict, key: str, name: str, count: int, kind=float):
    try:
        values = [kind(v) for v in fields[key].split()]
    except (KeyError, ValueError):
        raise VolumeError(f"{name}: missing or malformed {key}") from None
    if len(values) != count:
        raise VolumeError(f"{name}: {key} has {len(values)} values, expected {count}")
    return tuple(values)


def read_metaimage(path: Path) -> RawArray:
    path = Path(path)
    name = str(path)
    blob = path.read_bytes()
    fields, data_start = _parse_header(blob, name)
    ndims = int(fields.get("NDims", "0") or 0)
    if ndims != 3:
        raise VolumeError(f"{name}: NDims = {ndims}; a volume needs 3")
    if int(fields.get("ElementNumberOfChannels", "1")) != 1:
        raise VolumeError(f"{name}: ElementNumberOfChannels = {fields['ElementNumberOfChannels']}; a volume needs 1")
    dims = _numbers(fields, "DimSize", name, 3, int)
    etype = fields.get("ElementType", "")
    if etype not in ELEMENT_TYPES:
        raise VolumeError(f"{name}: unsupported ElementType {etype!r}")
    msb = fields.get("BinaryDataByteOrderMSB", fields.get("ElementByteOrderMSB", "False")).lower() == "true"
    dtype = np.dtype((">" if msb else "<") + ELEMENT_TYPES[etype])
    spacing = _numbers(fields, "ElementSpacing" if "ElementSpacing" in fields else "ElementSize", name, 3) \
        if ("ElementSpacing" in fields or "ElementSize" in fields) else None
    origin_key = next((k for k in ("Offset", "Origin", "Position") if k in fields), None)
    origin = _numbers(fields, origin_key, name, 3) if origin_key else None

    datafile = fields["ElementDataFile"]
    if datafile.upper() == "LOCAL":
        stored = blob[data_start:]
    elif datafile.upper().startswith("LIST") or "%" in datafile:
        raise VolumeError(f"{name}: multi-file MetaImage ({datafile}) is not supported; join the slices first")
    else:
        stored = read_stored_bytes(path.parent / datafile)
    compressed = fields.get("CompressedData", "False").lower() == "true"
    data = decompress(stored, "zlib" if compressed else "raw", name)
    header = int(fields.get("HeaderSize", "0"))
    need = int(np.prod(dims, dtype=np.int64)) * dtype.itemsize
    if header == -1:  # the data is the last `need` bytes
        header = max(len(data) - need, 0)
    if len(data) - header != need:
        nx, ny, nz = dims
        raise VolumeError(f"{name}: data holds {len(data) - header} bytes, but {nx}x{ny}x{nz} {etype} needs "
                          f"{need}; the data file is truncated or the header is wrong")
    nx, ny, nz = dims
    array = np.frombuffer(data, dtype=dtype, count=need // dtype.itemsize, offset=header).reshape(nz, ny, nx)
    return RawArray(array, spacing, origin)
