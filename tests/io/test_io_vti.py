"""VTK XML image data (.vti) in every encoding VTK writes, written here to VTK's layout (vtkXMLWriter):
an uncompressed array is a header (its byte count) and its bytes; a compressed one a header
``[blocks, block size, last block size, compressed sizes...]`` and zlib blocks; in base64 the compressed
header is encoded apart from its blocks."""

import base64
import math
import zlib

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import detect_format, load_field, load_volume

DATA = (np.arange(5 * 4 * 3, dtype=np.float32).reshape(3, 4, 5) * 1.5 - 7)  # [z, y, x]: nx=5 ny=4 nz=3
OTHER = np.arange(60, dtype=np.int16).reshape(3, 4, 5)[::-1].copy()


def blocks(raw: bytes, header: str, order: str, block: int):
    """The compression header and the zlib blocks of ``raw``."""
    parts = [zlib.compress(raw[i:i + block]) for i in range(0, len(raw), block)]
    last = len(raw) % block
    head = np.array([len(parts), block, last] + [len(p) for p in parts], dtype=order + header).tobytes()
    return head, b"".join(parts)


def encode(raw: bytes, header: str, order: str, compressed: bool, encoded: bool, block: int) -> bytes:
    if compressed:
        head, body = blocks(raw, header, order, block)
        return base64.b64encode(head) + base64.b64encode(body) if encoded else head + body
    sized = np.array([len(raw)], dtype=order + header).tobytes() + raw
    return base64.b64encode(sized) if encoded else sized


def write_vti(path, fmt="ascii", appended_encoding="raw", compressed=False, header="u4", order="<", block=64,
              arrays=(("density", DATA),), extent=(2, 6, 0, 3, 10, 12), direction=None):
    vtk_types = {"f4": "Float32", "i2": "Int16", "u1": "UInt8", "f8": "Float64"}
    attributes = (f' header_type="{"UInt32" if header == "u4" else "UInt64"}"'
                  f' byte_order="{"LittleEndian" if order == "<" else "BigEndian"}"'
                  + (' compressor="vtkZLibDataCompressor"' if compressed else ""))
    image = (f'<ImageData WholeExtent="{" ".join(map(str, extent))}" Origin="1 2 3" Spacing="0.5 1 2"'
             + (f' Direction="{" ".join(map(str, direction))}"' if direction is not None else "") + ">")
    body, tail, offset = [], b"", 0
    for name, values in arrays:
        raw = values.astype(order + values.dtype.str[1:]).tobytes()
        kind = vtk_types[values.dtype.str[1:]]
        if fmt == "ascii":
            text = " ".join(repr(float(v)) if values.dtype.kind == "f" else str(int(v)) for v in values.ravel())
            body.append(f'<DataArray type="{kind}" Name="{name}" format="ascii">\n{text}\n</DataArray>')
        elif fmt == "binary":
            text = encode(raw, header, order, compressed, True, block).decode()
            body.append(f'<DataArray type="{kind}" Name="{name}" format="binary">\n  {text}\n</DataArray>')
        else:
            chunk = encode(raw, header, order, compressed, appended_encoding == "base64", block)
            body.append(f'<DataArray type="{kind}" Name="{name}" format="appended" offset="{offset}"/>')
            tail += chunk
            offset += len(chunk)
    xml = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0"{attributes}>\n{image}\n'
           f'<Piece Extent="{" ".join(map(str, extent))}"><PointData Scalars="{arrays[0][0]}">'
           + "\n".join(body) + "</PointData><CellData/></Piece></ImageData>\n")
    blob = xml.encode()
    if fmt == "appended":
        blob += f'<AppendedData encoding="{appended_encoding}">\n_'.encode() + tail + b"\n</AppendedData>\n"
    path.write_bytes(blob + b"</VTKFile>\n")
    return path


CASES = [("ascii", "raw", False), ("binary", "raw", False), ("binary", "raw", True), ("appended", "raw", False),
         ("appended", "raw", True), ("appended", "base64", False), ("appended", "base64", True)]


