"""VTK XML image data (``.vti``), read here: no well-kept Python library reads it without VTK itself
(meshio reads the unstructured ``.vtu`` but not ImageData; pyvista is VTK).

What is read: ``WholeExtent``, ``Origin``, ``Spacing``, ``Direction`` (VTK 9: nine numbers, the matrix
row by row, its columns the index axes) and one point-data array (``volume.array`` names it; default the
``Scalars`` the PointData element names, else its first array), of one component.  Every encoding VTK
writes: ``ascii``; ``binary`` (base64, inline); ``appended`` (``raw`` or ``base64``); each with or
without ``vtkZLibDataCompressor`` blocks; ``header_type`` UInt32 or UInt64; either ``byte_order``.

The layout, as VTK's vtkXMLWriter writes it: an uncompressed array is a header (its byte count) followed
by the bytes; a compressed one is a header ``[blocks, block size, last block size (0: full), compressed
size of each block]`` followed by the zlib blocks.  In base64, an uncompressed array's header and bytes
are encoded as one stream, a compressed array's header apart from its blocks.

Pieces are assembled into WholeExtent: each piece's Extent inside it, every point covered, a point that
two pieces share (VTK splits an extent by cells, so neighbours share a plane of points) holding the same
value in both; gaps, conflicting overlaps and pieces of different types are refused.

Bounded like the other readers: the file's size and the array the extent promises are checked against
the memory budget before anything is decoded, each block is inflated to at most the block size, and the
header's sizes must add up to exactly the promised bytes.  VTK has no patient frame: the direction is
kept as the file gives it.
"""

from __future__ import annotations

import base64
import binascii
import math
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path
from .common import RawArray, axes_geometry, check_sample_type, integers, numbers, parse_ascii, show

TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
         "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8", "Char": "i1", "UInt8_t": "u1"}
HEADERS = {"UInt32": "u4", "UInt64": "u8"}


def _split(blob: bytes, name: str) -> tuple[bytes, bytes | None]:
    """The XML before the appended data (closed so it parses) and the appended bytes after its ``_``."""
    start = blob.find(b"<AppendedData")
    if start < 0:
        return blob, None
    tag_end = blob.find(b">", start)
    mark = blob.find(b"_", tag_end)
    if tag_end < 0 or mark < 0:
        raise VolumeError(f"{name}: the AppendedData element has no '_' marking its start; the file is damaged")
    return blob[:tag_end + 1] + b"</AppendedData></VTKFile>", blob[mark + 1:]


def _attribute(element, key, name, default=None):
    value = element.get(key, default)
    if value is None:
        raise VolumeError(f"{name}: the {element.tag} element has no {key} attribute; fix the file")
    return value


def read_vti(path: Path, array: str | None = None) -> RawArray:
    path = check_input_path(Path(path), "VTK image data file")
    name = str(path)
    check_bytes(path.stat().st_size, f"{name}: the .vti file", "raise the memory budget")
    xml, appended = _split(path.read_bytes(), name)
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise VolumeError(f"{name}: not valid VTK XML ({exc})") from None
    if root.tag != "VTKFile" or root.get("type") != "ImageData":
        raise VolumeError(f"{name}: not VTK XML image data (VTKFile type {show(root.get('type'))}); .vti holds "
                          f"ImageData")
    order = {"LittleEndian": "<", "BigEndian": ">"}.get(root.get("byte_order", "LittleEndian"))
    header = HEADERS.get(root.get("header_type", "UInt32"))
    compressor = root.get("compressor")
    if order is None or header is None:
        raise VolumeError(f"{name}: byte_order {show(root.get('byte_order'))} / header_type "
                          f"{show(root.get('header_type'))}; use LittleEndian or BigEndian, UInt32 or UInt64")
    if compressor not in (None, "vtkZLibDataCompressor"):
        raise VolumeError(f"{name}: compressor {show(compressor)} is not supported; write the file with "
                          f"vtkZLibDataCompressor or none")
    image = root.find("ImageData")
    if image is None:
        raise VolumeError(f"{name}: no ImageData element; fix the file")
    extent = integers(_attribute(image, "WholeExtent", name), name, "WholeExtent", 6)
    dims = tuple(extent[2 * a + 1] - extent[2 * a] + 1 for a in range(3))
    if min(dims) < 1:
        raise VolumeError(f"{name}: WholeExtent {show(image.get('WholeExtent'))} gives dims {dims}; each axis "
                          f"needs hi >= lo")
    spacing = numbers(image.get("Spacing", "1 1 1"), name, "Spacing", 3)
    origin = np.array(numbers(image.get("Origin", "0 0 0"), name, "Origin", 3))
    matrix = numbers(image.get("Direction", "1 0 0 0 1 0 0 0 1"), name, "Direction", 9)
    steps = np.array(matrix).reshape(3, 3).T * np.array(spacing)[:, None]  # rows: each index axis's step
    spacing, direction = axes_geometry(steps, name, "Direction and Spacing")
    origin = origin + np.asarray(direction) @ (np.array(extent[::2]) * np.array(spacing))  # the extent's start
    pieces = image.findall("Piece")
    if not pieces:
        raise VolumeError(f"{name}: ImageData has no Piece; fix the file")
    codec = _Codec(name, order, header, compressor, appended, root)
    out = _assemble(pieces, extent, dims, codec, array, order, name)
    return RawArray(out, spacing, tuple(float(v) for v in origin), direction)


