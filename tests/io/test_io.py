"""Every reader on small files written here (by the format's own library where there is one),
and the bad inputs each must reject with one clear line."""

import bz2
import gzip
import os
import struct

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import detect_format, load_volume
from dvr_gl.sandbox import Sandbox, SandboxError, active

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
    with pytest.raises(VolumeError,
                       match=r"holds 46 bytes, but 4x3x2 int16 \(dims, dtype and header_bytes\) needs 48 bytes"):
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


def test_a_file_named_like_a_glob_is_that_file(tmp_path):
    """``scan[1].npy`` names the file of that name, not the glob that matches ``scan1.npy``; a name that
    is neither a file nor a pattern matching one is refused naming it (not as missing TIFF slices)."""
    np.save(tmp_path / "scan[1].npy", DATA)
    np.save(tmp_path / "scan1.npy", DATA + 1)
    np.testing.assert_array_equal(load_volume(tmp_path / "scan[1].npy").data, DATA)
    np.testing.assert_array_equal(load_volume(tmp_path / "scan[1]*.npy").data, DATA + 1)  # a glob: scan1.npy
    for name in ("scan[2].npy", "x*.tif"):
        with pytest.raises(VolumeError, match=r"matches no file") as info:
            load_volume(tmp_path / name)
        assert name in str(info.value) and "TIFF" not in str(info.value)


def test_unknown_suffix(tmp_path):
    path = tmp_path / "v.qqq"
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
    # the affine is RAS; the volume's frame is LPS (tests/io/test_io_orientation.py has the rest)
    assert v.spacing == (0.5, 1.0, 2.0) and v.origin == (10.0, -20.0, 30.0)


@pytest.mark.parametrize("named", ["v.hdr", "v.img", "V.HDR"])
def test_a_nifti_pair_reads_from_either_file(tmp_path, named):
    """A ``.hdr``/``.img`` pair read by either name (the image's name raised nibabel's WrapStructError: the
    stored pixdim was read from the file named, not the header), the case kept."""
    nib = pytest.importorskip("nibabel")
    stem = "V" if named.isupper() else "v"
    nib.save(nib.Nifti1Pair(DATA.transpose(2, 1, 0), np.diag([0.5, 1.0, 2.0, 1.0])), str(tmp_path / f"{stem}.hdr"))
    if named.isupper():
        (tmp_path / "V.hdr").rename(tmp_path / "V.HDR")
        (tmp_path / "V.img").rename(tmp_path / "V.IMG")
    v = load_volume(tmp_path / named, format="nifti")
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 1.0, 2.0)


@pytest.mark.parametrize("named", ["v.hdr", "v.img"])
def test_a_nifti_pairs_companion_outside_the_sandbox_or_a_fifo_is_refused(tmp_path, named):
    """nibabel opens a pair's other file by name: linked outside the sandbox's roots it was read (the outside
    volume rendered), a FIFO there hung the reader; both are refused in one line, given either name."""
    nib = pytest.importorskip("nibabel")
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    nib.save(nib.Nifti1Pair(np.zeros((4, 3, 2), np.int16), np.eye(4)), str(root / "v.hdr"))
    nib.save(nib.Nifti1Pair(np.full((4, 3, 2), 4242, np.int16), np.eye(4)), str(outside / "s.hdr"))
    other = {"v.hdr": "v.img", "v.img": "v.hdr"}[named]
    (root / other).unlink()
    (root / other).symlink_to(outside / ("s" + other[1:]))
    with active(Sandbox(roots=(root,))):
        with pytest.raises(SandboxError, match="NIfTI pair's .* file lies outside the allowed folders"):
            load_volume(root / named, format="nifti")
    (root / other).unlink()
    os.mkfifo(root / other)
    with pytest.raises(SandboxError, match="not a regular file"):
        load_volume(root / named, format="nifti")


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
    with pytest.raises(VolumeError, match="holds 46 bytes, but DimSize 4 3 2 of MET_SHORT needs 48 bytes"):
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


