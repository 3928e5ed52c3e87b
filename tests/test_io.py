"""Every reader on small files written here (by the format's own library where there is one),
and the bad inputs each must reject with one clear line."""

import bz2
import gzip

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import detect_format, load_volume

DATA = (np.arange(4 * 3 * 2, dtype=np.int16).reshape(2, 3, 4) * 37 - 300)  # [z, y, x]: nx=4 ny=3 nz=2


# --- raw ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("endian, code", [("little", "<i2"), ("big", ">i2")])
def test_raw_with_header_and_endianness(tmp_path, endian, code):
    path = tmp_path / "v.raw"
    path.write_bytes(b"HEADER" + DATA.astype(code).tobytes())
    v = load_volume(path, dims=(4, 3, 2), dtype="int16", endian=endian, header_bytes=6)
    np.testing.assert_array_equal(v.data, DATA)


@pytest.mark.parametrize("suffix, compress", [(".raw.gz", gzip.compress), (".raw.bz2", bz2.compress)])
def test_raw_compressed_by_suffix(tmp_path, suffix, compress):
    path = tmp_path / ("v" + suffix)
    path.write_bytes(compress(DATA.astype("<i2").tobytes()))
    v = load_volume(path, dims=(4, 3, 2), dtype="int16")
    np.testing.assert_array_equal(v.data, DATA)


def test_raw_size_mismatch_names_both_sizes(tmp_path):
    path = tmp_path / "v.raw"
    path.write_bytes(DATA.astype("<i2").tobytes()[:-2])
    with pytest.raises(VolumeError, match=r"holds 46 bytes, but 4x3x2 int16 \(dims, dtype and header_bytes\) promises 48 bytes"):
        load_volume(path, dims=(4, 3, 2), dtype="int16")


def test_raw_unknown_dtype(tmp_path):
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(24))
    with pytest.raises(VolumeError, match="unknown dtype 'int12'; use one of"):
        load_volume(path, dims=(4, 3, 2), dtype="int12")


@pytest.mark.parametrize("dims", [(0, 3, 2), (4, 3), (4, -1, 2)])
def test_raw_bad_dims(tmp_path, dims):
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(24))
    with pytest.raises(VolumeError, match="dims must be three positive integers"):
        load_volume(path, dims=dims, dtype="uint8")


def test_raw_needs_dims_and_dtype(tmp_path):
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(24))
    with pytest.raises(VolumeError, match="needs dims and dtype"):
        load_volume(path)


def test_truncated_gzip_is_reported(tmp_path):
    path = tmp_path / "v.raw.gz"
    path.write_bytes(gzip.compress(DATA.astype("<i2").tobytes())[:-12])
    with pytest.raises(VolumeError, match="gzip data is truncated or corrupt"):
        load_volume(path, dims=(4, 3, 2), dtype="int16")


def test_nan_in_float_data_is_an_error_unless_replaced(tmp_path):
    data = np.ones((2, 3, 4), np.float32)
    data[0, 1, 2] = np.nan
    path = tmp_path / "f.raw"
    path.write_bytes(data.tobytes())
    with pytest.raises(VolumeError, match="1 NaN or Inf values; choose a replacement value"):
        load_volume(path, dims=(4, 3, 2), dtype="float32")
    v = load_volume(path, dims=(4, 3, 2), dtype="float32", nan_value=-1.0)
    assert v.data[0, 1, 2] == -1.0


def test_missing_file(tmp_path):
    with pytest.raises(VolumeError, match="file not found"):
        load_volume(tmp_path / "nope.nrrd")


def test_unknown_suffix(tmp_path):
    path = tmp_path / "v.xyz"
    path.write_bytes(b"1")
    with pytest.raises(VolumeError, match="cannot tell the format"):
        load_volume(path)


def test_spacing_and_origin_overrides(tmp_path):
    path = tmp_path / "v.npy"
    np.save(path, DATA)
    v = load_volume(path, spacing=(1, 2, 3), origin=(4, 5, 6))
    assert v.spacing == (1.0, 2.0, 3.0) and v.origin == (4.0, 5.0, 6.0)


# --- NRRD (pynrrd) ----------------------------------------------------------------------------------

nrrd = pytest.importorskip("nrrd", reason="pynrrd is the NRRD reader (extra 'nrrd')")


@pytest.mark.parametrize("encoding", ["raw", "gzip", "bzip2"])
def test_nrrd_attached(tmp_path, encoding):
    path = tmp_path / "v.nrrd"
    nrrd.write(str(path), DATA, {"encoding": encoding, "spacings": [0.5, 1.0, 2.0]}, index_order="C")
    v = load_volume(path)
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 1.0, 2.0)


def _write_nhdr(tmp_path, data_name, encoding="raw", extra=""):
    header = (f"NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nspacings: 1 1 2\nendian: big\n"
              f"encoding: {encoding}\n{extra}data file: {data_name}\n")
    path = tmp_path / "v.nhdr"
    path.write_text(header)
    return path


