"""NRRD (``.nrrd`` and detached ``.nhdr``): strict header fields, bounded data.

pynrrd parses the vector fields (``space directions``, ``space origin``): their lengths are the
spacing, their directions :attr:`Volume.direction`, turned from the header's ``space`` (RAS, LAS,
LPS; the spaces without a patient frame as they are) into LPS.  The rest is
done here, because pynrrd's header parser is lossy and its data reader is unbounded
(``tests/io/test_io.py::test_why_not_pynrrd_alone`` shows both): it truncates
``sizes: 32.5`` to 32 and casts ``sizes: 1e30`` to garbage, reads a ``line skip`` one
line at a time (``line skip: 100000000`` runs for minutes), and decompresses the whole
stream before comparing its size with the header.  Here each field must be what the
NRRD specification says, and the data comes from :func:`.compression.read_data`, which
stops at the promised size.  A detached data file split into ``.part1, .part2, ...``
(see :mod:`.compression`) is joined.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_input_path
from .common import (
    RawArray,
    axes_geometry,
    check_sample_type,
    integer,
    integers,
    numbers,
    parse_ascii,
    promised_bytes,
    require,
    show,
)
from .compression import after_lines, read_data, read_text

MAX_HEADER = 1 << 20  # bytes: a header longer than this is not a header
# The NRRD type names (teem's nrrdTypeStr and its synonyms), as numpy codes.
TYPES = {
    **dict.fromkeys(("signed char", "int8", "int8_t"), "i1"),
    **dict.fromkeys(("uchar", "unsigned char", "uint8", "uint8_t"), "u1"),
    **dict.fromkeys(("short", "short int", "signed short", "signed short int", "int16", "int16_t"), "i2"),
    **dict.fromkeys(("ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"), "u2"),
    **dict.fromkeys(("int", "signed int", "int32", "int32_t"), "i4"),
    **dict.fromkeys(("uint", "unsigned int", "uint32", "uint32_t"), "u4"),
    **dict.fromkeys(("longlong", "long long", "long long int", "signed long long", "signed long long int",
                     "int64", "int64_t"), "i8"),
    **dict.fromkeys(("ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t"), "u8"),
    "float": "f4", "double": "f8",
}
ENCODINGS = {"raw": "raw", "gzip": "gzip", "gz": "gzip", "bzip2": "bzip2", "bz2": "bzip2",
             "ascii": "ascii", "text": "ascii", "txt": "ascii"}


def read_header(path: Path) -> tuple[dict, int]:
    """The header's fields as written (``key: value``) and its length in bytes."""
    with open(path, "rb") as fh:
        head = fh.read(MAX_HEADER)
    if not (head.startswith(b"NRRD000") and head[7:8].isdigit()):
        raise VolumeError(f"{path}: not an NRRD file (the first line must be NRRD0001 to NRRD0005, got "
                          f"{show(head[:20].decode('latin-1'))})")
    fields: dict[str, str] = {}
    pos = head.find(b"\n") + 1 if b"\n" in head else len(head)
    while pos < len(head):
        end = head.find(b"\n", pos)
        if end < 0:
            if len(head) == MAX_HEADER:
                raise VolumeError(f"{path}: no blank line ends the header in its first {MAX_HEADER} bytes")
            end = len(head)  # a detached header may end without a newline
        line = head[pos:end].decode("latin-1").rstrip()
        pos = end + 1
        if not line:
            break
        field, sep, value = line.partition(":")
        if line.startswith("#") or value.startswith("="):
            continue  # comments and key:=value pairs carry nothing the renderer uses
        if not sep:
            raise VolumeError(f"{path}: header line {show(line)} is not 'field: value'; fix the header")
        if field in fields:
            raise VolumeError(f"{path}: field {field!r} appears twice; keep one")
        fields[field] = value.strip()
        if field in ("data file", "datafile") and fields[field].startswith("LIST"):
            break  # the file names follow, one a line, to the end: refused by _data_file, not misread as fields
    return fields, min(pos, len(head))


def _get(fields, *names, default=None):
    return next((fields[n] for n in names if n in fields), default)


def _required(fields, field, name) -> str:
    if field not in fields:
        raise VolumeError(f"{name}: the required field {field!r} is missing; fix the header")
    return fields[field]