def test_vtk_cell_scalars_are_not_read_as_point_data(tmp_path):
    """SCALARS after CELL_DATA (one per cell, fewer than the points) were read as the point data, running on
    into what follows them."""
    cells = " ".join(["9"] * 6)
    head = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 3 2\nSPACING 1 1 1\n"
    (tmp_path / "c.vtk").write_text(head + f"CELL_DATA 6\nSCALARS c short\nLOOKUP_TABLE default\n{cells}\n"
                                    f"POINT_DATA 24\nSCALARS p short\nLOOKUP_TABLE default\n"
                                    + " ".join(map(str, DATA.ravel())) + "\n")
    with pytest.raises(VolumeError, match="its first SCALARS are cell data"):
        load_volume(tmp_path / "c.vtk")
    (tmp_path / "p.vtk").write_text(head + "POINT_DATA 24\nSCALARS p short\nLOOKUP_TABLE default\n"
                                    + " ".join(map(str, DATA.ravel())) + f"\nCELL_DATA 6\nSCALARS c short\n{cells}\n")
    np.testing.assert_array_equal(load_volume(tmp_path / "p.vtk").data, DATA)


def test_vtk_truncated_and_unstructured(tmp_path):
    path = tmp_path / "v.vtk"
    path.write_bytes(_vtk_header("BINARY").encode() + DATA.astype(">i2").tobytes()[:30])
    with pytest.raises(VolumeError,
                       match="holds 30 bytes after the header, but DIMENSIONS 4 3 2 of short needs 48 bytes"):
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


def write_imagej_stack(path, pages=30, description=None, big=False):
    """A multi-page TIFF with an ImageJ-style description (``images=``, ``slices=``) on its pages, as OpenImageIO
    writes it (tifffile is not a dependency); the pages' values are their index times 7."""
    import OpenImageIO as oiio

    data = np.arange(pages * 16 * 20, dtype=np.uint16).reshape(pages, 16, 20) * 7
    text = description or f"ImageJ=1.53t\nimages={pages}\nslices={pages}\nloop=false\n"
    specs = []
    for _ in range(pages):
        specs.append(oiio.ImageSpec(20, 16, 1, oiio.UINT16))
        specs[-1].attribute("ImageDescription", text)
        specs[-1].attribute("tiff:bigtiff", int(big))
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), specs)
    for i in range(pages):
        if i:
            assert out.open(str(path), specs[i], "AppendSubimage")
        assert out.write_image(np.ascontiguousarray(data[i][..., None]))
    out.close()
    return data


@pytest.mark.parametrize("fraction", [0.3, 0.5, 0.9, 0.999])
@pytest.mark.parametrize("big", [False, True])
def test_tiff_truncated_stack_is_refused(tmp_path, fraction, big):
    """Issue 40: a 30-page stack cut at 30 % read as 9 slices without a word (OpenImageIO stops at the first
    page it cannot reach); the chain of pages walked here names the first page past the end."""
    path = tmp_path / "stack.tif"
    data = write_imagej_stack(path, big=big)
    np.testing.assert_array_equal(load_volume(path).data, data)
    blob = path.read_bytes()
    assert blob[2] == (43 if big else 42)
    path.write_bytes(blob[:int(len(blob) * fraction)])
    with pytest.raises(VolumeError, match=r"stack.tif: page \d+ reaches past the end of the file .* truncated"):
        load_volume(path)


@pytest.mark.parametrize("description, message", [
    ("ImageJ=1.53t\nimages=40\nslices=40\n", "holds 30 pages, its ImageJ description promises 40"),
    ("ImageJ=1.53t\nslices=31\n", "holds 30 pages, its ImageJ description promises 31"),
    ("ImageJ=1.53t\nimages=30\nchannels=2\nslices=14\n", "images=30 but channels=2 x slices=14 x frames=1 = 28"),
    ("ImageJ=1.53t\nimages=30\nchannels=0\nslices=15\n", "has channels='0'; it must be a count from 1"),
    ("ImageJ=1.53t\nimages=30\nframes=-2\nslices=15\n", "has frames='-2'; it must be a count from 1"),
    ("ImageJ=1.53t\nimages=30\nframes=999999999\nslices=15\n", "has frames='999999999'; it must be a count"),
    ("ImageJ=1.53t\nimages=banana\n", "its ImageJ description has images='banana'"),
    ('<?xml version="1.0"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image ID="Image:0">'
     '<Pixels SizeX="20" SizeY="16" SizeZ="32" SizeC="1" SizeT="1" DimensionOrder="XYZCT" Type="uint16"/>'
     '</Image></OME>', "holds 30 pages, its OME-XML description promises 32"),
    ('<OME><Image><Pixels SizeZ="15" SizeC="1" SizeT="3"/></Image></OME>', "holds 30 pages, its OME-XML .* 45"),
    ('<OME><Image><Pixels SizeZ="0" SizeC="1" SizeT="3"/></Image></OME>', "SizeZ='0'; it must be a count from 1"),
    ('<OME><Image><Pixels SizeZ="15" SizeC="2" DimensionOrder="XYZQT"/></Image></OME>', "DimensionOrder='XYZQT'"),
    ('<OME><Image><Pixels SizeZ="15" SizeC="2"><TiffData IFD="31"/></Pixels></Image></OME>',
     "TiffData has IFD='31'; it must be an integer from 0 to 29"),
    ('<OME><Image><Pixels SizeZ="15" SizeC="2"><TiffData PlaneCount="20"/></Pixels></Image></OME>',
     "TiffData map 20 of its 30 planes"),
    ('<OME><Image><Pixels SizeZ="30"/></Image><Image><Pixels SizeZ="30"/></Image></OME>', "describes 2 images"),
    ("<OME><Image", "its OME-XML description is not valid XML"),
])
def test_tiff_description_must_match_the_pages(tmp_path, description, message):
    write_imagej_stack(tmp_path / "stack.tif", description=description)
    with pytest.raises(VolumeError, match=message):
        load_volume(tmp_path / "stack.tif")