def test_nrrd_detached_big_endian_with_byte_skip(tmp_path):
    (tmp_path / "v.raw").write_bytes(b"\0" * 10 + DATA.astype(">i2").tobytes())
    v = load_volume(_write_nhdr(tmp_path, "v.raw", extra="byte skip: 10\n"))
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (1.0, 1.0, 2.0)


def test_nrrd_detached_data_split_in_parts_is_joined(tmp_path):
    blob = bz2.compress(DATA.astype(">i2").tobytes())
    (tmp_path / "v.raw.bz2.part1").write_bytes(blob[:20])
    (tmp_path / "v.raw.bz2.part2").write_bytes(blob[20:])
    v = load_volume(_write_nhdr(tmp_path, "v.raw.bz2", encoding="bzip2"))
    np.testing.assert_array_equal(v.data, DATA)


def test_nrrd_missing_part_is_reported(tmp_path):
    blob = bz2.compress(DATA.astype(">i2").tobytes())
    (tmp_path / "v.raw.bz2.part1").write_bytes(blob[:20])
    (tmp_path / "v.raw.bz2.part3").write_bytes(blob[20:])
    with pytest.raises(VolumeError, match="a part is missing"):
        load_volume(_write_nhdr(tmp_path, "v.raw.bz2", encoding="bzip2"))


def test_nrrd_truncated_gzip_is_reported(tmp_path):
    (tmp_path / "v.raw.gz").write_bytes(gzip.compress(DATA.astype(">i2").tobytes())[:-10])
    with pytest.raises(VolumeError, match="truncated"):
        load_volume(_write_nhdr(tmp_path, "v.raw.gz", encoding="gzip"))


def test_nrrd_missing_data_file(tmp_path):
    with pytest.raises(VolumeError, match="v.nhdr: its NRRD data file .*absent.raw was not found"):
        load_volume(_write_nhdr(tmp_path, "absent.raw"))


# --- NIfTI (nibabel) ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["v.nii", "v.nii.gz"])
def test_nifti(tmp_path, name):
    nib = pytest.importorskip("nibabel")
    affine = np.diag([0.5, 1.0, 2.0, 1.0])
    affine[:3, 3] = [-10, 20, 30]
    nib.save(nib.Nifti1Image(DATA.transpose(2, 1, 0), affine), str(tmp_path / name))  # nibabel is x-first
    v = load_volume(tmp_path / name)
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 1.0, 2.0) and v.origin == (-10.0, 20.0, 30.0)


def test_nifti_truncated(tmp_path):
    nib = pytest.importorskip("nibabel")
    big = np.random.default_rng(0).integers(0, 1000, (40, 30, 20)).astype(np.int16)
    nib.save(nib.Nifti1Image(big, np.eye(4)), str(tmp_path / "v.nii.gz"))
    blob = (tmp_path / "v.nii.gz").read_bytes()
    (tmp_path / "t.nii.gz").write_bytes(blob[: len(blob) // 2])
    with pytest.raises(VolumeError, match="truncated or corrupt"):
        load_volume(tmp_path / "t.nii.gz")


# --- MetaImage ------------------------------------------------------------------------------------

def _mhd_header(datafile, msb=False, compressed=False, extra=""):
    return (f"ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = {msb}\n"
            f"CompressedData = {compressed}\n{extra}ElementSpacing = 0.5 1 2\nOffset = 1 2 3\n"
            f"DimSize = 4 3 2\nElementType = MET_SHORT\nElementDataFile = {datafile}\n")


@pytest.mark.parametrize("msb", [False, True])
@pytest.mark.parametrize("compressed", [False, True])
def test_metaimage_detached(tmp_path, msb, compressed):
    import zlib

    raw = DATA.astype(">i2" if msb else "<i2").tobytes()
    (tmp_path / "v.zraw").write_bytes(zlib.compress(raw) if compressed else raw)
    (tmp_path / "v.mhd").write_text(_mhd_header("v.zraw", msb, compressed))
    v = load_volume(tmp_path / "v.mhd")
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 1.0, 2.0) and v.origin == (1.0, 2.0, 3.0)


def test_metaimage_local_data_and_wrong_compressed_size(tmp_path):
    """.mha with the data after the header; a CompressedDataSize that is short of the real stream
    (as in shared/data/large/frogtissue.mhd) must not cut the data."""
    import zlib

    blob = zlib.compress(DATA.astype("<i2").tobytes())
    header = _mhd_header("LOCAL", compressed=True, extra=f"CompressedDataSize = {len(blob) - 5}\n")
    (tmp_path / "v.mha").write_bytes(header.encode() + blob)
    np.testing.assert_array_equal(load_volume(tmp_path / "v.mha").data, DATA)


def test_metaimage_truncated_and_missing_data(tmp_path):
    import zlib

    (tmp_path / "v.zraw").write_bytes(zlib.compress(DATA.astype("<i2").tobytes())[:-6])
    (tmp_path / "v.mhd").write_text(_mhd_header("v.zraw", compressed=True))
    with pytest.raises(VolumeError, match="zlib data is truncated or corrupt"):
        load_volume(tmp_path / "v.mhd")
    (tmp_path / "v.zraw").write_bytes(DATA.astype("<i2").tobytes()[:-2])
    (tmp_path / "v.mhd").write_text(_mhd_header("v.zraw"))
    with pytest.raises(VolumeError, match="holds 46 bytes, but DimSize 4 3 2 of MET_SHORT promises 48 bytes"):
        load_volume(tmp_path / "v.mhd")
    (tmp_path / "v.mhd").write_text(_mhd_header("gone.raw"))
    with pytest.raises(VolumeError, match="its MetaImage data file .*gone.raw was not found"):
        load_volume(tmp_path / "v.mhd")


# --- legacy VTK --------------------------------------------------------------------------------------

def _vtk_header(mode):
    return (f"# vtk DataFile Version 3.0\ntest\n{mode}\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 3 2\n"
            f"SPACING 0.5 1 2\nORIGIN 1 2 3\nPOINT_DATA 24\nSCALARS s short 1\nLOOKUP_TABLE default\n")


def test_vtk_binary_is_big_endian(tmp_path):
    path = tmp_path / "v.vtk"
    path.write_bytes(_vtk_header("BINARY").encode() + DATA.astype(">i2").tobytes() + b"\n")
    v = load_volume(path)
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 1.0, 2.0) and v.origin == (1.0, 2.0, 3.0)


