"""DICOM series written here with pydicom: slice order, spacing, rescaling and orientation from the
headers, and the series that must be refused in one line."""

import math
import os

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import detect_format, load_field, load_volume

pydicom = pytest.importorskip("pydicom", reason="pydicom reads DICOM series (extra 'dicom')")
from pydicom.dataset import Dataset, FileMetaDataset  # noqa: E402
from pydicom.encaps import encapsulate  # noqa: E402
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, JPEGLSLossless, generate_uid  # noqa: E402

STORED = np.arange(5 * 3 * 4, dtype=np.int16).reshape(5, 3, 4) * 7 - 100  # [slice, row, column]
C, S = math.cos(math.radians(30)), math.sin(math.radians(30))
AXIAL = (1, 0, 0, 0, 1, 0)
OBLIQUE = (C, S, 0, 0, 0, -1)  # rows turned 30 degrees in the axial plane, columns toward inferior


def write_series(folder, stored=STORED, orientation=AXIAL, gap=2.5, origin=(-10, 20, 30), slope=1, intercept=0,
                 uid=None, number=3, names=None, skip=(), syntax=ExplicitVRLittleEndian, sideways=0.0):
    """One file per slice; the file names (and InstanceNumber) deliberately out of order."""
    folder.mkdir(exist_ok=True)
    uid = uid or generate_uid()
    row, col = np.array(orientation[:3], float), np.array(orientation[3:], float)
    normal = np.cross(row, col)
    rng = np.random.default_rng(len(str(folder)))
    labels = rng.permutation(len(stored))
    paths = []
    for k, pixels in enumerate(stored):
        if k in skip:
            continue
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = syntax
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
        ds.SeriesInstanceUID, ds.SeriesNumber, ds.SeriesDescription = uid, number, f"series {number}"
        ds.Modality = "CT"
        ds.InstanceNumber = int(labels[k]) + 1
        ds.ImageOrientationPatient = [f"{v:.8f}" for v in orientation]
        position = np.asarray(origin, float) + k * gap * normal + k * sideways * row
        ds.ImagePositionPatient = [f"{v:.6f}" for v in position]
        ds.PixelSpacing = ["0.75", "0.5"]  # between rows (y), between columns (x)
        ds.SliceThickness = str(gap)
        ds.RescaleSlope, ds.RescaleIntercept = str(slope), str(intercept)
        ds.Rows, ds.Columns = pixels.shape
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.PixelData = pixels.astype("<i2").tobytes()
        if syntax.is_compressed:  # a frame that is not really compressed: decoding must not be reached
            ds.PixelData = encapsulate([ds.PixelData])
        name = (names or "slice_{:03d}.dcm").format(int(labels[k]))
        ds.save_as(str(folder / name), enforce_file_format=True)
        paths.append(folder / name)
    return paths


def test_series_in_position_order_not_file_order(tmp_path):
    write_series(tmp_path / "s")
    v = load_volume(tmp_path / "s")
    np.testing.assert_array_equal(v.data, STORED)
    assert v.data.dtype == np.int16
    assert v.spacing == pytest.approx((0.5, 0.75, 2.5)) and v.origin == (-10.0, 20.0, 30.0)
    assert v.direction == ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def test_files_without_suffix_list_and_glob(tmp_path):
    """Found by content, not name: a list of files and a glob read the same volume."""
    paths = write_series(tmp_path / "s", names="IM{:04d}")
    assert detect_format(tmp_path / "s") == "dicom" and detect_format(paths) == "dicom"
    for source in (paths[::-1], str(tmp_path / "s" / "IM*")):
        np.testing.assert_array_equal(load_volume(source).data, STORED)
    assert load_field(paths).dims == (4, 3, 5)


def test_slope_and_intercept_integral_give_int16(tmp_path):
    write_series(tmp_path / "s", slope=2, intercept=-1024)
    v = load_volume(tmp_path / "s")
    assert v.data.dtype == np.int16
    np.testing.assert_array_equal(v.data, STORED * 2 - 1024)


def test_fractional_slope_gives_float32(tmp_path):
    write_series(tmp_path / "s", slope=0.5, intercept=0.25)
    v = load_volume(tmp_path / "s")
    assert v.data.dtype == np.float32
    np.testing.assert_allclose(v.data, STORED * 0.5 + 0.25)