def test_tiff_descriptions_that_agree_are_read(tmp_path):
    ome = ('<OME><Image><Pixels SizeZ="30" SizeC="1" SizeT="1"/></Image></OME>', "ImageJ=1.53t\nslices=30\n",
           "made with a camera", '<OME><Image><Pixels SizeZ="1"><TiffData><UUID FileName="other.ome.tif"/>'
           '</TiffData></Pixels></Image></OME>')  # a multi-file OME-TIFF: its pages lie in several files
    for description in ome:
        data = write_imagej_stack(tmp_path / "stack.tif", description=description)
        np.testing.assert_array_equal(load_volume(tmp_path / "stack.tif").data, data)


def test_tiff_chain_of_pages_that_loops_is_refused(tmp_path):
    """A page whose next-page offset points back at the first page: named, not followed forever."""
    path = tmp_path / "s.tif"
    write_imagej_stack(path, pages=2)
    blob = bytearray(path.read_bytes())
    first = struct.unpack("<I", blob[4:8])[0]
    second = struct.unpack("<I", blob[first + 2 + 12 * struct.unpack("<H", blob[first:first + 2])[0]:][:4])[0]
    n = struct.unpack("<H", blob[second:second + 2])[0]
    blob[second + 2 + 12 * n:second + 6 + 12 * n] = struct.pack("<I", first)
    path.write_bytes(bytes(blob))
    with pytest.raises(VolumeError, match="its chain of pages loops"):
        load_volume(path)


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


def test_tiff_folder_and_glob_through_a_scene(tmp_path):
    """A scene's volume.path may name a TIFF folder or glob (the readers check each page they open;
    a check of the path itself as one regular file refused both)."""
    from dvr_gl.scene.resolve import load_scene

    for i, s in enumerate(DATA.astype(np.uint16)):
        _write_tiff_pages(tmp_path / f"slice_{i}.tif", [s])
    for path in (tmp_path, tmp_path / "slice_*.tif"):
        scene = load_scene(None, {"volume.path": str(path), "image.width": 8, "image.height": 8})
        np.testing.assert_array_equal(scene.volume.data, DATA.astype(np.uint16))
    (tmp_path / "root").mkdir()
    with active(Sandbox(roots=(tmp_path / "root",))):
        with pytest.raises(SandboxError, match="outside the allowed folders"):
            load_scene(None, {"volume.path": str(tmp_path), "image.width": 8, "image.height": 8})


def test_tiff_slice_linked_out_of_the_sandbox_is_refused(tmp_path):
    """A folder inside the root with one slice that is a symlink to a file outside: refused before any
    member is opened (its content is not even sniffed for DICOM), in a folder and through a glob."""
    (tmp_path / "root").mkdir()
    for i, s in enumerate(DATA.astype(np.uint16)):
        _write_tiff_pages(tmp_path / "root" / f"slice_{i}.tif", [s])
    _write_tiff_pages(tmp_path / "far.tif", [DATA[0].astype(np.uint16)])
    (tmp_path / "root" / "slice_2.tif").symlink_to(tmp_path / "far.tif")
    with active(Sandbox(roots=(tmp_path / "root",))):
        for path in (tmp_path / "root", tmp_path / "root" / "slice_*.tif"):
            with pytest.raises(SandboxError, match="slice_2.tif: the .* lies outside the allowed folders"):
                load_volume(path)
    assert load_volume(tmp_path / "root").dims == (4, 3, 3)  # outside a sandbox the link is read


