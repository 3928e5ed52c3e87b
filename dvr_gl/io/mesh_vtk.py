"""Strict readers of VTK unstructured grids: XML ``.vtu`` and legacy ``.vtk`` ``UNSTRUCTURED_GRID``.

meshio read these before issue 40, and it misreads damaged files without a word: it takes each
``.vtu`` cell as the ``size`` entries of the connectivity that end at its offset, so offsets that
are all zero (or not increasing, or short of the connectivity) give other cells, not an error; it
keeps only the last ``<Piece>`` of a multi-piece file; a legacy file with fewer ``CELL_TYPES`` than
``CELLS`` loses cells; decompression has no bound.  ``tests/io/test_mesh_io.py`` keeps these cases
against meshio, to show why this reader exists.

Both readers return a :class:`RawGrid` (points, connectivity, offsets, types, arrays) and
:func:`check_cells` holds it to the format's rules, for every cell type: offsets start at 0, never
decrease and end at the connectivity's length; every type is a VTK cell type and every cell has
that type's number of points; every index names a point.  Header counts must agree with the data
(``NumberOfPoints``, ``NumberOfCells``, ``POINTS n``, ``CELLS n size``, ``CELL_TYPES n``,
``POINT_DATA n``, ``CELL_DATA n``), counts are bounded by the file's size before anything is
allocated, and decompressed sizes are checked against the memory budget before decompressing.
Every failure is one :class:`~dvr_gl.errors.VolumeError` line naming the file and the field.
"""

from __future__ import annotations

import base64
import binascii
import lzma
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_bytes

# VTK cell types: number -> (name, points per cell; None where it varies, with the least it may have)
VTK_CELLS = {
    0: ("empty", 0), 1: ("vertex", 1), 2: ("poly_vertex", None), 3: ("line", 2), 4: ("poly_line", None),
    5: ("triangle", 3), 6: ("triangle_strip", None), 7: ("polygon", None), 8: ("pixel", 4), 9: ("quad", 4),
    10: ("tetra", 4), 11: ("voxel", 8), 12: ("hexahedron", 8), 13: ("wedge", 6), 14: ("pyramid", 5),
    15: ("pentagonal_prism", 10), 16: ("hexagonal_prism", 12), 21: ("quadratic_edge", 3),
    22: ("quadratic_triangle", 6), 23: ("quadratic_quad", 8), 24: ("tetra10", 10),
    25: ("quadratic_hexahedron", 20), 26: ("quadratic_wedge", 15), 27: ("quadratic_pyramid", 13),
    28: ("biquadratic_quad", 9), 29: ("triquadratic_hexahedron", 27), 30: ("quadratic_linear_quad", 6),
    31: ("quadratic_linear_wedge", 12), 32: ("biquadratic_quadratic_wedge", 18),
    33: ("biquadratic_quadratic_hexahedron", 24), 34: ("biquadratic_triangle", 7), 35: ("cubic_line", 4),
    36: ("quadratic_polygon", None), 37: ("triquadratic_pyramid", 19), 41: ("convex_point_set", None),
    42: ("polyhedron", None),
}
LEAST_POINTS = {2: 1, 4: 2, 6: 3, 7: 3, 36: 6, 41: 1, 42: 4}
# linear volume cells written with their quadratic counterpart's points (PyVista's MAPDL export, e.g.
# notch_stress.vtk: 20-point "hexahedra", 15-point "wedges"): the corners come first and VTK draws
# the cell from them, as dvr-gl does (meshio took the last points: the mid-edge nodes)
QUADRATIC_POINTS = {10: (10,), 12: (20, 27), 13: (15, 18), 14: (13, 14)}
# cells that bound no volume (points, lines, surfaces): counted and left out
SURFACE_TYPES = frozenset({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 21, 22, 23, 28, 30, 34, 35, 36})


@dataclass
class RawGrid:
    """An unstructured grid as the file states it: ``offsets`` ``(C + 1,)`` from 0 (cell i is
    ``connectivity[offsets[i]:offsets[i + 1]]``), ``types`` ``(C,)`` VTK cell type numbers, arrays
    ``(N,)`` or ``(N, k)`` by name."""

    points: np.ndarray
    connectivity: np.ndarray
    offsets: np.ndarray
    types: np.ndarray
    point_arrays: dict = field(default_factory=dict)
    cell_arrays: dict = field(default_factory=dict)