@pytest.mark.parametrize("fmt, appended, compressed", CASES)
@pytest.mark.parametrize("header", ["u4", "u8"])
@pytest.mark.parametrize("order", ["<", ">"])
def test_every_encoding(tmp_path, fmt, appended, compressed, header, order):
    path = write_vti(tmp_path / "v.vti", fmt, appended, compressed, header, order,
                     arrays=(("density", DATA), ("labels", OTHER)))
    v = load_volume(path)
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 1.0, 2.0)
    assert v.origin == (1.0 + 2 * 0.5, 2.0, 3.0 + 10 * 2.0)  # the sample at the extent's start
    np.testing.assert_array_equal(load_volume(path, array="labels").data, OTHER)


def test_block_sizes_that_divide_and_do_not(tmp_path):
    """A last block that is full (its size written 0) and one that is partial."""
    for block in (60, 48, 1024):  # 240 bytes: 4 full blocks; 5 blocks, the last 0 mod 48; 1 partial block
        path = write_vti(tmp_path / "v.vti", "appended", "raw", True, block=block)
        np.testing.assert_array_equal(load_volume(path).data, DATA)


def test_direction_is_kept(tmp_path):
    c, s = math.cos(0.3), math.sin(0.3)
    rows = (c, -s, 0, s, c, 0, 0, 0, 1)  # VTK writes the matrix row by row; columns are the index axes
    v = load_volume(write_vti(tmp_path / "v.vti", "binary", direction=rows, extent=(0, 4, 0, 3, 0, 2)))
    np.testing.assert_allclose(np.array(v.direction), np.array(rows).reshape(3, 3), atol=1e-12)
    assert detect_format(tmp_path / "v.vti") == "vti" and load_field(tmp_path / "v.vti").dims == (5, 4, 3)