def test_tiff_slices_of_different_size(tmp_path):
    _write_tiff_pages(tmp_path / "a.tif", [np.zeros((3, 4), np.uint16)])
    _write_tiff_pages(tmp_path / "b.tif", [np.zeros((3, 5), np.uint16)])
    with pytest.raises(VolumeError, match="slices differ in size"):
        load_volume(tmp_path)


@pytest.mark.parametrize("name, fmt", [("a.nhdr", "nrrd"), ("a.NII.GZ", "nifti"), ("a.mha", "metaimage"),
                                       ("a.raw.bz2", "raw"), ("a.den", "raw"), ("a.tiff", "tiff")])
def test_detect_format(tmp_path, name, fmt):
    assert detect_format(tmp_path / name) == fmt


# --- strictness and bounds (issue 14) ------------------------------------------------------------




def _nhdr_with(tmp_path, replace=None, extra="", data=None):
    """A detached big-endian int16 NRRD of DATA with one header line replaced (or added)."""
    (tmp_path / "v.raw").write_bytes(DATA.astype(">i2").tobytes() if data is None else data)
    header = "NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nspacings: 1 1 2\nendian: big\nencoding: raw\n"
    for field, value in (replace or {}).items():
        header = "\n".join(f"{field}: {value}" if line.startswith(field + ":") else line
                           for line in header.split("\n"))
    path = tmp_path / "v.nhdr"
    path.write_text(header + extra + "data file: v.raw\n")
    return path


@pytest.mark.parametrize("field, value, message", [
    ("type", "banana", "type 'banana' is not an NRRD scalar type; use one of"),
    ("type", "float128", "type 'float128' is not an NRRD scalar type"),
    ("type", "block", "type 'block' is not an NRRD scalar type"),
    ("sizes", "4.5 3 2", "sizes must hold integers, got '4.5 3 2'"),
    ("sizes", "4 3", "sizes must hold 3 integers"),
    ("sizes", "4 0 2", "sizes must be >= 1"),
    ("sizes", "1e30 3 2", "sizes must hold integers"),
    ("endian", "middle", "endian 'middle' is neither little nor big"),
    ("spacings", "inf 1 2", "spacings must hold 3 finite numbers, got 'inf 1 2'"),
    ("spacings", "0 1 2", "spacings '0 1 2' must give spacings that are finite and > 0"),
    ("spacings", "-1 1 2", "must give spacings that are finite and > 0"),
    ("dimension", "x", "dimension must hold integers"),
    ("dimension", "2", "sizes must hold 2 integers"),
    ("encoding", "hex", "encoding 'hex' is not supported"),
])
def test_nrrd_malformed_field_is_named(tmp_path, field, value, message):
    with pytest.raises(VolumeError, match=message):
        load_volume(_nhdr_with(tmp_path, {field: value}))


@pytest.mark.parametrize("extra, message", [
    ("kinds: domain domain\n", "kinds 'domain domain' has 2 entries for dimension 3"),
    ("space origin: (nan,0,0)\n", "space origin .* must be three finite numbers"),
    ("space origin: banana\n", "space origin 'banana' is not a list of vectors"),
    ("line skip: -1\n", "line skip must be >= 0"),
    ("byte skip: 100000000\n", "holds 48 bytes, but the header .* needs 100000000 bytes to skip and 48"),
    ("spacings: 1 1 1\n", "field 'spacings' appears twice"),
])
def test_nrrd_malformed_extra_line_is_named(tmp_path, extra, message):
    with pytest.raises(VolumeError, match=message):
        load_volume(_nhdr_with(tmp_path, extra=extra))


def test_nrrd_empty_header_and_missing_fields(tmp_path):
    (tmp_path / "e.nhdr").write_bytes(b"")
    with pytest.raises(VolumeError, match="not an NRRD file"):
        load_volume(tmp_path / "e.nhdr")
    (tmp_path / "e.nhdr").write_text("NRRD0004\ntype: uint8\n")
    with pytest.raises(VolumeError, match="the required field 'dimension' is missing"):
        load_volume(tmp_path / "e.nhdr")


def test_nrrd_huge_line_skip_fails_at_once(tmp_path):
    """pynrrd reads skipped lines one at a time: 1e8 of them took minutes (issue 14)."""
    path = _nhdr_with(tmp_path, extra="line skip: 100000000\n")
    with pytest.raises(VolumeError, match="line skip 100000000 goes past the end of the data file"):
        load_volume(path)