def _assemble(pieces, extent, dims, codec, array, order, name) -> np.ndarray:
    """The whole extent's samples ``[z, y, x]`` from its pieces.

    Each piece's extent must lie inside WholeExtent, and together they must cover every point.  Pieces
    may share points only where they hold the same values there: VTK splits an extent by cells, so
    neighbouring pieces share their boundary plane of points; a shared point with two different values
    (or two pieces written over one another) is refused, as is a gap (it would be silent zeros)."""
    out = covered = None
    for number, piece in enumerate(pieces):
        element = _choose(piece, array, name)
        dtype = _dtype(element, order, name)
        if out is None:
            check_bytes(math.prod(dims) * (dtype.itemsize + 1), f"{name}: the {dims} array its WholeExtent "
                        f"promises", "check WholeExtent, or raise the memory budget")
            out, covered = np.zeros(dims[::-1], dtype), np.zeros(dims[::-1], bool)
        elif dtype != out.dtype:
            raise VolumeError(f"{name}: Piece {number}'s DataArray {element.get('Name')!r} has type "
                              f"{element.get('type')}, the first piece's is {out.dtype.name}; the pieces of one "
                              f"array must share its type")
        part = integers(piece.get("Extent", _text(extent)), name, f"Piece {number} Extent", 6)
        if any(part[2 * a] < extent[2 * a] or part[2 * a + 1] > extent[2 * a + 1]
               or part[2 * a + 1] < part[2 * a] for a in range(3)):
            raise VolumeError(f"{name}: Piece {number} Extent {_text(part)} is empty or lies outside WholeExtent "
                              f"{_text(extent)}; fix the file")
        shape = tuple(part[2 * a + 1] - part[2 * a] + 1 for a in (2, 1, 0))
        values = codec.read(element, dtype, math.prod(shape)).reshape(shape)
        box = tuple(slice(part[2 * a] - extent[2 * a], part[2 * a + 1] - extent[2 * a] + 1) for a in (2, 1, 0))
        shared = covered[box]
        if shared.any() and not np.array_equal(out[box][shared], values[shared], equal_nan=dtype.kind == "f"):
            raise VolumeError(f"{name}: Piece {number} Extent {_text(part)} overlaps an earlier piece with other "
                              f"values; each point of WholeExtent must have one value: fix the pieces' extents")
        out[box] = values
        covered[box] = True
    if not covered.all():  # a gap would be silent zeros
        z, y, x = (int(i) for i in np.argwhere(~covered)[0])
        missing = int(covered.size - np.count_nonzero(covered))
        raise VolumeError(f"{name}: the pieces leave {missing} of the {covered.size} points of WholeExtent "
                          f"{_text(extent)} without a value (the first at x, y, z = {x + extent[0]}, "
                          f"{y + extent[2]}, {z + extent[4]}); the file is incomplete")
    return out


def _text(extent) -> str:
    return " ".join(map(str, extent))


def _choose(piece, array, name):
    point = piece.find("PointData")
    arrays = [] if point is None else point.findall("DataArray")
    if array is not None:
        found = [a for a in arrays if a.get("Name") == array]
        if not found:
            raise VolumeError(f"{name}: no point-data array {array!r}; it has "
                              f"{', '.join(repr(a.get('Name')) for a in arrays) or 'none'}")
        return found[0]
    if not arrays:
        cells = piece.find("CellData")
        what = "only cell data" if cells is not None and cells.findall("DataArray") else "no arrays"
        raise VolumeError(f"{name}: the image has {what}; a volume needs point data (sample values at the grid "
                          f"points): convert it (e.g. ParaView's Cell Data to Point Data)")
    default = point.get("Scalars")
    chosen = next((a for a in arrays if default and a.get("Name") == default), arrays[0])
    return chosen


def _dtype(element, order, name) -> np.dtype:
    written = element.get("type")
    if written not in TYPES:
        raise VolumeError(f"{name}: DataArray {element.get('Name')!r} has type {show(written)}; use one of "
                          f"{', '.join(TYPES)}")
    components = element.get("NumberOfComponents", "1")
    if components != "1":
        raise VolumeError(f"{name}: DataArray {element.get('Name')!r} has {components} components; a volume needs "
                          f"one: name another array with volume.array, or extract one component")
    return check_sample_type(np.dtype(order + TYPES[written]), name, "DataArray type", written)