def test_oblique_orientation(tmp_path):
    """Columns of the direction: the row direction, the column direction, the normal; each sample where its
    slice's ImagePositionPatient and PixelSpacing put it."""
    write_series(tmp_path / "s", orientation=OBLIQUE)
    v = load_volume(tmp_path / "s")
    row, col = np.array(OBLIQUE[:3]), np.array(OBLIQUE[3:])
    np.testing.assert_allclose(np.array(v.direction), np.column_stack([row, col, np.cross(row, col)]), atol=1e-7)
    for i, j, k in [(3, 0, 0), (0, 2, 0), (0, 0, 4), (3, 2, 4)]:
        header = np.array([-10, 20, 30]) + k * 2.5 * np.cross(row, col) + i * 0.5 * row + j * 0.75 * col
        placed = np.array(v.origin) + np.array(v.direction) @ (np.array([i, j, k]) * v.spacing)
        np.testing.assert_allclose(placed, header, atol=1e-5)


def test_two_series_in_one_folder_are_named(tmp_path):
    write_series(tmp_path / "s", number=3)
    write_series(tmp_path / "s", number=7, stored=STORED + 1, names="other_{:03d}.dcm")
    with pytest.raises(VolumeError, match=r"2 series: number 3 'series 3' \(5 files.*number 7.*volume.series"):
        load_volume(tmp_path / "s")
    np.testing.assert_array_equal(load_volume(tmp_path / "s", series="7").data, STORED + 1)
    np.testing.assert_array_equal(load_volume(str(tmp_path / "s" / "slice_*")).data, STORED)
    with pytest.raises(VolumeError, match="no series '9' among"):
        load_volume(tmp_path / "s", series="9")


def test_missing_slice_is_named(tmp_path):
    write_series(tmp_path / "s", skip=(2,))
    with pytest.raises(VolumeError, match=r"slices 5 mm apart, the others 2.5 mm \(a missing slice\?\)"):
        load_volume(tmp_path / "s")


def test_tilted_gantry_is_refused(tmp_path):
    write_series(tmp_path / "s", sideways=0.4)
    with pytest.raises(VolumeError, match="shifted 0.4 mm sideways .* tilted gantry"):
        load_volume(tmp_path / "s")


def test_mismatched_sizes_and_orientations(tmp_path):
    uid = generate_uid()
    write_series(tmp_path / "a", uid=uid, skip=(3, 4))
    write_series(tmp_path / "a", uid=uid, stored=np.zeros((5, 3, 5), np.int16), skip=(0, 1, 2), names="b{:03d}.dcm")
    with pytest.raises(VolumeError, match=r"size \(Rows, Columns\) \[3, \d\] differs from .*'s \[3, \d\]"):
        load_volume(tmp_path / "a")
    write_series(tmp_path / "b", uid=uid, skip=(3, 4))
    write_series(tmp_path / "b", uid=uid, orientation=OBLIQUE, skip=(0, 1, 2), names="b{:03d}.dcm")
    with pytest.raises(VolumeError, match="ImageOrientationPatient .* differs"):
        load_volume(tmp_path / "b")


def test_duplicate_positions_are_refused(tmp_path):
    uid = generate_uid()
    write_series(tmp_path / "s", uid=uid)
    write_series(tmp_path / "s", uid=uid, names="echo2_{:03d}.dcm")
    with pytest.raises(VolumeError, match="two slices at one position"):
        load_volume(tmp_path / "s")


def test_compressed_syntax_names_the_plugin(tmp_path):
    from pydicom.pixels import get_decoder

    if get_decoder(JPEGLSLossless).is_available:
        pytest.skip("a JPEG-LS decoder is installed here, so nothing is missing to name")
    paths = write_series(tmp_path / "s", syntax=JPEGLSLossless)
    with pytest.raises(VolumeError, match=r"JPEG-LS Lossless .* is compressed, and pydicom decodes it only with a "
                                          r"plugin \(.*pylibjpeg-libjpeg.*\): e.g. pip install pylibjpeg"):
        load_volume(paths)


def test_folders_without_dicom(tmp_path):
    """A folder of TIFFs is still a TIFF stack; an empty folder and a non-DICOM file in a list are named."""
    (tmp_path / "e").mkdir()
    (tmp_path / "e" / "notes.txt").write_text("hello")
    assert detect_format(tmp_path / "e") == "tiff"
    with pytest.raises(VolumeError, match="no TIFF files"):
        load_volume(tmp_path / "e")
    with pytest.raises(VolumeError, match="not a DICOM file"):
        load_volume([tmp_path / "e" / "notes.txt"])
    with pytest.raises(VolumeError, match="no DICOM files"):
        load_volume(tmp_path / "e", format="dicom")