def test_nrrd_line_skip_within_the_file(tmp_path):
    path = _nhdr_with(tmp_path, extra="line skip: 2\n", data=b"one\ntwo\n" + DATA.astype(">i2").tobytes())
    np.testing.assert_array_equal(load_volume(path).data, DATA)


def test_nrrd_huge_line_skip_is_bounded_by_the_file_size_when_read_in_part(tmp_path):
    """The out-of-core layout counted a line skip one readline at a time: ``line skip: 100000000`` on a
    32 KB file ran for minutes in ``dvr render`` (issue 40); now the newlines are counted in chunks."""
    import time

    from dvr_gl.io import voxel_layout

    path = tmp_path / "v.nrrd"
    path.write_bytes(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 32 32 32\nencoding: raw\n"
                     b"line skip: 100000000\n\n" + bytes(range(256)) * 128)
    start = time.perf_counter()
    with pytest.raises(VolumeError, match="line skip 100000000 goes past the end of the data file .128 lines."):
        voxel_layout(path, "nrrd", {})
    assert time.perf_counter() - start < 1
    lines = b"one\n" + b"x" * (3 << 20) + b"\ntwo\n"  # lines that span the chunks read
    layout = voxel_layout(_nhdr_with(tmp_path, extra="line skip: 3\n", data=lines + DATA.astype(">i2").tobytes()),
                          "nrrd", {})
    assert layout.offset == len(lines) and layout.dims == (4, 3, 2)


def test_nrrd_more_leading_axes_of_size_1_than_numpy_has_dimensions(tmp_path):
    """70 axes, 67 of them of size 1: numpy takes 64 dimensions at most (was an internal error); 100,000
    such axes are dropped in linear time."""
    for ones in (67, 100000):
        sizes = "1 " * ones + "4 3 2"
        path = _nhdr_with(tmp_path, {"dimension": ones + 3, "sizes": sizes, "spacings": "nan " * ones + "1 1 2"})
        np.testing.assert_array_equal(load_volume(path).data, DATA)


def test_nrrd_data_file_list_is_refused_as_such(tmp_path):
    """``data file: LIST`` is followed by file names, one a line: once called a malformed header line."""
    (tmp_path / "l.nhdr").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n"
                                     "data file: LIST 2\na.raw\nb.raw\n")
    with pytest.raises(VolumeError, match="data file 'LIST 2' names several files; join them into one"):
        load_volume(tmp_path / "l.nhdr")


def _outside_data_files(tmp_path):
    """A sandbox root and, outside it, a data file; the headers inside the root name it through a
    symlink, ``..`` and an absolute path."""
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    raw = DATA.astype(">i2").tobytes()
    (outside / "v.raw").write_bytes(raw)
    (root / "link.raw").symlink_to(outside / "v.raw")
    return root, outside, ("link.raw", "../outside/v.raw", str(outside / "v.raw"))


@pytest.mark.parametrize("kind", ["nrrd", "metaimage"])
def test_data_files_outside_the_sandbox_are_refused(tmp_path, kind):
    """A header inside the root naming a data file outside it (a symlink, ``..``, an absolute path) is
    refused when read whole, when read in part (the out-of-core layout), and before a missing data file's
    folder is searched for split parts."""
    from dvr_gl.io import voxel_layout

    root, outside, names = _outside_data_files(tmp_path)
    for name in (*names, "../outside/absent.raw"):
        if kind == "nrrd":
            header = root / "v.nhdr"
            header.write_text("NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nendian: big\nencoding: raw\n"
                              f"line skip: 0\ndata file: {name}\n")
        else:
            header = root / "v.mhd"
            header.write_text(_mhd_header(name, msb=True))
        if "absent" not in name:  # outside the sandbox, each reads
            np.testing.assert_array_equal(load_volume(header).data, DATA)
        with active(Sandbox(roots=(root,))):
            for read in (lambda: load_volume(header), lambda: voxel_layout(header, kind, {})):
                with pytest.raises(SandboxError, match="data file lies outside the allowed folders"):
                    read()
    (outside / "absent.raw.part1").write_bytes(b"")
    with active(Sandbox(roots=(root,))), pytest.raises(SandboxError, match="absent.raw: the .* lies outside"):
        load_volume(header)