@pytest.mark.parametrize("change, message", [
    (lambda b: b.replace(b'NumberOfComponents="1"', b""), None),
    (lambda b: b.replace(b'format="binary"', b'format="binary" NumberOfComponents="3"'), "3 components"),
    (lambda b: b.replace(b'WholeExtent="2 6', b'WholeExtent="2 600'),
     "the pieces leave 7128 of the 7188 points of WholeExtent"),
    (lambda b: b.replace(b'type="Float32"', b'type="Complex"'), "type 'Complex'"),
    (lambda b: b[:len(b) // 2], "not valid VTK XML"),
    (lambda b: b.replace(b'type="ImageData"', b'type="UnstructuredGrid"'), "not VTK XML image data"),
])
def test_damaged_files_are_named(tmp_path, change, message):
    path = write_vti(tmp_path / "v.vti", "binary", compressed=True)
    path.write_bytes(change(path.read_bytes()))
    if message is None:
        np.testing.assert_array_equal(load_volume(path).data, DATA)
        return
    with pytest.raises(VolumeError, match=message):
        load_volume(path)


def test_truncated_appended_data_and_bad_header(tmp_path):
    path = write_vti(tmp_path / "v.vti", "appended", "raw", False)
    blob = path.read_bytes()
    cut = blob.index(b"\n_") + 100
    path.write_bytes(blob[:cut])
    with pytest.raises(VolumeError, match="truncated"):
        load_volume(path)
    path = write_vti(tmp_path / "w.vti", "appended", "raw", True)
    blob = path.read_bytes()
    at = blob.index(b"\n_") + 2 + 4  # the block size in the compression header: claims 4x the bytes
    path.write_bytes(blob[:at] + np.array([256], "<u4").tobytes() + blob[at + 4:])
    with pytest.raises(VolumeError, match="compression header promises"):
        load_volume(path)


def test_a_zlib_bomb_stops_at_the_block_size(tmp_path):
    """A block that inflates past its promised size is refused without inflating it all."""
    path = write_vti(tmp_path / "v.vti", "appended", "raw", True, block=1024)
    blob = path.read_bytes()
    start = blob.index(b"\n_") + 2
    bomb = zlib.compress(b"\0" * (64 << 20))
    head = np.array([1, 1024, 240, len(bomb)], "<u4").tobytes()
    path.write_bytes(blob[:start] + head + bomb + b"\n</AppendedData>\n</VTKFile>\n")
    with pytest.raises(VolumeError, match=r"block 0 inflates to 240 bytes or more, the header says 240"):
        load_volume(path)


def test_cell_data_only_and_unknown_array(tmp_path):
    path = write_vti(tmp_path / "v.vti")
    path.write_bytes(path.read_bytes().replace(b"<PointData", b"<CellData").replace(b"</PointData><CellData/>",
                                                                                     b"</CellData>"))
    with pytest.raises(VolumeError, match="only cell data"):
        load_volume(path)
    with pytest.raises(VolumeError, match="no point-data array 'pressure'; it has 'density'"):
        load_volume(write_vti(tmp_path / "w.vti"), array="pressure")


def write_pieces(path, pieces, whole=(0, 4, 0, 3, 0, 2), kind="Float32"):
    """An ascii .vti with one Piece per ``(extent, values[z, y, x])``."""
    body = "".join(
        f'<Piece Extent="{" ".join(map(str, e))}"><PointData Scalars="s"><DataArray type="{kind}" Name="s" '
        f'format="ascii">{" ".join(str(v) for v in np.ravel(values))}</DataArray></PointData></Piece>'
        for e, values in pieces)
    path.write_text(f'<VTKFile type="ImageData" version="1.0"><ImageData WholeExtent="{" ".join(map(str, whole))}" '
                    f'Origin="0 0 0" Spacing="1 1 1">{body}</ImageData></VTKFile>')
    return path


WHOLE = np.arange(60, dtype=np.float32).reshape(3, 4, 5)  # [z, y, x] of extent 0 4 0 3 0 2


def test_pieces_are_assembled_into_the_whole_extent(tmp_path):
    """Pieces as VTK splits an extent (by cells: neighbours share a boundary plane of points), in any order."""
    low, high = ((0, 4, 0, 3, 0, 1), WHOLE[0:2]), ((0, 4, 0, 3, 1, 2), WHOLE[1:3])
    np.testing.assert_array_equal(load_volume(write_pieces(tmp_path / "v.vti", [high, low])).data, WHOLE)
    quarters = [((0, 2, 0, 3, 0, 2), WHOLE[:, :, :3]), ((3, 4, 0, 1, 0, 2), WHOLE[:, :2, 3:]),
                ((3, 4, 2, 3, 0, 2), WHOLE[:, 2:, 3:])]
    np.testing.assert_array_equal(load_volume(write_pieces(tmp_path / "q.vti", quarters)).data, WHOLE)


@pytest.mark.parametrize("pieces, message", [
    # issue 40: two pieces of one extent passed the point count, the other half of the volume was zeros
    ([((0, 4, 0, 3, 0, 0), WHOLE[0]), ((0, 4, 0, 3, 0, 0), WHOLE[1]), ((0, 4, 0, 3, 0, 0), WHOLE[2])],
     "Piece 1 Extent 0 4 0 3 0 0 overlaps an earlier piece with other values"),
    ([((0, 4, 0, 3, 0, 0), WHOLE[0]), ((0, 4, 0, 3, 0, 0), WHOLE[0]), ((0, 4, 0, 3, 2, 2), WHOLE[2])],
     r"leave 20 of the 60 points .* without a value \(the first at x, y, z = 0, 0, 1\)"),
    ([((0, 4, 0, 3, 0, 1), WHOLE[:2])], "leave 20 of the 60 points"),
    ([((0, 4, 0, 3, 0, 1), WHOLE[:2]), ((0, 4, 0, 3, 2, 3), np.zeros((2, 4, 5)))], "lies outside WholeExtent"),
    ([((0, 4, 0, 3, 2, 1), WHOLE[:0])], "is empty or lies outside"),
])
def test_pieces_that_overlap_or_leave_gaps_are_refused(tmp_path, pieces, message):
    with pytest.raises(VolumeError, match=message):
        load_volume(write_pieces(tmp_path / "v.vti", pieces))


def test_ascii_array_longer_than_its_extent_is_refused(tmp_path):
    """The extra values were ignored: a piece's extent cut to the first slice read silently."""
    path = write_pieces(tmp_path / "v.vti", [((0, 4, 0, 3, 0, 0), WHOLE)], whole=(0, 4, 0, 3, 0, 0))
    with pytest.raises(VolumeError, match="holds more than the 20 values its extent promises"):
        load_volume(path)


def test_pieces_of_different_types_are_refused(tmp_path):
    path = write_pieces(tmp_path / "v.vti", [((0, 4, 0, 3, 0, 1), WHOLE[:2]), ((0, 4, 0, 3, 2, 2), WHOLE[2])])
    blob = path.read_bytes()
    at = blob.rindex(b'type="Float32"')
    path.write_bytes(blob[:at] + b'type="Float64"' + blob[at + 14:])
    with pytest.raises(VolumeError, match="Piece 1's DataArray 's' has type Float64, the first piece's is float32"):
        load_volume(path)