def _dtype(fields, name, encoding) -> np.dtype:
    written = _required(fields, "type", name)
    if written not in TYPES:
        raise VolumeError(f"{name}: type {show(written)} is not an NRRD scalar type; use one of uint8, int8, "
                          f"uint16, int16, uint32, int32, uint64, int64, float, double")
    code = TYPES[written]
    endian = fields.get("endian")
    if endian is not None and endian not in ("little", "big"):
        raise VolumeError(f"{name}: endian {show(endian)} is neither little nor big; fix the header")
    if endian is None and code[1] != "1" and encoding != "ascii":
        raise VolumeError(f"{name}: the field 'endian' (little or big) is required for type {written}")
    return check_sample_type(np.dtype((">" if endian == "big" else "<") + code), name, "type", written)


# NRRD's colour kinds (the kinds of an axis of colour components) and how many components each has; any
# case.  3-color and 4-color say no colour space: nearly every writer means RGB(A).  HSV and XYZ are refused.
COLOUR_KINDS = {"rgb-color": 3, "rgba-color": 4, "3-color": 3, "4-color": 4}
OTHER_COLOUR_KINDS = ("hsv-color", "xyz-color")
# The kinds of a space axis: never a colour axis.
SPACE_KINDS = ("domain", "space", "time")


def _colour_axis(fields, sizes, name, color: bool) -> int | None:
    """The axis of colour components (read as a colour volume: :mod:`dvr_gl.fields.color`), or None: the axis
    whose kind is a colour kind (RGB-color, RGBA-color, 3-color, 4-color), or, when colour is asked
    (``volume.role = "rgb"``), a first axis of 3 or 4 that is not a space axis."""
    kinds = [k.lower() for k in fields.get("kinds", "").split()]
    for axis, kind in enumerate(kinds):
        if kind in OTHER_COLOUR_KINDS:
            raise VolumeError(f"{name}: kinds gives axis {axis} as {kind}; colour volumes are read as RGB(A): "
                              f"convert it to RGB (e.g. with teem's unu or 3D Slicer)")
        if kind in COLOUR_KINDS:
            if sizes[axis] != COLOUR_KINDS[kind]:
                raise VolumeError(f"{name}: kinds gives axis {axis} as {kind}, but sizes gives it {sizes[axis]} "
                                  f"components, not {COLOUR_KINDS[kind]}; fix the header")
            return axis
    if not color:
        return None
    if len(sizes) == 4 and sizes[0] in (3, 4) and (not kinds or kinds[0] not in SPACE_KINDS):
        return 0
    raise VolumeError(f"{name}: volume.role = rgb, but sizes {' '.join(map(str, sizes))} has no colour axis: "
                      f"colour is a first axis of 3 (RGB) or 4 (RGBA) components (kinds RGB-color or "
                      f"RGBA-color), then x, y, z; or give the field role scalar")


def _axes(sizes, name) -> list[int]:
    """The three axes that form the volume: all of them, or those left after dropping leading
    axes of size 1 (a one-valued "list" axis, for example)."""
    ones = next((i for i, s in enumerate(sizes) if s != 1), len(sizes))
    axes = list(range(min(ones, max(len(sizes) - 3, 0)), len(sizes)))
    if len(axes) != 3:
        colour = " (a first axis of colour components: set volume.role = rgb)" if (
            len(sizes) == 4 and sizes[0] in (3, 4)) else ""
        raise VolumeError(f"{name}: sizes {' '.join(map(str, sizes))} do not form a 3D volume; a volume "
                          f"needs dimension 3 (or extra leading axes of size 1){colour}")
    return axes


def _vectors(fields, field, name, parse):
    nrrd = require("nrrd", "pynrrd", "nrrd")
    try:
        return parse(fields[field], dtype=float)
    except (nrrd.NRRDError, ValueError, TypeError, IndexError) as exc:
        raise VolumeError(f"{name}: {field} {show(fields[field])} is not a list of vectors like "
                          f"(1,0,0) ({exc}); fix the header") from None


# NRRD's spaces (and their abbreviations) -> the signs that turn their coordinates into LPS.  The spaces
# without a patient frame (scanner-xyz, 3D-right-handed, 3D-left-handed) are taken as they are.
SPACES = {
    **dict.fromkeys(("right-anterior-superior", "ras"), (-1.0, -1.0, 1.0)),
    **dict.fromkeys(("left-anterior-superior", "las"), (1.0, -1.0, 1.0)),
    **dict.fromkeys(("left-posterior-superior", "lps"), (1.0, 1.0, 1.0)),
    **dict.fromkeys(("scanner-xyz", "3d-right-handed", "3d-left-handed"), (1.0, 1.0, 1.0)),
}