def check_cells(path, grid: RawGrid) -> None:
    """Hold the cells to VTK's rules (see the module doc); one VolumeError naming the first breach."""
    n_points, conn, offsets, types = len(grid.points), grid.connectivity, grid.offsets, grid.types
    cells = len(offsets) - 1
    if len(types) != cells:
        raise VolumeError(f"{path}: {len(types)} cell types for {cells} cells; the counts must agree (the file "
                          "is damaged)")
    if offsets[0] != 0 or offsets[-1] != len(conn):
        raise VolumeError(f"{path}: cell offsets run from {int(offsets[0])} to {int(offsets[-1])}, not from 0 to "
                          f"the connectivity's length {len(conn)}; the file is damaged")
    sizes = np.diff(offsets)
    if (sizes < 0).any():
        at = int(np.argmax(sizes < 0))
        raise VolumeError(f"{path}: cell offsets decrease at cell {at}; offsets must not decrease (the file is "
                          "damaged)")
    known = np.isin(types, list(VTK_CELLS))
    if not known.all():
        at = int(np.argmax(~known))
        raise VolumeError(f"{path}: cell {at} has type {int(types[at])}, not a VTK cell type; the file is damaged")
    for t in np.unique(types).tolist():
        name, want = VTK_CELLS[t]
        have = sizes[types == t]
        if want is None:
            bad = have < LEAST_POINTS[t]
        else:
            bad = ~np.isin(have, (want, *QUADRATIC_POINTS.get(t, ())))
        if bad.any():
            need = f"at least {LEAST_POINTS[t]}" if want is None else " or ".join(
                map(str, (want, *QUADRATIC_POINTS.get(t, ()))))
            raise VolumeError(f"{path}: a {name} cell (VTK type {t}) has {int(have[np.argmax(bad)])} points, not "
                              f"{need}; the offsets or types are damaged")
    if len(conn) and (conn.min() < 0 or conn.max() >= n_points):
        bad = int(conn.min() if conn.min() < 0 else conn.max())
        raise VolumeError(f"{path}: a cell names point {bad}, outside 0..{n_points - 1}; the connectivity is "
                          "damaged")


def check_arrays(path, grid: RawGrid) -> None:
    """Every array has one tuple per point (per cell)."""
    n_points, n_cells = len(grid.points), len(grid.offsets) - 1
    for arrays, n, what in ((grid.point_arrays, n_points, "points"), (grid.cell_arrays, n_cells, "cells")):
        for name, values in arrays.items():
            if len(values) != n:
                raise VolumeError(f"{path}: array {name!r} has {len(values)} tuples for {n} {what}; the file is "
                                  "damaged")


# --- VTK XML (.vtu) ----------------------------------------------------------------------------

XML_TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
             "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}
COMPRESSORS = {"vtkZLibDataCompressor": "zlib", "vtkLZMADataCompressor": "lzma"}