def test_nrrd_line_skip_in_part_checks_the_data_file_first(tmp_path):
    """The layout counts a line skip's newlines in the data file: only after the sandbox allowed it."""
    from dvr_gl.io import voxel_layout

    root, outside, names = _outside_data_files(tmp_path)
    (root / "v.nhdr").write_text("NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nendian: big\n"
                                 "encoding: raw\nline skip: 1\ndata file: link.raw\n")
    os.mkfifo(root / "fifo.raw")
    (root / "f.nhdr").write_text((root / "v.nhdr").read_text().replace("link.raw", "fifo.raw"))
    with active(Sandbox(roots=(root,))), pytest.raises(SandboxError, match="link.raw: the NRRD data file lies"):
        voxel_layout(root / "v.nhdr", "nrrd", {})
    with pytest.raises(SandboxError, match="fifo.raw: the NRRD data file is not a regular file"):
        voxel_layout(root / "f.nhdr", "nrrd", {})


def test_tiny_spacing_is_accepted_without_work_proportional_to_its_inverse(tmp_path):
    v = load_volume(_nhdr_with(tmp_path, {"spacings": "1e-300 1 2"}))
    assert v.spacing == (1e-300, 1.0, 2.0)


@pytest.mark.parametrize("encoding, compress", [("gzip", gzip.compress), ("bzip2", bz2.compress)])
def test_decompression_bomb_stops_at_the_promised_size(tmp_path, encoding, compress):
    """16 MiB of zeros behind a header promising 48 bytes: decoding stops at 49 bytes."""
    bomb = compress(bytes(16 << 20))
    path = _nhdr_with(tmp_path, {"encoding": encoding}, data=bomb)
    with pytest.raises(VolumeError, match=f"the {encoding} data decodes to more than 48 bytes"):
        load_volume(path)
    (tmp_path / "b.raw.gz").write_bytes(gzip.compress(bytes(16 << 20)))
    with pytest.raises(VolumeError, match="decodes to more than 48 bytes"):
        load_volume(tmp_path / "b.raw.gz", dims=(4, 3, 2), dtype="int16")


def test_multi_member_gzip_is_read_whole(tmp_path):
    raw = DATA.astype(">i2").tobytes()
    path = _nhdr_with(tmp_path, {"encoding": "gzip"}, data=gzip.compress(raw[:20]) + gzip.compress(raw[20:]))
    np.testing.assert_array_equal(load_volume(path).data, DATA)


def test_fifo_data_file_is_refused_without_blocking(tmp_path):
    path = _nhdr_with(tmp_path)
    os.remove(tmp_path / "v.raw")
    os.mkfifo(tmp_path / "v.raw")
    with pytest.raises(SandboxError, match="NRRD data file is not a regular file"):
        load_volume(path)
    os.mkfifo(tmp_path / "f.npy")
    with pytest.raises(SandboxError, match="not a regular file"):
        load_volume(tmp_path / "f.npy")


def test_promised_bytes_are_checked_against_the_budget_before_reading(tmp_path):
    path = _nhdr_with(tmp_path, {"sizes": "100000 100000 100000"})
    with pytest.raises(SandboxError, match="promises would take .* over the memory budget"):
        load_volume(path)
    with active(Sandbox(max_bytes=40)):
        with pytest.raises(SandboxError, match="over the memory budget"):
            load_volume(_nhdr_with(tmp_path))
    (tmp_path / "elsewhere").mkdir()
    with active(Sandbox(roots=(tmp_path / "elsewhere",))):
        with pytest.raises(SandboxError, match="outside the allowed folders"):
            load_volume(_nhdr_with(tmp_path))


@pytest.mark.parametrize("spacing", [(0, 1, 1), (float("inf"), 1, 1), (-1, 1, 1), (1, 1)])
def test_spacing_override_must_be_finite_and_positive(tmp_path, spacing):
    np.save(tmp_path / "v.npy", DATA)
    with pytest.raises(VolumeError, match=r"spacing \(volume.spacing\) must be three finite numbers > 0"):
        load_volume(tmp_path / "v.npy", spacing=spacing)


def test_raw_dims_must_be_integers(tmp_path):
    (tmp_path / "v.raw").write_bytes(bytes(48))
    with pytest.raises(VolumeError, match="dims must be three positive integers"):
        load_volume(tmp_path / "v.raw", dims=(4.5, 3, 2), dtype="int16")