class _Codec:
    """Decodes one DataArray from its element's text or the appended bytes."""

    def __init__(self, name, order, header, compressor, appended, root):
        self.name, self.compressor, self.appended = name, compressor, appended
        self.header = np.dtype(order + header)
        section = root.find("AppendedData")
        self.appended_encoding = None if section is None else section.get("encoding", "raw")
        if self.appended_encoding not in (None, "raw", "base64"):
            raise VolumeError(f"{name}: AppendedData encoding {show(self.appended_encoding)}; use raw or base64")

    def read(self, element, dtype, count) -> np.ndarray:
        fmt = element.get("format", "ascii")
        what = f"DataArray {element.get('Name')!r}"
        nbytes = count * dtype.itemsize
        if fmt == "ascii":
            text = (element.text or "").encode()
            if len(text.split(maxsplit=count)) > count:  # more values than the extent: the extent or data is wrong
                raise VolumeError(f"{self.name}: the ASCII {what} holds more than the {count} values its extent "
                                  f"promises; the extent or the array is wrong")
            return parse_ascii(text, count, dtype, self.name, what)
        if fmt == "binary":
            text = "".join((element.text or "").split()).encode()
            blob = self._stream(text, nbytes, what, encoded=True)
        elif fmt == "appended":
            if self.appended is None:
                raise VolumeError(f"{self.name}: {what} is appended, but the file has no AppendedData")
            offset = _offset(element, self.name)
            encoded = self.appended_encoding == "base64"
            blob = self._stream(self.appended[offset:], nbytes, what, encoded)
        else:
            raise VolumeError(f"{self.name}: {what} has format {show(fmt)}; use ascii, binary or appended")
        return np.frombuffer(blob, dtype=dtype, count=count)

    def _decode(self, text: bytes, nbytes: int, what: str) -> bytes:
        try:
            return base64.b64decode(text[:4 * math.ceil(nbytes / 3)], validate=True)
        except (binascii.Error, ValueError):
            raise VolumeError(f"{self.name}: {what} is not valid base64; the file is damaged") from None

    def _take(self, data: bytes, at: int, nbytes: int, what: str) -> bytes:
        if len(data) < at + nbytes:
            raise VolumeError(f"{self.name}: {what} is truncated ({max(len(data) - at, 0)} of {nbytes} bytes)")
        return data[at:at + nbytes]

    def _stream(self, data: bytes, nbytes: int, what: str, encoded: bool) -> bytes:
        h = self.header.itemsize
        if self.compressor is None:
            if encoded:
                data = self._decode(data, h + nbytes, what)
            size = int(np.frombuffer(self._take(data, 0, h, what), self.header)[0])
            if size != nbytes:
                raise VolumeError(f"{self.name}: {what} holds {size} bytes, its extent and type need {nbytes}")
            return self._take(data, h, nbytes, what)
        first = self._decode(data, h, what) if encoded else data
        blocks = int(np.frombuffer(self._take(first, 0, h, what), self.header)[0])
        if blocks > max(1, nbytes):  # each block holds at least one byte
            raise VolumeError(f"{self.name}: {what}'s compression header claims {blocks} blocks for {nbytes} bytes")
        head_bytes = (3 + blocks) * h
        head = self._decode(data, head_bytes, what) if encoded else data
        fields = np.frombuffer(self._take(head, 0, head_bytes, what), self.header).astype(np.int64)
        block, last, sizes = int(fields[1]), int(fields[2]), fields[3:]
        total = 0 if blocks == 0 else block * (blocks - 1) + (last or block)
        if total != nbytes:
            raise VolumeError(f"{self.name}: {what}'s compression header promises {total} bytes, its extent and "
                              f"type need {nbytes}")
        if encoded:
            rest = data[4 * math.ceil(head_bytes / 3):]
            body = self._decode(rest, int(sizes.sum()), what)
        else:
            body = data
        at = 0 if encoded else head_bytes
        out = bytearray()
        for b, size in enumerate(sizes):
            want = block if b < blocks - 1 or not last else last
            chunk = self._take(body, at, int(size), what)
            at += int(size)
            try:
                inflater = zlib.decompressobj()
                piece = inflater.decompress(chunk, want)
            except zlib.error as exc:
                raise VolumeError(f"{self.name}: {what}, block {b}: not a zlib stream ({exc})") from None
            if len(piece) != want or inflater.unconsumed_tail:
                raise VolumeError(f"{self.name}: {what}, block {b} inflates to {len(piece)} bytes"
                                  f"{' or more' if inflater.unconsumed_tail else ''}, the header says {want}")
            out += piece
        return bytes(out)


def _offset(element, name) -> int:
    return integers(_attribute(element, "offset", name), name, "DataArray offset", 1, minimum=0)[0]