def test_single_slice_uses_slice_thickness(tmp_path):
    write_series(tmp_path / "s", stored=STORED[:1])
    v = load_volume(tmp_path / "s")
    assert v.dims == (4, 3, 1) and v.spacing == pytest.approx((0.5, 0.75, 2.5))


def test_series_key_on_other_formats_is_refused(tmp_path):
    np.save(tmp_path / "v.npy", STORED)
    with pytest.raises(VolumeError, match="volume.series applies to dicom; this is npy"):
        load_volume(tmp_path / "v.npy", series="3")
    assert os.path.exists(tmp_path / "v.npy")


def retag(paths, change=None, replace=None):
    """Rewrite each slice: ``change(ds)`` on the dataset, then ``replace`` (old, new) in the file's bytes
    (how a value pydicom would not write, such as a DS of letters, gets into a file)."""
    for p in paths:
        if change is not None:
            ds = pydicom.dcmread(p)
            change(ds)
            ds.save_as(p)
        if replace is not None:
            blob = p.read_bytes()
            assert replace[0] in blob
            p.write_bytes(blob.replace(*replace))


def _set(keyword, value):
    return lambda ds: setattr(ds, keyword, value)


@pytest.mark.parametrize("change, replace, message", [
    # issue 40: internal errors before
    (lambda ds: delattr(ds, "Columns"), None, "slice_000.dcm: Columns is missing"),
    # found by fuzzing: a slice without Rows was taken for a non-image and left out (an end slice silently)
    (lambda ds: delattr(ds, "Rows"), None, "slice_000.dcm: Rows is missing"),
    (_set("SamplesPerPixel", None), None, "slice_000.dcm: SamplesPerPixel must be an integer >= 1, got nothing"),
    (_set("RescaleSlope", "9.99"), (b"9.99", b"abcd"), "RescaleSlope must be a finite number, got 'abcd'"),
    # issue 40: messages that blamed another tag, or the transfer function
    (_set("PixelSpacing", ["-2.8", "-2.8"]), None, r"PixelSpacing must hold 2 finite numbers > 0, got '-2.8\\-2.8'"),
    (_set("PixelSpacing", ["0", "0"]), None, r"PixelSpacing must hold 2 finite numbers > 0, got '0\\0'"),
    (_set("RescaleIntercept", "1e30"), None, "RescaleSlope 1 and RescaleIntercept 1e.30 take the stored values "
     r"-100 to -23 to values near 1e.30, where float32 cannot tell neighbouring stored values apart"),
    (_set("RescaleSlope", "1e37"), None, "outside the range of float32"),
    # found trying more
    (_set("RescaleSlope", "0"), None, "RescaleSlope is 0"),
    (_set("RescaleSlope", "nan"), None, "RescaleSlope must be a finite number, got 'nan'"),
    (_set("NumberOfFrames", "0"), None, "NumberOfFrames must be an integer >= 1, got '0'"),
    (_set("ImageOrientationPatient", ["0"] * 6), None, r"ImageOrientationPatient's row direction .* has length 0"),
    (_set("ImageOrientationPatient", ["1", "0", "0", "1", "0", "0"]), None,
     "ImageOrientationPatient's row and column directions are 0 degrees apart"),
    (_set("PhotometricInterpretation", "PALETTE COLOR"), None, "PhotometricInterpretation 'PALETTE COLOR'"),
    (_set("Rows", 0), None, "Rows must be an integer from 1 to 65535, got '0'"),
])
def test_bad_tags_are_named(tmp_path, change, replace, message):
    paths = write_series(tmp_path / "s")
    retag(paths, change, replace)
    with pytest.raises(VolumeError, match=message):
        load_volume(tmp_path / "s")


def test_bad_slice_thickness_of_a_single_slice_is_named(tmp_path):
    paths = write_series(tmp_path / "s", stored=STORED[:1])
    retag(paths, _set("SliceThickness", "7.77"), (b"7.77", b"thin"))
    with pytest.raises(VolumeError, match="SliceThickness must be a finite number, got 'thin'"):
        load_volume(tmp_path / "s")