@pytest.mark.parametrize("line, value, message", [
    ("NDims", "x", "NDims must hold integers, got 'x'"),
    ("DimSize", "4 3", "DimSize must hold 3 integers"),
    ("DimSize", "4 3 2.5", "DimSize must hold integers"),
    ("ElementSpacing", "0.5 nan 2", "ElementSpacing must hold 3 finite numbers"),
    ("ElementSpacing", "0.5 0 2", "ElementSpacing must be three finite numbers > 0"),
    ("ElementType", "MET_FLOAT128", "ElementType = 'MET_FLOAT128' is not supported"),
    ("BinaryDataByteOrderMSB", "maybe", "BinaryDataByteOrderMSB = 'maybe'; use True or False"),
])
def test_metaimage_malformed_field_is_named(tmp_path, line, value, message):
    (tmp_path / "v.raw").write_bytes(DATA.astype("<i2").tobytes())
    header = "\n".join(f"{line} = {value}" if h.startswith(line + " ") else h
                       for h in _mhd_header("v.raw").split("\n"))
    (tmp_path / "v.mhd").write_text(header)
    with pytest.raises(VolumeError, match=message):
        load_volume(tmp_path / "v.mhd")


def test_metaimage_zlib_bomb(tmp_path):
    import zlib

    (tmp_path / "v.zraw").write_bytes(zlib.compress(bytes(16 << 20)))
    (tmp_path / "v.mhd").write_text(_mhd_header("v.zraw", compressed=True))
    with pytest.raises(VolumeError, match="the zlib data decodes to more than 48 bytes"):
        load_volume(tmp_path / "v.mhd")


@pytest.mark.parametrize("old, new, message", [
    ("DIMENSIONS 4 3 2", "DIMENSIONS 2 2", "DIMENSIONS must hold 3 integers"),
    ("DIMENSIONS 4 3 2", "DIMENSIONS a b c", "DIMENSIONS must hold integers"),
    ("SPACING 0.5 1 2", "SPACING x 1 2", "SPACING must hold 3 finite numbers"),
    ("SPACING 0.5 1 2", "SPACING 0 1 2", "SPACING must be three finite numbers > 0"),
    ("POINT_DATA 24", "POINT_DATA 25", "POINT_DATA 25 does not match DIMENSIONS 4 3 2"),
    ("SCALARS s short 1", "SCALARS s short x", "SCALARS components must hold integers"),
    ("SCALARS s short 1", "SCALARS s bit 1", "SCALARS type 'bit' is not supported"),
])
def test_vtk_malformed_field_is_named(tmp_path, old, new, message):
    path = tmp_path / "v.vtk"
    path.write_bytes(_vtk_header("BINARY").replace(old, new).encode() + DATA.astype(">i2").tobytes())
    with pytest.raises(VolumeError, match=message):
        load_volume(path)


def _nifti_bytes(tmp_path):
    nib = pytest.importorskip("nibabel")
    nib.save(nib.Nifti1Image(DATA.transpose(2, 1, 0), np.diag([0.5, 1, 2, 1])), str(tmp_path / "v.nii"))
    return bytearray((tmp_path / "v.nii").read_bytes())


@pytest.mark.parametrize("offset, fmt, value, message", [
    (42, "<h", -5, r"dim gives shape \(-5, 3, 2\)"),  # dim[1]: nibabel raised OverflowError/ValueError
    (70, "<h", 1234, "truncated or corrupt .*data code 1234 not recognized"),  # datatype
    (70, "<h", 32, "datatype complex64 is not a scalar type a volume can hold"),  # complex64
    (80, "<f", -0.5, r"pixdim\[1..3\] must be three finite numbers > 0"),  # nibabel took abs()
    (80, "<f", float("inf"), r"pixdim\[1..3\] must be three finite numbers > 0"),
    (44, "<h", 30000, "the file holds 400 bytes, but vox_offset 352 and .* need 480352"),  # dim[2]: more than stored
])
def test_nifti_malformed_field_is_named(tmp_path, offset, fmt, value, message):
    blob = _nifti_bytes(tmp_path)
    struct.pack_into(fmt, blob, offset, value)
    (tmp_path / "bad.nii").write_bytes(blob)
    with pytest.raises(VolumeError, match=message):
        load_volume(tmp_path / "bad.nii")


@pytest.mark.parametrize("array, message", [
    (np.zeros((2, 3, 4), np.complex64), "dtype complex64 is not a scalar type"),
    (np.zeros((2, 3, 4), "U3"), "dtype <U3 is not a scalar type"),
    (np.zeros((2, 3, 0), np.uint8), "shape must be three integers >= 1"),
])
def test_npy_unsupported_arrays(tmp_path, array, message):
    np.save(tmp_path / "v.npy", array)
    with pytest.raises(VolumeError, match=message):
        load_volume(tmp_path / "v.npy")