def _space_signs(fields, name) -> np.ndarray:
    """The signs that turn the header's space coordinates into LPS."""
    if "space" in fields:
        space = fields["space"].lower()
        if space not in SPACES:
            raise VolumeError(f"{name}: space {show(fields['space'])} is not a 3D NRRD space; use "
                              f"right-anterior-superior (RAS), left-anterior-superior (LAS), "
                              f"left-posterior-superior (LPS), scanner-xyz or 3D-right-handed")
        return np.array(SPACES[space])
    if "space dimension" in fields and integer(fields["space dimension"], name, "space dimension") != 3:
        raise VolumeError(f"{name}: space dimension {fields['space dimension']}; a volume needs 3")
    return np.ones(3)


def _geometry(fields, name, dim, axes):
    """Spacing and direction of the three axes: from ``space directions`` (each axis's step, its length the
    spacing), else ``spacings`` (direction not stated); None where the header gives none."""
    if "space directions" in fields:
        nrrd = require("nrrd", "pynrrd", "nrrd")
        rows = _vectors(fields, "space directions", name, nrrd.parse_optional_vector_list)
        if len(rows) != dim:
            raise VolumeError(f"{name}: space directions has {len(rows)} entries for dimension {dim}")
        steps = [rows[a] for a in axes]
        if all(s is not None for s in steps):
            if any(len(s) != 3 for s in steps):
                raise VolumeError(f"{name}: space directions {show(fields['space directions'])} must give "
                                  f"3-vectors for a 3D space; fix the header")
            signs = _space_signs(fields, name)
            return axes_geometry([signs * np.asarray(s) for s in steps], name, "space directions")
        if "spacings" not in fields:
            return None, None
    if "spacings" not in fields:
        return None, None
    values = numbers(fields["spacings"], name, "spacings", dim, allow_nan=True)
    chosen = [values[a] for a in axes]
    if any(math.isnan(s) for s in chosen):
        return None, None
    if not all(math.isfinite(s) and s > 0 for s in chosen):
        raise VolumeError(f"{name}: spacings {show(fields['spacings'])} must give spacings that are finite and > 0; "
                          f"fix the header or set volume.spacing")
    return tuple(chosen), None


def _origin(fields, name):
    if "space origin" not in fields:
        return None
    nrrd = require("nrrd", "pynrrd", "nrrd")
    origin = _vectors(fields, "space origin", name, nrrd.parse_vector)
    if len(origin) != 3 or not np.all(np.isfinite(origin)):
        raise VolumeError(f"{name}: space origin {show(fields['space origin'])} must be three finite numbers")
    return tuple(float(v) for v in _space_signs(fields, name) * origin)


def _data_file(fields, path) -> tuple[Path, int]:
    """The file holding the data and where it starts in it (after an attached header)."""
    datafile = _get(fields, "data file", "datafile")
    if datafile is None:
        return path, None
    if datafile.startswith("LIST") or "%" in datafile:
        raise VolumeError(f"{path}: data file {show(datafile)} names several files; join them into one")
    return path.parent / os.path.expanduser(datafile), 0


def nrrd_layout(path: Path):
    """Where the voxels of an NRRD file lie (:class:`.raw.RawLayout`), for reading them in part: raw
    encoding only (attached or detached; ``line skip`` and ``byte skip`` counted); other encodings carry a
    refusal (convert the file to raw encoding or to zarr)."""
    from .raw import RawLayout, stored_layout

    path = check_input_path(Path(path), "NRRD file")
    name = str(path)
    fields, header_size = read_header(path)
    if _perhaps_colour(fields):  # read_nrrd says whether it is and what is wrong with it
        return RawLayout(path, 0, (1, 1, 1), np.dtype(np.uint8), refusal=f"{name}: a colour volume (or a 4D "
                         f"NRRD) is read whole, not in part: set volume.out_of_core = 'auto'")
    dim, sizes, encoding, dtype, axes, geometry = _header(fields, name)
    volume_dims = tuple(sizes[a] for a in axes)  # x, y, z: the leading axes dropped have size 1
    if encoding != "raw":
        return RawLayout(path, 0, volume_dims, dtype, refusal=f"{name}: {encoding}-encoded NRRD data cannot be read "
                         f"in part; convert it to raw encoding (e.g. unu save -e raw) or to zarr")
    line_skip = integer(_get(fields, "line skip", "lineskip", default="0"), name, "line skip", minimum=0)
    byte_skip = integer(_get(fields, "byte skip", "byteskip", default="0"), name, "byte skip", minimum=-1)
    target, start = _data_file(fields, path)
    start = header_size if start is None else start
    if line_skip and byte_skip >= 0 and os.path.lexists(target):  # a split file is refused by stored_layout
        start = after_lines(check_input_path(target, "NRRD data file"), start, line_skip, name)
    offset = -1 if byte_skip < 0 else start + byte_skip
    return stored_layout(target, offset, volume_dims, dtype, name, f"the header (sizes {fields['sizes']}, type "
                         f"{fields['type']})", "NRRD data file", spacing=geometry[0], direction=geometry[1],
                         origin=geometry[2])


