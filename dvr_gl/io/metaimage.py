"""MetaImage (``.mhd`` with a data file, ``.mha`` with the data after the header), read directly.

SimpleITK, the obvious library, was tried and rejected: version 2.5.7 trusts the
header's ``CompressedDataSize``, and where that is short of the real stream (it is
in ``shared/data/large/frogtissue.mhd``: 260020 of 262087 bytes) it returns about a
million uninitialized voxels, different on every read, without any error.  This
reader decodes the zlib stream (up to one byte past the promised size, so a small
header over a huge stream fails at once) and checks that it holds exactly the
voxels the header promises.

Orientation: ``TransformMatrix`` (or its synonyms ``Rotation``, ``Orientation``) holds the
direction of each index axis in turn, x's three numbers first, as ITK's MetaImageIO reads
it (``SetDirection(axis, numbers[3*axis : 3*axis+3])``): the numbers as written fill the
direction matrix's columns.  ITK's frame is LPS, so they are kept as they are, and so is
``Offset`` (or ``Origin``, ``Position``).  ``AnatomicalOrientation`` is a label that ITK
does not apply either; it is ignored.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_input_path
from .common import RawArray, axes_geometry, check_spacing, integer, integers, numbers, promised_bytes, show
from .compression import read_data

ELEMENT_TYPES = {
    "MET_UCHAR": "u1", "MET_CHAR": "i1", "MET_USHORT": "u2", "MET_SHORT": "i2", "MET_UINT": "u4",
    "MET_INT": "i4", "MET_ULONG": "u4", "MET_LONG": "i4", "MET_ULONG_LONG": "u8", "MET_LONG_LONG": "i8",
    "MET_FLOAT": "f4", "MET_DOUBLE": "f8",
}


MAX_HEADER = 1 << 20  # bytes: a header longer than this is not a header


def _parse_header(path: Path, name: str) -> tuple[dict, int]:
    """Header fields and the offset just after the ``ElementDataFile`` line."""
    with open(path, "rb") as fh:
        blob = fh.read(MAX_HEADER)
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
            raise VolumeError(f"{name}: header line {show(line)} is not 'Key = Value'; fix the header")
        fields[key.strip()] = value.strip()
        if key.strip() == "ElementDataFile":
            return fields, min(pos, len(blob))
    raise VolumeError(f"{name}: no ElementDataFile line; not a MetaImage header, or a truncated one")


def _flag(fields: dict, key: str, name: str) -> bool:
    value = fields.get(key, "False")
    if value.lower() not in ("true", "false"):
        raise VolumeError(f"{name}: {key} = {show(value)}; use True or False")
    return value.lower() == "true"


def _first(fields: dict, *keys):
    return next((k for k in keys if k in fields), None)


def metaimage_layout(path: Path):
    """Where the voxels of a MetaImage file lie (:class:`.raw.RawLayout`), for reading them in part:
    uncompressed data only (``.mhd`` with its ``ElementDataFile``, or ``.mha``); compressed data carries a
    refusal (write it uncompressed, or convert it to zarr)."""
    from .raw import RawLayout, stored_layout

    path = check_input_path(Path(path), "MetaImage file")
    name = str(path)
    fields, data_start, dims, dtype, geometry = _header(path, name)
    datafile, local, header = _data_file(fields, name)
    if _flag(fields, "CompressedData", name):
        return RawLayout(path, 0, dims, dtype, refusal=f"{name}: compressed MetaImage data cannot be read in part; "
                         f"write it uncompressed (CompressedData = False) or convert it to zarr")
    offset = -1 if header < 0 else (data_start if local else 0) + header
    nx, ny, nz = dims
    return stored_layout(path if local else path.parent / datafile, offset, dims, dtype, name,
                         f"DimSize {nx} {ny} {nz} of {fields['ElementType']}", "MetaImage data file",
                         spacing=geometry[0], origin=geometry[1], direction=geometry[2])


def _data_file(fields: dict, name: str):
    """The data file's name, whether it is the header's own file (LOCAL) and the bytes to skip in it."""
    datafile = fields["ElementDataFile"]
    if datafile.upper().startswith("LIST") or "%" in datafile:
        raise VolumeError(f"{name}: multi-file MetaImage ({datafile}) is not supported; join the slices first")
    header = integer(fields.get("HeaderSize", "0"), name, "HeaderSize", minimum=-1)
    return datafile, datafile.upper() == "LOCAL", header


def read_metaimage(path: Path) -> RawArray:
    path = check_input_path(Path(path), "MetaImage file")
    name = str(path)
    fields, data_start, dims, dtype, (spacing, origin, direction) = _header(path, name)
    nx, ny, nz = dims
    etype = fields["ElementType"]
    datafile, local, header = _data_file(fields, name)
    blob = read_data(path if local else path.parent / datafile, promised_bytes(dims, dtype), name=name,
                     encoding="zlib" if _flag(fields, "CompressedData", name) else "raw",
                     start=data_start if local else 0, skip=header, what="MetaImage data file",
                     promise=f"DimSize {nx} {ny} {nz} of {etype}")
    return RawArray(np.frombuffer(blob, dtype=dtype).reshape(nz, ny, nx), spacing, origin, direction)


def _header(path: Path, name: str):
    """The checked header: its fields, where LOCAL data starts, dims (x, y, z), the stored sample type and
    the geometry ``(spacing, origin, direction)``."""
    fields, data_start = _parse_header(path, name)
    ndims = integer(fields.get("NDims", "missing"), name, "NDims")
    if ndims != 3:
        raise VolumeError(f"{name}: NDims = {ndims}; a volume needs 3")
    channels = integer(fields.get("ElementNumberOfChannels", "1"), name, "ElementNumberOfChannels")
    if channels != 1:
        raise VolumeError(f"{name}: ElementNumberOfChannels = {channels}; a volume needs 1")
    dims = integers(fields.get("DimSize", ""), name, "DimSize", 3, minimum=1)
    etype = fields.get("ElementType", "")
    if etype not in ELEMENT_TYPES:
        raise VolumeError(f"{name}: ElementType = {show(etype)} is not supported; use one of "
                          f"{', '.join(ELEMENT_TYPES)}")
    msb = _flag(fields, _first(fields, "BinaryDataByteOrderMSB", "ElementByteOrderMSB") or "-", name)
    dtype = np.dtype((">" if msb else "<") + ELEMENT_TYPES[etype])
    spacing_key = _first(fields, "ElementSpacing", "ElementSize")
    spacing = check_spacing(numbers(fields[spacing_key], name, spacing_key, 3), name, spacing_key) \
        if spacing_key else None
    origin_key = _first(fields, "Offset", "Origin", "Position")
    origin = numbers(fields[origin_key], name, origin_key, 3) if origin_key else None
    direction = None
    matrix_key = _first(fields, "TransformMatrix", "Rotation", "Orientation")
    if matrix_key:
        columns = numbers(fields[matrix_key], name, matrix_key, 9)
        _, direction = axes_geometry(columns, name, matrix_key)  # each axis's unit vector, x first
    return fields, data_start, dims, dtype, (spacing, origin, direction)