def test_npy_truncated_and_fortran_order(tmp_path):
    np.save(tmp_path / "v.npy", np.asfortranarray(DATA))
    np.testing.assert_array_equal(load_volume(tmp_path / "v.npy").data, DATA)
    blob = (tmp_path / "v.npy").read_bytes()
    (tmp_path / "v.npy").write_bytes(blob[:-2])
    with pytest.raises(VolumeError, match="holds 46 bytes after the header, but its header .* needs 48"):
        load_volume(tmp_path / "v.npy")


def test_bool_and_float64_are_converted(tmp_path):
    np.save(tmp_path / "b.npy", DATA > 0)
    assert load_volume(tmp_path / "b.npy").data.dtype == np.uint8
    np.save(tmp_path / "d.npy", DATA.astype(np.float64))
    assert load_volume(tmp_path / "d.npy").data.dtype == np.float32


def test_why_not_pynrrd_alone(tmp_path):
    """pynrrd's header parser truncates a fractional size without a word, so the sizes (and the
    other fields the renderer uses) are parsed here; see dvr_gl/io/nrrd.py."""
    header = nrrd.read_header(["NRRD0004", "type: uint8", "dimension: 3", "sizes: 4.5 3 2", "encoding: raw"])
    assert list(header["sizes"]) == [4, 3, 2]


def test_npy_header_findings_of_the_fuzzer(tmp_path):
    """A header length of 4 GiB made numpy try to read (and allocate) that much; an unclosed
    bracket in the header raised tokenize.TokenError: both are now user errors."""
    np.save(tmp_path / "v.npy", DATA)
    blob = bytearray((tmp_path / "v.npy").read_bytes())
    lying = b"\x93NUMPY\x02\x00" + struct.pack("<I", 0xFFFFFFF0) + bytes(blob[10:])
    (tmp_path / "a.npy").write_bytes(lying)
    with pytest.raises(VolumeError, match="not a readable .npy array"):
        load_volume(tmp_path / "a.npy")
    blob[blob.index(b")")] = ord(" ")
    (tmp_path / "b.npy").write_bytes(bytes(blob))
    with pytest.raises(VolumeError, match="not a readable .npy array"):
        load_volume(tmp_path / "b.npy")


def test_skips_are_seeked_or_counted_against_the_budget(tmp_path):
    """A raw byte skip is seeked over; a skip in decoded (gzip) data is held, so it counts."""
    raw = DATA.astype(">i2").tobytes()
    with active(Sandbox(max_bytes=1000)):
        path = _nhdr_with(tmp_path, extra="byte skip: 5000\n", data=bytes(5000) + raw)
        np.testing.assert_array_equal(load_volume(path).data, DATA)
        path = _nhdr_with(tmp_path, {"encoding": "gzip"}, extra="byte skip: 5000\n",
                          data=gzip.compress(bytes(5000) + raw))
        with pytest.raises(SandboxError, match=r"\(and 5000 bytes to skip\) would take"):
            load_volume(path)
    path = _nhdr_with(tmp_path, extra="line skip: 1\nbyte skip: -1\n", data=b"x\nabc" + raw)
    np.testing.assert_array_equal(load_volume(path).data, DATA)


def test_side_by_side_composites_over_the_background_with_gaps():
    """The docs' figures: premultiplied pictures over the background, a gap of it between them."""
    from dvr_gl.image import side_by_side

    half_red = np.zeros((5, 3, 4), np.float32)
    half_red[..., 0] = half_red[..., 3] = 0.5  # premultiplied red at alpha 0.5
    row = side_by_side([half_red, half_red], gap=2, background=(0.0, 0.0, 1.0, 1.0))
    assert row.shape == (5, 8, 4)
    assert np.allclose(row[0, 0], [0.5, 0.0, 0.5, 1.0]) and np.allclose(row[0, 3], [0.0, 0.0, 1.0, 1.0])
    assert side_by_side([row, row], axis=0, gap=1).shape == (11, 8, 4)


def test_axis_steps_of_any_finite_length_keep_their_direction():
    """The length of a step of 1e200 overflowed in the plain norm (its square is 1e400): the direction came
    out 0 and a DICOM series of PixelSpacing 1e308 was called "90 degrees from orthogonal"."""
    from dvr_gl.io.common import axes_geometry

    for length in (1e-200, 1.0, 1e200, 1e307):
        spacing, direction = axes_geometry(np.diag([length, 2 * length, 0.5 * length]) @ np.eye(3)[[1, 0, 2]],
                                           "v", "space directions")
        assert spacing == pytest.approx((length, 2 * length, 0.5 * length))
        np.testing.assert_array_equal(np.abs(np.array(direction)), np.eye(3)[[1, 0, 2]].T)
