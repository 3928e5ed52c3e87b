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
from ..sandbox import check_input_path
from .common import RawArray, check_spacing, integer, integers, numbers, parse_ascii, promised_bytes, show
from .compression import read_data, read_text

VTK_TYPES = {
    "bit": None, "unsigned_char": "u1", "char": "i1", "unsigned_short": "u2", "short": "i2",
    "unsigned_int": "u4", "int": "i4", "unsigned_long": "u8", "long": "i8", "float": "f4",
    "double": "f8", "vtktypeint64": "i8", "vtktypeuint64": "u8",
}


MAX_HEADER = 1 << 20  # bytes: a header longer than this is not a header


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


def _parse(lines, name: str) -> dict:
    """The header's DIMENSIONS, SPACING, ORIGIN, POINT_DATA and SCALARS, and where the data starts."""
    found: dict = {"spacing": None, "origin": None}
    section = None  # POINT_DATA or CELL_DATA: which the attributes that follow belong to
    for line, after in lines:
        key, _, rest = line.partition(" ")
        key = key.upper()
        if key == "DATASET" and rest.strip().upper() != "STRUCTURED_POINTS":
            raise VolumeError(f"{name}: DATASET {show(rest)} is not STRUCTURED_POINTS; only regular grids "
                              f"are volumes")
        elif key == "DIMENSIONS":
            found["dims"] = integers(rest, name, "DIMENSIONS", 3, minimum=1)
        elif key in ("SPACING", "ASPECT_RATIO"):
            found["spacing"] = check_spacing(numbers(rest, name, key, 3), name, key)
        elif key == "ORIGIN":
            found["origin"] = numbers(rest, name, "ORIGIN", 3)
        elif key == "POINT_DATA":
            found["count"] = integer(rest, name, "POINT_DATA", minimum=1)
            section = key
        elif key == "CELL_DATA":
            section = key
        elif key == "SCALARS" and section == "CELL_DATA":  # read as point data, it was the wrong values
            raise VolumeError(f"{name}: its first SCALARS are cell data (after CELL_DATA); a volume needs point "
                              f"data: write the POINT_DATA section first, or convert the cell data to point data")
        elif key == "SCALARS":
            words = rest.split()
            if len(words) not in (2, 3):
                raise VolumeError(f"{name}: SCALARS {show(rest)} must be 'SCALARS name type [components]'")
            found["type"] = words[1].lower()
            found["components"] = integer(words[2], name, "SCALARS components") if len(words) == 3 else 1
        elif key == "LOOKUP_TABLE" and "type" in found:
            found["offset"] = after
            return found
    raise VolumeError(f"{name}: no DIMENSIONS or no SCALARS/LOOKUP_TABLE point data in the header")


def read_vtk_structured_points(path: Path) -> RawArray:
    path = check_input_path(Path(path), "VTK file")
    name = str(path)
    with open(path, "rb") as fh:
        lines = _header_lines(fh.read(MAX_HEADER))
    try:
        magic, _ = next(lines)
        _title, _ = next(lines)
        mode, _ = next(lines)
    except StopIteration:
        raise VolumeError(f"{name}: truncated legacy VTK header (it needs a version, a title and "
                          f"ASCII or BINARY)") from None
    if not magic.startswith("# vtk DataFile"):
        raise VolumeError(f"{name}: not a legacy VTK file (first line {show(magic)})")
    mode = mode.upper()
    if mode not in ("ASCII", "BINARY"):
        raise VolumeError(f"{name}: expected ASCII or BINARY on line 3, got {show(mode)}")
    found = _parse(lines, name)
    if "dims" not in found:
        raise VolumeError(f"{name}: no DIMENSIONS line before the point data")
    nx, ny, nz = dims = found["dims"]
    count = nx * ny * nz
    if found.get("count", count) != count:
        raise VolumeError(f"{name}: POINT_DATA {found['count']} does not match DIMENSIONS {nx} {ny} {nz} "
                          f"({count} points); fix the header")
    code = VTK_TYPES.get(found["type"])
    if code is None:
        raise VolumeError(f"{name}: SCALARS type {show(found['type'])} is not supported; use one of "
                          f"{', '.join(t for t, c in VTK_TYPES.items() if c)}")
    if found["components"] != 1:
        raise VolumeError(f"{name}: SCALARS has {found['components']} components; a volume needs 1")
    dt = np.dtype(">" + code)  # binary legacy VTK is big-endian by definition
    if mode == "BINARY":
        blob = read_data(path, promised_bytes(dims, dt), name=name, start=found["offset"], exact=False,
                         what="VTK file", promise=f"DIMENSIONS {nx} {ny} {nz} of {found['type']}")
        data = np.frombuffer(blob, dtype=dt)
    else:
        data = parse_ascii(read_text(path, name, found["offset"], 0, count), count, dt, name, "point data")
    return RawArray(data.reshape(nz, ny, nx), found["spacing"], found["origin"])