def test_vtk_ascii(tmp_path):
    path = tmp_path / "v.vtk"
    path.write_text(_vtk_header("ASCII") + " ".join(map(str, DATA.ravel())) + "\n")
    np.testing.assert_array_equal(load_volume(path).data, DATA)


def test_vtk_truncated_and_unstructured(tmp_path):
    path = tmp_path / "v.vtk"
    path.write_bytes(_vtk_header("BINARY").encode() + DATA.astype(">i2").tobytes()[:30])
    with pytest.raises(VolumeError, match="holds 30 bytes after the header, but DIMENSIONS 4 3 2 of short promises 48 bytes"):
        load_volume(path)
    path.write_text("# vtk DataFile Version 2.0\nmesh\nASCII\nDATASET UNSTRUCTURED_GRID\n")
    with pytest.raises(VolumeError, match="not STRUCTURED_POINTS"):
        load_volume(path)


# --- npy and TIFF stacks -----------------------------------------------------------------------------

def test_npy(tmp_path):
    np.save(tmp_path / "v.npy", DATA)
    np.testing.assert_array_equal(load_volume(tmp_path / "v.npy").data, DATA)
    np.save(tmp_path / "flat.npy", DATA[0])
    with pytest.raises(VolumeError, match="expected a 3D array"):
        load_volume(tmp_path / "flat.npy")


def _write_tiff_pages(path, slices):
    import OpenImageIO as oiio

    specs = [oiio.ImageSpec(s.shape[1], s.shape[0], 1, oiio.UINT16) for s in slices]
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), specs)
    for i, s in enumerate(slices):
        if i:
            assert out.open(str(path), specs[i], "AppendSubimage")
        assert out.write_image(np.ascontiguousarray(s[..., None]))  # (h, w, channels)
    out.close()


def test_tiff_multipage_stack(tmp_path):
    data = DATA.astype(np.uint16) + 1000
    _write_tiff_pages(tmp_path / "stack.tif", list(data))
    v = load_volume(tmp_path / "stack.tif")
    np.testing.assert_array_equal(v.data, data)
    assert v.data.dtype == np.uint16


def test_tiff_folder_in_natural_order(tmp_path):
    data = DATA.astype(np.uint16) + 1000
    data = np.concatenate([data] * 6)  # 12 slices: slice_10 must come after slice_9
    for i, s in enumerate(data):
        _write_tiff_pages(tmp_path / f"slice_{i}.tif", [s])
    np.testing.assert_array_equal(load_volume(tmp_path).data, data)
    np.testing.assert_array_equal(load_volume(tmp_path / "slice_*.tif").data, data)


def test_tiff_slices_of_different_size(tmp_path):
    _write_tiff_pages(tmp_path / "a.tif", [np.zeros((3, 4), np.uint16)])
    _write_tiff_pages(tmp_path / "b.tif", [np.zeros((3, 5), np.uint16)])
    with pytest.raises(VolumeError, match="slices differ in size"):
        load_volume(tmp_path)


@pytest.mark.parametrize("name, fmt", [("a.nhdr", "nrrd"), ("a.NII.GZ", "nifti"), ("a.mha", "metaimage"),
                                       ("a.raw.bz2", "raw"), ("a.den", "raw"), ("a.tiff", "tiff")])
def test_detect_format(tmp_path, name, fmt):
    assert detect_format(tmp_path / name) == fmt