def _b64chars(nbytes: int) -> int:
    return -(-nbytes // 3) * 4


class _VtuData:
    """The DataArrays of one file: ascii, inline base64 (``binary``) or appended (raw or base64),
    uncompressed or in zlib/LZMA blocks, with a UInt32/UInt64 header."""

    def __init__(self, path, root, appended: bytes | None, appended_encoding: str | None):
        self.path = path
        order = root.get("byte_order", "LittleEndian")
        if order not in ("LittleEndian", "BigEndian"):
            raise VolumeError(f"{path}: byte_order {order!r}; expected LittleEndian or BigEndian")
        self.endian = "<" if order == "LittleEndian" else ">"
        header = root.get("header_type", "UInt32")
        if header not in ("UInt32", "UInt64"):
            raise VolumeError(f"{path}: header_type {header!r}; expected UInt32 or UInt64")
        self.header = np.dtype(self.endian + XML_TYPES[header])
        compressor = root.get("compressor")
        if compressor is not None and compressor not in COMPRESSORS:
            raise VolumeError(f"{path}: compressor {compressor!r} is not supported; save the file with "
                              f"{' or '.join(COMPRESSORS)}, or uncompressed")
        self.compressor = COMPRESSORS.get(compressor)
        self.appended, self.appended_encoding = appended, appended_encoding

    def read(self, da, what: str) -> np.ndarray:
        """The values of DataArray ``da`` (1D, in its type)."""
        kind = da.get("type")
        if kind not in XML_TYPES:
            raise VolumeError(f"{self.path}: {what} has type {kind!r}; expected one of {', '.join(XML_TYPES)}")
        dtype = np.dtype(self.endian + XML_TYPES[kind])
        fmt = da.get("format", "ascii")
        if fmt == "ascii":
            return _numbers(self.path, (da.text or "").split(), dtype, what)
        if fmt == "binary":
            payload = self._b64(re.sub(r"\s+", "", da.text or ""), 0, what)
        elif fmt == "appended":
            if self.appended is None:
                raise VolumeError(f"{self.path}: {what} is appended, but the file has no <AppendedData>")
            offset = _int_attr(self.path, da, "offset", what)
            payload = (self._raw(self.appended, offset, what) if self.appended_encoding == "raw"
                       else self._b64(self.appended.decode("ascii", "replace"), offset, what))
        else:
            raise VolumeError(f"{self.path}: {what} has format {fmt!r}; expected ascii, binary or appended")
        if len(payload) % dtype.itemsize:
            raise VolumeError(f"{self.path}: {what} holds {len(payload)} bytes, not a whole number of {kind}")
        return np.frombuffer(payload, dtype)

    def _sizes(self, header: np.ndarray, what: str) -> tuple[int, list[int]]:
        """Uncompressed bytes and the compressed block sizes of a compressed array's header."""
        blocks, size, last = (int(v) for v in header[:3])
        if blocks == 0:
            return 0, []
        total = size * (blocks - 1) + (last or size)
        check_bytes(float(total), f"{self.path}: {what}", "use a smaller mesh")
        return total, [int(v) for v in header[3:3 + blocks]]

    def _decompress(self, data: bytes, header: np.ndarray, what: str) -> bytes:
        total, sizes = self._sizes(header, what)
        blocks, size, last = (int(v) for v in header[:3])
        out, at = [], 0
        for k, n in enumerate(sizes):
            want = (last or size) if k == blocks - 1 else size
            chunk = data[at:at + n]
            at += n
            try:
                if self.compressor == "zlib":
                    d = zlib.decompressobj()
                    got = d.decompress(chunk, want + 1)
                else:
                    got = lzma.LZMADecompressor().decompress(chunk, want + 1)
            except (zlib.error, lzma.LZMAError) as exc:
                raise VolumeError(f"{self.path}: {what}: block {k} does not decompress ({exc}); the file is "
                                  "damaged") from None
            if len(got) != want:
                raise VolumeError(f"{self.path}: {what}: block {k} holds {len(got)} bytes, the header says {want}; "
                                  "the file is damaged")
            out.append(got)
        if at != len(data) or sum(map(len, out)) != total:
            raise VolumeError(f"{self.path}: {what}: the compressed blocks do not match the header")
        return b"".join(out)

    def _header_items(self, first: int, what: str, available: int) -> int:
        """Header entries: one (the byte count) uncompressed, 3 + blocks compressed."""
        if self.compressor is None:
            return 1
        if first > available // self.header.itemsize:
            raise VolumeError(f"{self.path}: {what} claims {first} compressed blocks, more than the file holds")
        return 3 + first

    def _raw(self, blob: bytes, offset: int, what: str) -> bytes:
        hb = self.header.itemsize
        if not 0 <= offset <= len(blob) - hb:
            raise VolumeError(f"{self.path}: {what} starts at offset {offset}, outside the appended data")
        first = int(np.frombuffer(blob, self.header, 1, offset)[0])
        items = self._header_items(first, what, len(blob) - offset)
        header = np.frombuffer(blob[offset:offset + items * hb], self.header)
        if len(header) != items:
            raise VolumeError(f"{self.path}: {what}: the appended data ends inside its header")
        start = offset + items * hb
        n = first if self.compressor is None else sum(int(v) for v in header[3:])
        data = blob[start:start + n]
        if len(data) != n:
            raise VolumeError(f"{self.path}: {what} needs {n} bytes, the appended data holds {len(data)}; the file "
                              "is truncated")
        return data if self.compressor is None else self._decompress(data, header, what)

    def _b64(self, text: str, offset: int, what: str) -> bytes:
        hb = self.header.itemsize
        if not 0 <= offset < len(text):
            raise VolumeError(f"{self.path}: {what} starts at offset {offset}, outside the data")
        first = int(np.frombuffer(_unb64(self.path, text[offset:offset + _b64chars(hb)], what)[:hb].ljust(hb, b"\0"),
                                  self.header)[0])
        items = self._header_items(first, what, len(text) - offset)
        hchars = _b64chars(items * hb)
        # VTK encodes the header alone (padded with '=' unless a multiple of 3 bytes); some writers
        # encode header and data as one stream.  Either way the header's characters decode to it.
        alone = (items * hb) % 3 == 0 or text[offset + hchars - 1:offset + hchars] == "="
        head = _unb64(self.path, text[offset:offset + hchars], what)[:items * hb]
        if len(head) != items * hb:
            raise VolumeError(f"{self.path}: {what}: the data ends inside its header; the file is truncated")
        header = np.frombuffer(head, self.header)
        n = int(header[0]) if self.compressor is None else sum(int(v) for v in header[3:])
        if n > len(text) * 3 // 4:
            raise VolumeError(f"{self.path}: {what} claims {n} bytes, more than the file holds; the file is damaged")
        if alone:
            data = _unb64(self.path, text[offset + hchars:offset + hchars + _b64chars(n)], what)[:n]
        else:
            data = _unb64(self.path, text[offset:offset + _b64chars(items * hb + n)], what)[items * hb:items * hb + n]
        if len(data) != n:
            raise VolumeError(f"{self.path}: {what} needs {n} bytes, the file holds {len(data)}; it is truncated")
        return data if self.compressor is None else self._decompress(data, header, what)


def _unb64(path, text: str, what: str) -> bytes:
    try:
        return base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as exc:
        raise VolumeError(f"{path}: {what} is not valid base64 ({exc}); the file is damaged") from None


def _int_attr(path, element, name: str, what: str) -> int:
    text = element.get(name)
    if text is None or not re.fullmatch(r"\s*\d{1,18}\s*", text):
        raise VolumeError(f"{path}: {what}: {name}={text!r} is not a count")
    return int(text)


def _numbers(path, tokens, dtype: np.dtype, what: str) -> np.ndarray:
    """Whitespace-separated numbers as ``dtype`` (integers must be whole and in range)."""
    try:
        values = np.array(tokens, dtype=np.float64)
    except ValueError:
        bad = next((t for t in tokens if not _is_number(t)), "?")
        raise VolumeError(f"{path}: {what} holds {bad!r}, not a number; the file is damaged") from None
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        if not (np.isfinite(values).all() and (values == np.round(values)).all()
                and (values >= info.min).all() and (values <= info.max).all()):
            raise VolumeError(f"{path}: {what} holds values that are not {dtype.name} integers; the file is damaged")
    return values.astype(dtype)


def _is_number(token) -> bool:
    try:
        float(token)
        return True
    except ValueError:
        return False


def read_vtu(path: Path) -> RawGrid:
    """A ``.vtu`` file's grid, its pieces joined (points numbered on, as VTK joins them)."""
    from xml.etree import ElementTree as ET

    blob = Path(path).read_bytes()
    appended, encoding = None, None
    at = blob.find(b"<AppendedData")
    xml = blob
    if at >= 0:  # raw appended data is not XML: cut it out, parse the rest
        end = blob.find(b">", at)
        tag = blob[at:end].decode("latin-1")
        match = re.search(r'encoding\s*=\s*"([^"]*)"', tag)
        encoding = match.group(1) if match else "raw"
        if encoding not in ("raw", "base64"):
            raise VolumeError(f"{path}: AppendedData encoding {encoding!r}; expected raw or base64")
        under = blob.find(b"_", end)
        stop = blob.rfind(b"</AppendedData>")
        if end < 0 or under < 0 or stop < under:
            raise VolumeError(f"{path}: <AppendedData> has no '_' before its data or no end; the file is damaged")
        appended = blob[under + 1:stop]
        if encoding == "base64":
            appended = appended.strip()
        xml = blob[:at] + b"</VTKFile>"
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise VolumeError(f"{path}: not well-formed XML ({exc}); the file is damaged") from None
    if root.tag != "VTKFile" or root.get("type") != "UnstructuredGrid":
        raise VolumeError(f"{path}: not a VTK UnstructuredGrid file (root <{root.tag} type={root.get('type')!r}>)")
    grid = root.find("UnstructuredGrid")
    pieces = grid.findall("Piece") if grid is not None else []
    if not pieces:
        raise VolumeError(f"{path}: no <UnstructuredGrid><Piece>; the file holds no mesh")
    data = _VtuData(path, root, appended, encoding)
    parts = [_piece(path, data, piece, i) for i, piece in enumerate(pieces)]
    return _join(path, parts)


def _piece(path, data: _VtuData, piece, index: int) -> RawGrid:
    where = f"piece {index}" if index else "the piece"
    n_points = _int_attr(path, piece, "NumberOfPoints", where)
    n_cells = _int_attr(path, piece, "NumberOfCells", where)
    points_da = piece.find("Points/DataArray")
    if points_da is None:
        raise VolumeError(f"{path}: {where} has no <Points><DataArray>")
    points = data.read(points_da, "Points")
    components = _int_attr(path, points_da, "NumberOfComponents", "Points") \
        if points_da.get("NumberOfComponents") is not None else 1
    if components != 3 or len(points) != 3 * n_points:
        raise VolumeError(f"{path}: {where}: Points holds {len(points)} values in {components} components; "
                          f"NumberOfPoints={n_points} needs {3 * n_points} in 3")
    cells = {da.get("Name"): da for da in piece.findall("Cells/DataArray")}
    missing = [n for n in ("connectivity", "offsets", "types") if n not in cells]
    if missing:
        raise VolumeError(f"{path}: {where}: <Cells> lacks {', '.join(missing)}; the file is damaged")
    if "faces" in cells or "faceoffsets" in cells:
        raise VolumeError(f"{path}: polyhedron cells (faces) cannot be rendered; dvr-gl takes tetrahedra, "
                          "hexahedra, wedges, pyramids and quadratic tetrahedra")
    conn, ends, types = (_indices(path, data.read(cells[name], name), name)
                         for name in ("connectivity", "offsets", "types"))
    if len(ends) != n_cells or len(types) != n_cells:
        raise VolumeError(f"{path}: {where}: {len(ends)} offsets and {len(types)} types for NumberOfCells="
                          f"{n_cells}; the counts must agree")
    out = RawGrid(points.astype(np.float64).reshape(-1, 3), conn, np.concatenate([[0], ends]), types)
    for key, arrays, n in (("PointData", out.point_arrays, n_points), ("CellData", out.cell_arrays, n_cells)):
        for i, da in enumerate(piece.findall(f"{key}/DataArray")):
            name = da.get("Name") or f"{key}{i}"
            values = data.read(da, f"{key} array {name!r}")
            k = _int_attr(path, da, "NumberOfComponents", name) if da.get("NumberOfComponents") else 1
            if k < 1 or len(values) != k * n:
                raise VolumeError(f"{path}: {where}: array {name!r} holds {len(values)} values; {n} "
                                  f"{'points' if key == 'PointData' else 'cells'} of {k} components need {k * n}")
            arrays[name] = values.reshape(n, k) if k > 1 else values
    check_cells(path, out)
    return out


def _indices(path, values: np.ndarray, what: str) -> np.ndarray:
    """An array of indices, counts or types: of an integer type (a float 10.5 is no cell type), as int64."""
    if values.dtype.kind not in "iu":
        raise VolumeError(f"{path}: {what} is of type {values.dtype.name}; VTK stores it as integers (the file is "
                          "damaged)")
    if values.dtype == np.uint64 and len(values) and values.max() > np.iinfo(np.int64).max:
        raise VolumeError(f"{path}: {what} holds {int(values.max())}, past any index; the file is damaged")
    return values.astype(np.int64)


def _join(path, parts: list[RawGrid]) -> RawGrid:
    """Pieces as one grid: each piece's connectivity shifted past the points before it; arrays kept
    where every piece has them (with the same components)."""
    if len(parts) == 1:
        return parts[0]
    first_point = np.cumsum([0] + [len(p.points) for p in parts[:-1]])
    first_entry = np.cumsum([0] + [len(p.connectivity) for p in parts[:-1]])
    grid = RawGrid(np.concatenate([p.points for p in parts]),
                   np.concatenate([p.connectivity + s for p, s in zip(parts, first_point)]),
                   np.concatenate([[0]] + [p.offsets[1:] + s for p, s in zip(parts, first_entry)]),
                   np.concatenate([p.types for p in parts]))
    for key in ("point_arrays", "cell_arrays"):
        names = set.intersection(*(set(getattr(p, key)) for p in parts))
        for name in names:
            values = [getattr(p, key)[name] for p in parts]
            if len({v.shape[1:] for v in values}) == 1:
                getattr(grid, key)[name] = np.concatenate(values)
    return grid


# --- legacy VTK ---------------------------------------------------------------------------------

LEGACY_TYPES = {"bit": None, "unsigned_char": "u1", "char": "i1", "unsigned_short": "u2", "short": "i2",
                "unsigned_int": "u4", "int": "i4", "unsigned_long": "u8", "long": "i8", "float": "f4",
                "double": "f8", "vtkidtype": "i4", "vtktypeint8": "i1", "vtktypeuint8": "u1",
                "vtktypeint16": "i2", "vtktypeuint16": "u2", "vtktypeint32": "i4", "vtktypeuint32": "u4",
                "vtktypeint64": "i8", "vtktypeuint64": "u8", "vtktypefloat32": "f4", "vtktypefloat64": "f8"}


class _Legacy:
    """A cursor over a legacy file: keyword lines, then counts of numbers (ASCII tokens, or big-endian
    binary followed by a newline)."""

    def __init__(self, path, blob: bytes):
        self.path, self.blob, self.pos = path, blob, 0
        if not blob.startswith(b"# vtk DataFile Version"):
            raise VolumeError(f"{path}: no '# vtk DataFile Version' line; not a legacy VTK file")
        version = self.line()
        self.line()  # the title
        mode = self.line().strip().upper()
        if mode not in (b"ASCII", b"BINARY"):
            raise VolumeError(f"{path}: the third line must be ASCII or BINARY, got {mode[:20]!r}")
        self.ascii = mode == b"ASCII"
        self.version = version

    def line(self) -> bytes:
        end = self.blob.find(b"\n", self.pos)
        end = len(self.blob) if end < 0 else end
        text, self.pos = self.blob[self.pos:end], end + 1
        return text.rstrip(b"\r")

    def keyword(self) -> list[str] | None:
        """The next non-blank line's words (None at the end of the file)."""
        while self.pos < len(self.blob):
            words = self.line().decode("latin-1").split()
            if words:
                return words
        return None

    def peek(self) -> list[str]:
        pos = self.pos
        words = self.keyword() or []
        self.pos = pos
        return words

    def values(self, count: int, kind: str, what: str) -> np.ndarray:
        """``count`` numbers of the legacy type name ``kind``."""
        code = LEGACY_TYPES.get(kind.lower(), "?")
        if code is None or code == "?":
            raise VolumeError(f"{self.path}: {what} has type {kind!r}; expected one of "
                              f"{', '.join(k for k, v in LEGACY_TYPES.items() if v)}")
        dtype = np.dtype(">" + code)
        left = len(self.blob) - self.pos
        if count < 0 or count > (left if not self.ascii else (left + 1) // 2):
            raise VolumeError(f"{self.path}: {what} claims {count} values, more than the rest of the file holds "
                              f"({left} bytes); the file is truncated or the count is wrong")
        if self.ascii:
            parts = self.blob[self.pos:].split(None, count)
            if len(parts) < count:
                raise VolumeError(f"{self.path}: {what} needs {count} values, the file holds {len(parts)}; it is "
                                  "truncated")
            self.pos = len(self.blob) - (len(parts[count]) if len(parts) > count else 0)
            return _numbers(self.path, parts[:count], dtype, what)
        n = count * dtype.itemsize
        data = self.blob[self.pos:self.pos + n]
        if len(data) != n:
            raise VolumeError(f"{self.path}: {what} needs {n} bytes, the file holds {len(data)}; it is truncated")
        self.pos += n
        return np.frombuffer(data, dtype)

    def skip_metadata(self):
        """A METADATA block (5.1): lines up to a blank one."""
        while self.pos < len(self.blob) and self.line().strip():
            pass


def _count(path, words: list[str], i: int, what: str) -> int:
    if len(words) <= i or not re.fullmatch(r"\d{1,18}", words[i]):
        raise VolumeError(f"{path}: {' '.join(words)[:60]!r}: {what} must be a count")
    return int(words[i])


def read_legacy(path: Path) -> RawGrid:
    """A legacy ``.vtk`` ``UNSTRUCTURED_GRID`` (versions up to 4.2: ``CELLS n size`` of counted
    cells; 5.1: ``OFFSETS`` and ``CONNECTIVITY``), ASCII or binary; or a ``POLYDATA`` (its
    VERTICES, LINES, POLYGONS and TRIANGLE_STRIPS as cells of VTK types 2, 4, 7 and 6)."""
    f = _Legacy(path, Path(path).read_bytes())
    points = offsets = conn = types = None
    arrays, n_data = None, 0
    grid = RawGrid(np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64))
    dataset, last, poly = None, "the header", []
    while (words := f.keyword()) is not None:
        key = words[0].upper()
        if key == "DATASET":
            dataset = words[1].upper() if len(words) > 1 else ""
            if dataset not in ("UNSTRUCTURED_GRID", "POLYDATA"):
                raise VolumeError(f"{path}: DATASET {dataset[:30]}; this reader takes UNSTRUCTURED_GRID (or POLYDATA "
                                  "surfaces)")
        elif key == "POINTS":
            n = _count(path, words, 1, "POINTS n")
            points = f.values(3 * n, words[2] if len(words) > 2 else "?", "POINTS").astype(np.float64).reshape(n, 3)
        elif key == "CELLS":
            n, size = _count(path, words, 1, "CELLS n"), _count(path, words, 2, "CELLS size")
            offsets, conn = _cells_section(path, f, n, size)
        elif key in POLYDATA_CELLS and dataset == "POLYDATA":
            n, size = _count(path, words, 1, f"{key} n"), _count(path, words, 2, f"{key} size")
            cell_offsets, cell_conn = _cells_section(path, f, n, size)
            poly.append((POLYDATA_CELLS[key], cell_offsets, cell_conn))
        elif key == "CELL_TYPES":
            n = _count(path, words, 1, "CELL_TYPES n")
            types = f.values(n, "int", "CELL_TYPES").astype(np.int64)
        elif key in ("POINT_DATA", "CELL_DATA"):
            n_data = _count(path, words, 1, f"{key} n")
            arrays = grid.point_arrays if key == "POINT_DATA" else grid.cell_arrays
        elif key == "METADATA":
            f.skip_metadata()
        elif key in ("SCALARS", "VECTORS", "NORMALS", "TENSORS", "TENSORS6", "TEXTURE_COORDINATES",
                     "GLOBAL_IDS", "PEDIGREE_IDS", "COLOR_SCALARS", "LOOKUP_TABLE", "FIELD"):
            _attribute(path, f, words, arrays, n_data)
        elif _is_number(key):
            raise VolumeError(f"{path}: a number ({key[:20]}) where a section belongs, after {last}: its count is "
                              "smaller than its data; the file is damaged")
        else:
            raise VolumeError(f"{path}: unknown section {key[:30]!r}; the file is damaged or not a legacy VTK "
                              "unstructured grid")
        last = key
    if dataset is None:
        raise VolumeError(f"{path}: no DATASET line; not a legacy VTK unstructured grid")
    if dataset == "POLYDATA":  # surfaces: the sections' cells in the file's order, typed by section
        if poly:
            conn = np.concatenate([c for _, _, c in poly])
            shift = np.cumsum([0] + [len(c) for _, _, c in poly[:-1]])
            offsets = np.concatenate([[0]] + [o[1:] + s for (_, o, _), s in zip(poly, shift)])
            types = np.concatenate([np.full(len(o) - 1, t) for t, o, _ in poly])
        else:
            offsets, conn, types = np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    for value, section in ((points, "POINTS"), (conn, "CELLS"), (types, "CELL_TYPES")):
        if value is None:
            raise VolumeError(f"{path}: no {section} section; an unstructured grid needs POINTS, CELLS and "
                              "CELL_TYPES")
    grid.points, grid.connectivity, grid.offsets, grid.types = points, conn, offsets, types
    if len(types) != len(offsets) - 1:
        raise VolumeError(f"{path}: CELL_TYPES has {len(types)} entries for {len(offsets) - 1} CELLS; the counts "
                          "must agree (the file is damaged)")
    check_cells(path, grid)
    check_arrays(path, grid)
    return grid


def _cells_section(path, f: _Legacy, n: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Offsets ``(cells + 1,)`` and connectivity of a cell section: ``n`` counted cells in ``size`` entries
    (up to 4.2), or ``OFFSETS`` (``n`` entries) and ``CONNECTIVITY`` (``size``) in 5.1."""
    if f.peek()[:1] and f.peek()[0].upper() == "OFFSETS":
        kind = f.keyword()
        offsets = f.values(n, kind[1] if len(kind) > 1 else "?", "OFFSETS").astype(np.int64)
        kind = f.keyword() or ["?"]
        if kind[0].upper() != "CONNECTIVITY":
            raise VolumeError(f"{path}: CONNECTIVITY must follow OFFSETS; the file is damaged")
        conn = f.values(size, kind[1] if len(kind) > 1 else "?", "CONNECTIVITY").astype(np.int64)
        if not len(offsets):
            raise VolumeError(f"{path}: OFFSETS needs one more entry than cells; none given")
        return offsets, conn
    return _counted_cells(path, f.values(size, "int", "CELLS").astype(np.int64), n)


# POLYDATA sections and the VTK cell type of their cells
POLYDATA_CELLS = {"VERTICES": 2, "LINES": 4, "POLYGONS": 7, "TRIANGLE_STRIPS": 6}


def _counted_cells(path, data: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Offsets and connectivity of ``CELLS n size`` data: each cell its point count, then its points."""
    counts_at = np.zeros(n, np.int64)
    k = data[0] if len(data) else 0
    if n and len(data) == n * (k + 1) and k >= 0 and (data[::k + 1] == k).all():  # one size: no loop
        counts_at = np.arange(n, dtype=np.int64) * (k + 1)
    else:
        at = 0
        for i in range(n):
            if at >= len(data) or data[at] < 0:
                raise VolumeError(f"{path}: CELLS {n} {len(data)}: cell {i}'s point count lies past the data or is "
                                  "negative; the counts are damaged")
            counts_at[i] = at
            at += int(data[at]) + 1
        if at != len(data):
            raise VolumeError(f"{path}: CELLS {n} {len(data)}: the cells' point counts add up to {at} entries, not "
                              f"{len(data)}; the counts are damaged")
    sizes = data[counts_at] if n else np.zeros(0, np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    keep = np.ones(len(data), bool)
    keep[counts_at] = False
    return offsets, data[keep]


def _attribute(path, f: _Legacy, words: list[str], arrays, n: int):
    """One POINT_DATA or CELL_DATA attribute, kept (in ``arrays``) where it is numeric."""
    key = words[0].upper()
    if arrays is None and key != "FIELD":
        raise VolumeError(f"{path}: {key} before POINT_DATA or CELL_DATA; the file is damaged")
    name = words[1] if len(words) > 1 else "?"
    if key == "SCALARS":
        k = _count(path, words, 3, "SCALARS components") if len(words) > 3 else 1
        if not 1 <= k <= 4:
            raise VolumeError(f"{path}: SCALARS {name} has {k} components; VTK allows 1 to 4")
        if f.peek()[:1] and f.peek()[0].upper() == "LOOKUP_TABLE":
            f.keyword()
        arrays[name] = _shaped(f.values(n * k, words[2] if len(words) > 2 else "?", f"SCALARS {name}"), n, k)
    elif key in ("VECTORS", "NORMALS"):
        arrays[name] = _shaped(f.values(3 * n, words[2] if len(words) > 2 else "?", f"{key} {name}"), n, 3)
    elif key in ("TENSORS", "TENSORS6"):
        k = 9 if key == "TENSORS" else 6
        arrays[name] = _shaped(f.values(k * n, words[2] if len(words) > 2 else "?", f"{key} {name}"), n, k)
    elif key == "TEXTURE_COORDINATES":
        k = _count(path, words, 2, "TEXTURE_COORDINATES dim")
        if not 1 <= k <= 3:
            raise VolumeError(f"{path}: TEXTURE_COORDINATES {name} of dimension {k}; VTK allows 1 to 3")
        f.values(k * n, words[3] if len(words) > 3 else "?", f"{key} {name}")
    elif key in ("GLOBAL_IDS", "PEDIGREE_IDS"):
        f.values(n, words[2] if len(words) > 2 else "?", f"{key} {name}")
    elif key == "COLOR_SCALARS":
        k = _count(path, words, 2, "COLOR_SCALARS components")
        f.values(k * n, "float" if f.ascii else "unsigned_char", f"{key} {name}")
    elif key == "LOOKUP_TABLE":
        size = _count(path, words, 2, "LOOKUP_TABLE size")
        f.values(4 * size, "float" if f.ascii else "unsigned_char", f"LOOKUP_TABLE {name}")
    else:  # FIELD name count: arrays "name components tuples type"
        for _ in range(_count(path, words, 2, "FIELD count")):
            head = f.keyword() or ["?"]
            if head[0].upper() == "METADATA":
                f.skip_metadata()
                head = f.keyword() or ["?"]
            k, tuples = _count(path, head, 1, "components"), _count(path, head, 2, "tuples")
            values = f.values(k * tuples, head[3] if len(head) > 3 else "?", f"FIELD array {head[0]!r}")
            if arrays is not None and k >= 1:
                if tuples != n:
                    raise VolumeError(f"{path}: FIELD array {head[0]!r} has {tuples} tuples for {n} "
                                      "points or cells; the file is damaged")
                arrays[head[0]] = _shaped(values, tuples, k)
            if f.peek()[:1] and f.peek()[0].upper() == "METADATA":
                f.keyword()
                f.skip_metadata()


def _shaped(values: np.ndarray, n: int, k: int) -> np.ndarray:
    return values.reshape(n, k) if k > 1 else values