def test_pydicom_prints_nothing(tmp_path, capfd):
    """pydicom warns about values it cannot convert; nothing of it reaches the terminal."""
    paths = write_series(tmp_path / "s")
    retag(paths, _set("RescaleSlope", "9.99"), (b"9.99", b"abcd"))
    with pytest.raises(VolumeError):
        load_volume(tmp_path / "s")
    retag(paths, None, (b"abcd", b"1.0 "))
    retag(paths[:1], _set("SeriesDescription", "x" * 80))  # too long for LO: pydicom warns when it reads it
    np.testing.assert_array_equal(load_volume(tmp_path / "s").data, STORED)
    assert capfd.readouterr() == ("", "")


def test_series_members_stay_in_the_sandbox(tmp_path):
    """Every member of a folder or glob is checked (links followed) before it is read: a member linked
    to an outside file is refused, not read and not skipped, and so is a glob or list reaching outside."""
    from dvr_gl.sandbox import Sandbox, SandboxError, active

    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    paths = write_series(root / "s")
    other = write_series(outside, stored=STORED[:1], names="far{:03d}.dcm")[0]
    (outside / "notes.txt").write_text("secret")
    with active(Sandbox(roots=(root,))):
        np.testing.assert_array_equal(load_volume(root / "s").data, STORED)
        for target in (other, outside / "notes.txt"):
            link = root / "s" / "zz_link.dcm"
            link.symlink_to(target)
            with pytest.raises(SandboxError, match="zz_link.dcm: the file of the series folder or glob lies "
                                                   "outside the allowed folders"):
                load_volume(root / "s")
            link.unlink()
        with pytest.raises(SandboxError, match="far000.dcm: the .* lies outside the allowed folders"):
            load_volume(str(root / "s" / ".." / ".." / "outside" / "*.dcm"))
        with pytest.raises(SandboxError, match="lies outside the allowed folders"):
            load_volume([*paths, other])


def test_a_damaged_element_is_named_only_where_it_is_used(tmp_path):
    """pydicom decodes an element when it is first used (fuzzing found an unknown VR raising in a later tag
    access): the tags the reader uses are decoded with the header and a damaged one named; a damaged tag
    it does not use is left alone."""
    paths = write_series(tmp_path / "s")
    retag(paths, _set("SliceLocation", "1"), (b"\x20\x00\x41\x10DS", b"\x20\x00\x41\x10U\xff"))  # unused
    np.testing.assert_array_equal(load_volume(tmp_path / "s").data, STORED)
    retag(paths, None, (b"\x28\x00\x53\x10DS", b"\x28\x00\x53\x10U\xff"))  # RescaleSlope
    with pytest.raises(VolumeError, match="RescaleSlope cannot be read .*Unknown Value Representation"):
        load_volume(tmp_path / "s")


def test_a_deflate_bomb_is_measured_against_the_budget(tmp_path):
    """pydicom inflates a deflated dataset whole: a 300 KB file inflating to 300 MB took 1.3 GB under a 50 MB
    budget; its size is now measured in chunks first, stopping past the budget."""
    from pydicom.uid import DeflatedExplicitVRLittleEndian

    from dvr_gl.sandbox import Sandbox, SandboxError, active

    paths = write_series(tmp_path / "s", syntax=DeflatedExplicitVRLittleEndian)
    np.testing.assert_array_equal(load_volume(tmp_path / "s").data, STORED)  # deflated slices read
    ds = pydicom.dcmread(paths[0])
    ds.add_new(0x00090010, "LO", "BOMB")
    ds.add_new(0x00091010, "OB", bytes(64 << 20))
    ds.save_as(paths[0])
    assert paths[0].stat().st_size < 1 << 20
    with active(Sandbox(max_bytes=16 << 20)):
        with pytest.raises(SandboxError, match=r"its deflated dataset, inflated, would take \d+ MiB, over the "
                                               r"memory budget of 16 MiB; raise the memory budget, or store"):
            load_volume(tmp_path / "s")


def test_reading_a_series_reports_progress(tmp_path):
    """A series of thousands of files takes minutes: its headers and pixels are reported as they are read."""
    from dvr_gl import progress

    write_series(tmp_path / "s")
    seen = []
    with progress.reporting(lambda done, total: seen.append((done, total))):
        load_volume(tmp_path / "s")
    assert seen.count((5, 5)) == 2 and (1, 5) in seen  # headers, then pixels