def _header(fields, name, color: bool = False):
    """The checked fields that say what the voxels are: dimension, sizes, encoding, sample type, the three
    volume axes and the geometry ``(spacing, direction, origin)``; ``color``: read a first axis of 3 or 4
    components as colour (:func:`_colour_axis`)."""
    dim = integer(_required(fields, "dimension", name), name, "dimension", minimum=1)
    sizes = integers(_required(fields, "sizes", name), name, "sizes", dim, minimum=1)
    encoding = ENCODINGS.get(_required(fields, "encoding", name))
    if encoding is None:
        raise VolumeError(f"{name}: encoding {show(fields['encoding'])} is not supported; use raw, gzip, "
                          f"bzip2 or ascii")
    dtype = _dtype(fields, name, encoding)
    if "kinds" in fields and len(fields["kinds"].split()) != dim:
        raise VolumeError(f"{name}: kinds {show(fields['kinds'])} has {len(fields['kinds'].split())} entries "
                          f"for dimension {dim}; give one kind per axis")
    colour = _colour_axis(fields, sizes, name, color)
    axes = _axes(sizes, name) if colour is None else _space_axes(sizes, colour, name)
    (spacing, direction), origin = _geometry(fields, name, dim, axes), _origin(fields, name)
    return dim, sizes, encoding, dtype, axes, (spacing, direction, origin)


def _perhaps_colour(fields) -> bool:
    """Whether a header may hold colour: a colour kind, or a first axis of 3 or 4 of four."""
    sizes = fields.get("sizes", "").split()
    kinds = fields.get("kinds", "").lower().split()
    colour_kind = any(k in COLOUR_KINDS or k in OTHER_COLOUR_KINDS for k in kinds)
    return colour_kind or (len(sizes) == 4 and sizes[0] in ("3", "4"))


def _space_axes(sizes, colour: int, name) -> list[int]:
    """The three space axes beside the colour axis (leading axes of size 1 dropped, as :func:`_axes`)."""
    others = [a for a in range(len(sizes)) if a != colour]
    return [others[a] for a in _axes([sizes[a] for a in others], name)]


def read_nrrd(path: Path, color: bool = False) -> RawArray:
    """An NRRD file's voxels ``[z, y, x]`` and geometry; a colour volume's ``[z, y, x, 3|4]`` (an axis of
    kind RGB-color or RGBA-color, or with ``color`` (``volume.role = "rgb"``) a first axis of 3 or 4
    components), which :func:`dvr_gl.io.load_volume` makes a :class:`~dvr_gl.fields.color.ColorVolume`."""
    path = check_input_path(Path(path), "NRRD file")
    name = str(path)
    fields, header_size = read_header(path)
    dim, sizes, encoding, dtype, axes, (spacing, direction, origin) = _header(fields, name, color)
    colour = _colour_axis(fields, sizes, name, color)
    line_skip = integer(_get(fields, "line skip", "lineskip", default="0"), name, "line skip", minimum=0)
    byte_skip = integer(_get(fields, "byte skip", "byteskip", default="0"), name, "byte skip", minimum=-1)
    target, start = _data_file(fields, path)
    start = header_size if start is None else start
    count = math.prod(sizes)
    if encoding == "ascii":
        flat = parse_ascii(read_text(target, name, start, line_skip, count), count, dtype, name, "data")
    else:
        blob = read_data(target, promised_bytes(sizes, dtype), name=name, encoding=encoding, start=start,
                         line_skip=line_skip, skip=byte_skip, what="NRRD data file",
                         promise=f"the header (sizes {fields['sizes']}, type {fields['type']})")
        flat = np.frombuffer(blob, dtype=dtype)
    # NRRD lists the fastest axis first: sizes "nx ny nz" is the array [z, y, x]; the leading axes left out
    # have size 1 (and there may be more of them than numpy's 64 dimensions)
    if colour is not None:  # the components last, wherever the file keeps them
        kept = sorted([*axes, colour])
        data = flat.reshape(tuple(sizes[a] for a in reversed(kept)))
        data = np.moveaxis(data, len(kept) - 1 - kept.index(colour), -1)
        return RawArray(np.ascontiguousarray(data), spacing, origin, direction)
    data = flat.reshape(tuple(sizes[a] for a in reversed(axes)))
    return RawArray(data, spacing, origin, direction)

