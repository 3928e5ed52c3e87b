"""Inputs for fuzzing the volume readers: small valid files of every format, their mutations,
and the one property every reader must have.

Mutations: bytes (set, insert, delete, truncate) for every file; header lines for text headers; for
DICOM series (issue 40) a tag the reader uses set to a bad token or deleted, written by pydicom
unchecked; for ``.vti`` an XML attribute set to a bad token (extents among them) or an element
dropped or duplicated.  A folder (DICOM series, TIFF slices) is a seed whose ``main`` is ``""``.

Shared by ``tests/io/test_fuzz_readers.py`` (hypothesis draws the ``random.Random``, a bounded
number of examples in CI) and ``benchmarks/fuzz_readers.py`` (a long seeded run with a table).

The property: reading a mutated file either raises a :class:`DvrError` (a user error, one line)
or returns a valid :class:`Volume` (3D, finite samples, finite positive spacing) or particle set
(finite positions and values, positive smoothing lengths and densities), printing
nothing, within
:data:`TIMEOUT` seconds and :data:`BUDGET` bytes of the sandbox's memory budget.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import io
import math
import os
import random
import re
import signal
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dvr_gl.errors import DvrError
from dvr_gl.io import PARTICLE_FORMATS, load_field, load_volume
from dvr_gl.sandbox import Sandbox, active

TIMEOUT = 5.0  # seconds per example: each reads at most a few KB, so this is a hang, not a slow machine
BUDGET = 64 << 20  # bytes: the sandbox's memory budget while fuzzing (nothing huge is allocated)
DATA = (np.arange(4 * 3 * 2, dtype=np.int16).reshape(2, 3, 4) * 37 - 300)  # [z, y, x]
# Field values of the wrong type or range, as a header would hold them.
BAD_TOKENS = ["", "0", "-1", "1", "2", "32.5", "1e30", "1e-300", "-0", "nan", "inf", "-inf", "banana",
              "99999999999999999999", "0x10", "(1,2)", "(nan,0,0)", "none", "True", "LOCAL", "-1 -1 -1",
              "4 3", "4 3 2 1", "1 1 1", "1e308 1e308 1e308", "\u00e9", "%d", "../../../etc/passwd",
              "100000000", "float128", "complex64", "MET_FLOAT", "gzip", "bzip2", "ascii", "big", "little"]


@dataclass
class Seed:
    """A valid input: files by name, the one to load, and load_volume's keyword arguments."""

    reader: str
    files: dict[str, bytes]
    main: str
    options: dict = field(default_factory=dict)
    text: tuple[str, ...] = ()  # files whose header is text (line mutations apply)
    link: Path | None = None  # a folder whose data files are linked beside the header


def _nifti(gz: bool) -> bytes:
    import nibabel as nib

    img = nib.Nifti1Image(DATA.transpose(2, 1, 0), np.diag([0.5, 1.0, 2.0, 1.0]))
    blob = img.to_bytes()
    return gzip.compress(blob, mtime=0) if gz else blob


def _tiff() -> bytes:
    import tempfile

    import OpenImageIO as oiio

    slices = list(DATA.astype(np.uint16))
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "s.tif")
        specs = [oiio.ImageSpec(4, 3, 1, oiio.UINT16) for _ in slices]
        out = oiio.ImageOutput.create(path)
        out.open(path, specs)
        for i, s in enumerate(slices):
            if i:
                out.open(path, specs[i], "AppendSubimage")
            out.write_image(np.ascontiguousarray(s[..., None]))
        out.close()
        return Path(path).read_bytes()


def _tiff_slices() -> dict[str, bytes]:
    """A folder of one-page TIFF slices (natural order: s2 before s10)."""
    import tempfile

    import OpenImageIO as oiio

    files = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, s in enumerate(DATA.astype(np.uint16)):
            path = os.path.join(tmp, f"s{i}.tif")
            out = oiio.ImageOutput.create(path)
            out.open(path, oiio.ImageSpec(4, 3, 1, oiio.UINT16))
            out.write_image(np.ascontiguousarray(s[..., None]))
            out.close()
            files[f"s{i}.tif"] = Path(path).read_bytes()
    return files


# The DICOM tags the series reader uses, and their value representations.
DICOM_TAGS = {"Rows": "US", "Columns": "US", "SamplesPerPixel": "US", "NumberOfFrames": "IS",
              "PhotometricInterpretation": "CS", "BitsAllocated": "US", "BitsStored": "US",
              "PixelRepresentation": "US", "ImageOrientationPatient": "DS", "ImagePositionPatient": "DS",
              "PixelSpacing": "DS", "RescaleSlope": "DS", "RescaleIntercept": "DS", "SliceThickness": "DS",
              "SeriesInstanceUID": "UI", "SeriesNumber": "IS"}


# --- channels and time steps (issue 42): hyperstacks and NIfTI 4D/5D --------------------------------------

# A hyperstack of 2 time points, 2 slices, 2 channels of 4 x 3 pixels: ImageJ's and OME-TIFF's descriptions.
HYPERSTACK = {
    "h.tif": "ImageJ=1.54f\nimages=8\nchannels=2\nslices=2\nframes=2\nhyperstack=true\nunit=micron\nspacing=2\n"
             "finterval=1.5\n",
    "o.tif": '<OME><Image ID="Image:0"><Pixels DimensionOrder="XYCZT" SizeX="4" SizeY="3" SizeZ="2" SizeC="2" '
             'SizeT="2" PhysicalSizeX="0.5" PhysicalSizeZ="2" TimeIncrement="3"><Channel Name="a"/><Channel '
             'Name="b"/><TiffData IFD="0" PlaneCount="8"/></Pixels></Image></OME>',
}
# NIfTI files of 4 or 5 dimensions: the extra axes and the intent code (1007: a vector, so channels).
NIFTI_ND = {"t.nii": ((3,), 0), "v.nii": ((2,), 1007), "f.nii.gz": ((2, 2), 0)}


def _hyperstack(description: str, pages: int = 8) -> bytes:
    """``pages`` grey 4 x 3 pages (value 100 k + the pixel's index) with ``description`` on each."""
    import tempfile

    import OpenImageIO as oiio

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "h.tif")
        specs = []
        for _ in range(pages):
            specs.append(oiio.ImageSpec(4, 3, 1, oiio.UINT16))
            specs[-1].attribute("ImageDescription", description)
            specs[-1].attribute("XResolution", 2.0)
            specs[-1].attribute("YResolution", 2.0)
        out = oiio.ImageOutput.create(path)
        out.open(path, specs)
        for k in range(pages):
            if k:
                out.open(path, specs[k], "AppendSubimage")
            out.write_image(np.ascontiguousarray((100 * k + np.arange(12, dtype=np.uint16)).reshape(3, 4, 1)))
        out.close()
        return Path(path).read_bytes()


def _nifti_nd(extra: tuple, intent: int, gz: bool) -> bytes:
    import nibabel as nib

    data = DATA.transpose(2, 1, 0).reshape(4, 3, 2, *(1,) * len(extra)) + np.zeros((1, 1, 1) + extra, np.int16)
    for k in range(int(np.prod(extra))):  # each step and channel its own values
        np.reshape(data, (4, 3, 2, -1))[..., k] += k
    img = nib.Nifti1Image(data, np.diag([0.5, 1.0, 2.0, 1.0]))
    if intent:
        img.header["intent_code"] = intent
    img.header.set_xyzt_units(2, 8)
    blob = img.to_bytes()
    return gzip.compress(blob, mtime=0) if gz else blob


def mutate_description(name: str, rnd: random.Random) -> tuple[bytes, str]:
    """A hyperstack written again with its description's count, order or map set to a bad token (a count of
    zero, below zero, huge, not a number) or a line dropped, or with pages that do not match it."""
    import re

    text = HYPERSTACK[name]
    tokens = BAD_TOKENS + ["0", "-3", "3", "16", "999999999", "1048577", "XYZCT", "XYZZT", "YXZCT"]
    found = list(re.finditer(r'(\w+)="([^"]*)"', text)) if text.startswith("<") else \
        list(re.finditer(r"^(\w+)=(.*)$", text, re.M))
    m = rnd.choice(found)
    token = rnd.choice(tokens)
    if rnd.random() < 0.15:
        text, what = text[:m.start()] + text[m.end():], f"drop {m.group(1)}"
    else:
        text, what = text[:m.start(2)] + token + text[m.end(2):], f"{m.group(1)} -> {token!r}"
    pages = rnd.choice([8, 8, 8, 1, 7, 9, 16])
    return _hyperstack(text, pages), f"{what}, {pages} pages"


def mutate_nifti_header(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A NIfTI-1 header's dim[k], intent_code, pixdim[4] or xyzt_units set to a bad value."""
    import struct

    gz = blob[:2] == b"\x1f\x8b"
    raw = bytearray(gzip.decompress(blob) if gz else blob)
    field = rnd.choice(["dim", "dim", "intent", "pixdim4", "units"])
    if field == "dim":
        k, value = rnd.randrange(8), rnd.choice([0, -1, 1, 2, 3, 5, 6, 7, 8, 32767, -32768])
        struct.pack_into("<h", raw, 40 + 2 * k, value)
        what = f"dim[{k}] = {value}"
    elif field == "intent":
        value = rnd.choice([0, 1006, 1007, 2001, 2003, 2004, 9999, -1])
        struct.pack_into("<h", raw, 68, value)
        what = f"intent_code = {value}"
    elif field == "pixdim4":
        value = rnd.choice([0.0, -1.0, float("nan"), float("inf"), 1e30, 1e-30])
        struct.pack_into("<f", raw, 76 + 16, value)
        what = f"pixdim[4] = {value}"
    else:
        value = rnd.randrange(256)
        raw[123] = value
        what = f"xyzt_units = {value}"
    out = bytes(raw)
    return (gzip.compress(out, mtime=0) if gz else out), what


def _dicom_slice(pixels: np.ndarray, z: float, uid: str, slope=1.0, intercept=0.0) -> bytes:
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian

    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = CTImageStorage
    meta.MediaStorageSOPInstanceUID = f"1.2.3.4.{int(z * 10)}"
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
    ds.SeriesInstanceUID, ds.SeriesNumber, ds.Modality = uid, 3, "CT"
    ds.ImageOrientationPatient = ["1", "0", "0", "0", "1", "0"]
    ds.ImagePositionPatient = ["-1", "2", f"{z:g}"]
    ds.PixelSpacing, ds.SliceThickness = ["0.75", "0.5"], "2"
    ds.RescaleSlope, ds.RescaleIntercept = f"{slope:g}", f"{intercept:g}"
    ds.Rows, ds.Columns = pixels.shape
    ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
    ds.PixelData = pixels.astype("<i2").tobytes()
    buf = io.BytesIO()
    ds.save_as(buf, enforce_file_format=True)
    return buf.getvalue()


def _dicom_series() -> dict[str, bytes]:
    """Three slices 2 mm apart, their names out of position order; or {} without pydicom."""
    try:
        import pydicom  # noqa: F401
    except ImportError:
        return {}
    stack = np.concatenate([DATA, DATA[:1] + 5])
    return {f"IM{k}": _dicom_slice(stack[i], 2.0 * i, "1.2.3.9", slope=2, intercept=-10)
            for k, i in zip((2, 0, 1), range(3))}


def _vti(fmt: str, compressed: bool = False, appended_encoding: str = "raw") -> bytes:
    """DATA as VTK XML image data (float32; header UInt32, little-endian) in one encoding, laid out as
    VTK's vtkXMLWriter writes it (see tests/io/test_io_vti.py)."""
    import base64

    raw = DATA.astype("<f4").tobytes()
    if compressed:
        blocks = [zlib.compress(raw[i:i + 32]) for i in range(0, len(raw), 32)]
        head = np.array([len(blocks), 32, len(raw) % 32] + [len(b) for b in blocks], "<u4").tobytes()
        body = b"".join(blocks)
        stream = (base64.b64encode(head) + base64.b64encode(body)) if fmt == "binary" or \
            appended_encoding == "base64" else head + body
    else:
        sized = np.array([len(raw)], "<u4").tobytes() + raw
        stream = base64.b64encode(sized) if fmt == "binary" or appended_encoding == "base64" else sized
    if fmt == "ascii":
        array = f'format="ascii">{" ".join(f"{v:g}" for v in DATA.ravel())}</DataArray>'
    elif fmt == "binary":
        array = f'format="binary">{stream.decode()}</DataArray>'
    else:
        array = 'format="appended" offset="0"/>'
    xml = ('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
           'header_type="UInt32"' + (' compressor="vtkZLibDataCompressor"' if compressed else "") + '>\n'
           '<ImageData WholeExtent="0 3 0 2 0 1" Origin="1 2 3" Spacing="0.5 1 2">\n'
           '<Piece Extent="0 3 0 2 0 1">\n<PointData Scalars="s">\n'
           f'<DataArray type="Float32" Name="s" NumberOfComponents="1" {array}\n'
           '</PointData>\n</Piece>\n</ImageData>\n')
    if fmt == "appended":
        xml += f'<AppendedData encoding="{appended_encoding}">\n_'
        return xml.encode() + stream + b"\n</AppendedData>\n</VTKFile>\n"
    return (xml + "</VTKFile>\n").encode()


def _vti_pieces() -> bytes:
    """DATA in two ascii pieces that share the plane z = 0 (as VTK splits an extent by cells)."""
    blob = _vti("ascii").decode()
    piece = '<Piece Extent="{}">\n<PointData Scalars="s">\n<DataArray type="Float32" Name="s" format="ascii">{}' \
            '</DataArray>\n</PointData>\n</Piece>\n'
    two = piece.format("0 3 0 2 0 0", " ".join(f"{v:g}" for v in DATA[0].ravel())) + \
        piece.format("0 3 0 2 0 1", " ".join(f"{v:g}" for v in DATA.ravel()))
    start, end = blob.index("<Piece"), blob.index("</Piece>") + len("</Piece>\n")
    return (blob[:start] + two + blob[end:]).encode()


#: a colour volume's voxels [z, y, x, rgb] (8-bit sRGB codes)
RGB = (np.arange(2 * 3 * 4 * 3) * 11 % 256).astype(np.uint8).reshape(2, 3, 4, 3)


def _rgba16() -> bytes:
    alpha = np.full(RGB.shape[:3] + (1,), 40000, "<u2")
    return np.concatenate([RGB.astype("<u2") * 257, alpha], axis=3).tobytes()


def _npy(data=None) -> bytes:
    buf = io.BytesIO()
    np.save(buf, DATA if data is None else data)
    return buf.getvalue()


def _particle_csv() -> bytes:
    rows = ["x,y,z,h,m,rho,u", "0,0,0,1,1,2,5", "1.5,0,0,0.5,2,1,6", "0,-1,2,1.25,1,0.5,7"]
    return ("\n".join(rows) + "\n").encode()


def _particle_npz() -> bytes:
    buf = io.BytesIO()
    np.savez(buf, positions=np.array([[0.0, 0, 0], [1.5, 0, 0], [0, -1, 2]]), h=np.array([1.0, 0.5, 1.25]),
             m=np.array([1.0, 2, 1]), rho=np.array([2.0, 1, 0.5]))
    return buf.getvalue()


def _particle_hdf5() -> bytes:
    try:
        import h5py
    except ImportError:
        return b""
    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        gas = f.create_group("PartType0")
        gas["Coordinates"] = np.array([[0.0, 0, 0], [1.5, 0, 0], [0, -1, 2]])
        gas["SmoothingLength"] = np.array([2.0, 1.0, 2.5])
        gas["Masses"] = np.array([1.0, 2, 1], np.float32)
        gas["Density"] = np.array([2.0, 1, 0.5], np.float32)
    return buf.getvalue()


def seeds() -> list[Seed]:
    """One small valid file set per reader and encoding (4x3x2 int16 samples)."""
    be, le = DATA.astype(">i2").tobytes(), DATA.astype("<i2").tobytes()
    nrrd = "NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 3 2\nspacings: 0.5 1 2\nendian: {}\nencoding: {}\n"
    colour = ("NRRD0004\ntype: {}\ndimension: 4\nsizes: {} 4 3 2\nkinds: {} domain domain domain\nendian: little\n"
              "encoding: raw\nspacings: nan 0.5 1 2\n")
    mhd = ("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
           "CompressedData = {}\nElementSpacing = 0.5 1 2\nOffset = 1 2 3\nDimSize = 4 3 2\n"
           "ElementType = MET_SHORT\nHeaderSize = 0\nElementDataFile = {}\n")
    vtk = ("# vtk DataFile Version 3.0\nseed\n{}\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 3 2\n"
           "SPACING 0.5 1 2\nORIGIN 1 2 3\nPOINT_DATA 24\nSCALARS s short 1\nLOOKUP_TABLE default\n")
    return [
        Seed("raw", {"v.raw": b"HEAD" + le}, "v.raw", dict(dims=(4, 3, 2), dtype="int16", header_bytes=4)),
        Seed("raw", {"v.raw.gz": gzip.compress(le, mtime=0)}, "v.raw.gz", dict(dims=(4, 3, 2), dtype="int16")),
        Seed("nrrd", {"v.nrrd": nrrd.format("big", "raw").encode() + b"\n" + be}, "v.nrrd", text=("v.nrrd",)),
        Seed("nrrd", {"v.nhdr": (nrrd.format("big", "gzip") + "data file: v.raw.gz\n").encode(),
                      "v.raw.gz": gzip.compress(be, mtime=0)}, "v.nhdr", text=("v.nhdr",)),
        Seed("nrrd", {"v.nhdr": (nrrd.format("little", "bzip2") + "byte skip: 2\ndata file: v.raw.bz2\n").encode(),
                      "v.raw.bz2": bz2.compress(b"\0\0" + le)}, "v.nhdr", text=("v.nhdr",)),
        Seed("nrrd", {"v.nhdr": (nrrd.format("big", "ascii") + "line skip: 1\ndata file: v.txt\n").encode(),
                      "v.txt": b"# values\n" + " ".join(map(str, DATA.ravel())).encode()}, "v.nhdr",
             text=("v.nhdr", "v.txt")),
        Seed("metaimage", {"v.mha": mhd.format("False", "LOCAL").encode() + le}, "v.mha", text=("v.mha",)),
        Seed("metaimage", {"v.mhd": mhd.format("True", "v.zraw").encode(), "v.zraw": zlib.compress(le)},
             "v.mhd", text=("v.mhd",)),
        Seed("vtk", {"v.vtk": vtk.format("BINARY").encode() + be + b"\n"}, "v.vtk", text=("v.vtk",)),
        Seed("vtk", {"v.vtk": (vtk.format("ASCII") + " ".join(map(str, DATA.ravel())) + "\n").encode()},
             "v.vtk", text=("v.vtk",)),
        Seed("npy", {"v.npy": _npy()}, "v.npy"),
        # colour volumes (dvr_gl/fields/color.py): by the header's kind, by the role, RGBA 16-bit, an npy
        Seed("nrrd", {"c.nrrd": colour.format("uint8", "3", "RGB-color").encode() + b"\n" + RGB.tobytes()}, "c.nrrd",
             text=("c.nrrd",)),
        Seed("nrrd", {"c.nrrd": colour.format("uint8", "3", "vector").encode() + b"\n" + RGB.tobytes()}, "c.nrrd",
             dict(role="rgb"), text=("c.nrrd",)),
        Seed("nrrd", {"c.nrrd": colour.format("uint16", "4", "RGBA-color").encode() + b"\n" + _rgba16()}, "c.nrrd",
             text=("c.nrrd",)),
        Seed("npy", {"c.npy": _npy(RGB)}, "c.npy", dict(role="rgb")),
        Seed("nifti", {"v.nii": _nifti(False)}, "v.nii"),
        Seed("nifti", {"v.nii.gz": _nifti(True)}, "v.nii.gz"),
        Seed("tiff", {"s.tif": _tiff()}, "s.tif"),
        Seed("tiff", {"h.tif": _hyperstack(HYPERSTACK["h.tif"])}, "h.tif", dict(time=1)),
        Seed("tiff", {"o.tif": _hyperstack(HYPERSTACK["o.tif"])}, "o.tif"),
        Seed("tiff", {"o.tif": _hyperstack(HYPERSTACK["o.tif"])}, "o.tif", dict(channel=1, time=1)),
        *[Seed("nifti", {name: _nifti_nd(extra, intent, name.endswith(".gz"))}, name,
               dict(time=1) if len(extra) == 2 or not intent else {}) for name, (extra, intent) in NIFTI_ND.items()],
        Seed("tiff", _tiff_slices(), ""),
        Seed("vti", {"v.vti": _vti("ascii")}, "v.vti"),
        Seed("vti", {"v.vti": _vti("binary")}, "v.vti"),
        Seed("vti", {"v.vti": _vti("binary", compressed=True)}, "v.vti"),
        Seed("vti", {"v.vti": _vti("appended")}, "v.vti"),
        Seed("vti", {"v.vti": _vti("appended", compressed=True)}, "v.vti"),
        Seed("vti", {"v.vti": _vti("appended", appended_encoding="base64")}, "v.vti"),
        Seed("vti", {"v.vti": _vti_pieces()}, "v.vti"),
        *([Seed("dicom", _dicom_series(), "")] if _dicom_series() else []),
        Seed("csv", {"p.csv": _particle_csv()}, "p.csv", text=("p.csv",)),
        Seed("npz", {"p.npz": _particle_npz()}, "p.npz"),
        *([Seed("hdf5", {"p.hdf5": _particle_hdf5()}, "p.hdf5")] if _particle_hdf5() else []),
    ]


def shared_seeds(shared: Path) -> list[Seed]:
    """The text headers in the shared datasets folder; their data files are linked, not copied."""
    found = []
    for header in sorted([*shared.glob("*/*.nhdr"), *shared.glob("*/*.mhd")]):
        reader = "nrrd" if header.suffix == ".nhdr" else "metaimage"
        found.append(Seed(reader, {header.name: header.read_bytes()}, header.name, text=(header.name,),
                          link=header.parent))
    vtk = shared / "regular" / "ironProt.vtk"
    if vtk.is_file():
        found.append(Seed("vtk", {vtk.name: vtk.read_bytes()}, vtk.name, text=(vtk.name,)))
    return found


# --- mutations ------------------------------------------------------------------------------------

def mutate_bytes(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A random byte-level change: set, insert, delete or truncate."""
    b = bytearray(blob)
    kind = rnd.choice(["set", "set", "insert", "delete", "truncate"])
    at = rnd.randrange(len(b) + 1)
    if kind == "set" and b:
        for _ in range(rnd.randint(1, 4)):
            b[rnd.randrange(len(b))] = rnd.choice([0, 0xFF, 0x7F, 0x80, rnd.randrange(256)])
    elif kind == "insert":
        b[at:at] = bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 8)))
    elif kind == "delete":
        del b[at:at + rnd.randint(1, 16)]
    else:
        del b[at:]
    return bytes(b), f"{kind} at {at}"


def mutate_lines(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A random change to the header's lines: a value replaced by a bad token, a line dropped,
    duplicated or swapped, or the header cut; binary data after the header is kept."""
    head, sep, tail = _split_header(blob)
    lines = head.split(b"\n")
    i = rnd.randrange(len(lines))
    kind = rnd.choice(["value", "value", "value", "drop", "duplicate", "swap", "cut"])
    if kind == "value":
        line = lines[i].decode("latin-1")
        cut = max(line.find(":"), line.find("="), line.find(" "))
        token = rnd.choice(BAD_TOKENS)
        lines[i] = ((line[:cut + 1] + " " if cut >= 0 else "") + token).encode("utf-8")
        what = f"line {i} value -> {token!r}"
    elif kind == "drop":
        del lines[i]
        what = f"drop line {i}"
    elif kind == "duplicate":
        lines.insert(i, lines[i])
        what = f"duplicate line {i}"
    elif kind == "swap":
        j = rnd.randrange(len(lines))
        lines[i], lines[j] = lines[j], lines[i]
        what = f"swap lines {i}, {j}"
    else:
        return head[:rnd.randrange(len(head) + 1)], "cut the header"
    return b"\n".join(lines) + sep + tail, what


def _split_header(blob: bytes) -> tuple[bytes, bytes, bytes]:
    """(header text, separator, the rest): the rest starts after the NRRD blank line, the
    MetaImage ElementDataFile line or the VTK LOOKUP_TABLE line."""
    for marker in (b"\n\n", b"ElementDataFile = LOCAL\n", b"LOOKUP_TABLE default\n"):
        at = blob.find(marker)
        if at >= 0:
            end = at + len(marker)
            return blob[:end - 1], b"\n", blob[end:]
    return blob, b"", b""


def mutate_xml(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A VTK XML attribute's value (before any appended data) replaced by a bad token, or an element
    dropped or duplicated."""
    import re

    end = blob.find(b"<AppendedData")
    head = blob if end < 0 else blob[:end]
    if rnd.random() < 0.7:
        found = list(re.finditer(rb'(\w+)="([^"]*)"', head))
        m = rnd.choice(found)
        token = rnd.choice(BAD_TOKENS + ["0 3 0 2 0 0", "0 3 0 2 1 1", "-1 3 0 2 0 1", "0 30 0 2 0 1", "0 0 0 0 0 0"])
        return blob[:m.start(2)] + token.encode("utf-8") + blob[m.end(2):], f"{m.group(1).decode()} -> {token!r}"
    found = list(re.finditer(rb"<(Piece|DataArray|PointData)\b.*?</\1>", head, re.S))
    if not found:
        return mutate_bytes(blob, rnd)
    m = rnd.choice(found)
    twice = rnd.random() < 0.5
    return blob[:m.start()] + (m.group(0) * 2 if twice else b"") + blob[m.end():], \
        f"{'duplicate' if twice else 'drop'} a {m.group(1).decode()}"


def mutate_dicom(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A tag the series reader uses set to a bad token (as pydicom writes it, unchecked), or deleted."""
    import warnings

    import pydicom
    from pydicom.dataelem import DataElement

    ds = pydicom.dcmread(io.BytesIO(blob), force=True)
    keyword = rnd.choice(sorted(DICOM_TAGS))
    token = rnd.choice(BAD_TOKENS)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if rnd.random() < 0.2:
                if keyword in ds:
                    del ds[keyword]
                token = "(deleted)"
            else:
                vr = DICOM_TAGS[keyword]
                value = int(token) if vr == "US" else token.replace(" ", "\\")
                tag = pydicom.datadict.tag_for_keyword(keyword)
                ds[tag] = DataElement(tag, vr, value, validation_mode=pydicom.config.IGNORE)
            out = io.BytesIO()
            ds.save_as(out)
    except Exception:  # noqa: BLE001 - a value pydicom cannot write (a US of letters): mutate the bytes
        return mutate_bytes(blob, rnd)
    return out.getvalue(), f"{keyword} -> {token!r}"


def mutate(seed: Seed, rnd: random.Random) -> tuple[dict[str, bytes], str]:
    """A mutated copy of ``seed``'s files and what was changed."""
    files = dict(seed.files)
    name = rnd.choice(sorted(files))
    if seed.reader in ("dicom", "vti") and rnd.random() < 0.6:
        files[name], what = (mutate_dicom if seed.reader == "dicom" else mutate_xml)(files[name], rnd)
    elif name in HYPERSTACK and rnd.random() < 0.6:
        files[name], what = mutate_description(name, rnd)
    elif name in NIFTI_ND and rnd.random() < 0.6:
        files[name], what = mutate_nifti_header(files[name], rnd)
    elif name in seed.text and rnd.random() < 0.7:
        files[name], what = mutate_lines(files[name], rnd)
    else:
        files[name], what = mutate_bytes(files[name], rnd)
    return files, f"{name}: {what}"


# --- the property ---------------------------------------------------------------------------------

class Hang(BaseException):
    """A reader ran past TIMEOUT: a BaseException, as the sandbox's own timer, so that no reader's turning of
    a library's exceptions into one line (meshio's, zarr's) hides it."""


@contextlib.contextmanager
def time_limit(seconds: float):
    def alarm(signum, frame):
        raise Hang(f"no result after {seconds} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def write_case(folder: Path, seed: Seed, files: dict[str, bytes]) -> Path:
    """Write ``files`` into an empty ``folder`` (linking a shared header's data files)."""
    for old in folder.iterdir():
        old.unlink()
    if seed.link is not None:
        for data in seed.link.iterdir():
            if data.suffix not in (".nhdr", ".mhd", ".md", ".txt"):
                (folder / data.name).symlink_to(data)
    for name, blob in files.items():
        (folder / name).write_bytes(blob)
    return folder / seed.main


def check_reader(path: Path, seed: Seed) -> str:
    """``user error`` or ``volume``; any other exception (or a hang) propagates."""
    printed = io.StringIO()
    try:
        with active(Sandbox(max_bytes=BUDGET)), time_limit(TIMEOUT), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            volume = (load_field if seed.reader in PARTICLE_FORMATS else load_volume)(path, **seed.options)
    except DvrError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return "user error"
    finally:  # a library's log line or warning would reach the user's terminal
        assert not printed.getvalue(), f"printed {printed.getvalue()[:200]!r}"
    if volume.kind == "particles":
        assert len(volume) > 0 and np.isfinite(volume.positions).all() and np.isfinite(volume.values).all()
        assert (volume.smoothing_lengths > 0).all() and (volume.densities > 0).all()
        return "volume"
    for member in getattr(volume, "members", ()):  # a file's channels: each a valid volume
        _check_grid(member.field)
    if volume.kind != "fields":
        _check_grid(volume)
    return "volume"


def _check_grid(volume) -> None:
    data = volume.data
    if getattr(volume, "role", None) == "rgb":  # a colour volume: four components in [0, 1]
        assert data.ndim == 4 and data.shape[3] == 4 and np.all((data >= 0) & (data <= 1))
        data = data[..., 3]
    assert data.ndim == 3 and data.size > 0
    assert data.dtype.kind != "f" or np.isfinite(data).all()
    assert len(volume.spacing) == 3 and all(math.isfinite(s) and s > 0 for s in volume.spacing)
    assert all(math.isfinite(o) for o in volume.origin)


# --- colour tables of label maps (dvr_gl/labels/readers.py) -------------------------------------------

#: A valid table of each format a label map's ``transfer_function.file`` reads, by file name.
COLOR_TABLES = {
    "labels.ctbl": b"# Color table file /tmp/labels.ctbl\n# 4 values\n0 Background 0 0 0 0\n1 tissue 128 174 128 255\n"
                   b"2 bone 241 214 145 255\n7 vessel 216 101 79 128\n",
    "slicer.txt": b"0 Background 0 0 0 0\n1 tissue 128 174 128 255\n2 bone 241 214 145 255\n7 vessel 216 101 79 128\n",
    "itksnap.txt": b"################################################\n# ITK-SnAP Label Description File\n"
                   b"# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL\n################################################\n"
                   b'    0     0    0    0        0  0  0    "Clear Label"\n'
                   b'    1   255    0    0        1  1  1    "Label 1 (liver)"\n'
                   b'    2     0  255    0      0.5  1  1    "Label 2"\n'
                   b'    3     0    0  255        1  0  1    "Hidden"\n',
    "seg.seg.nrrd": b"NRRD0004\n# Complete NRRD file format specification at:\ntype: unsigned char\ndimension: 3\n"
                    b"space: left-posterior-superior\nsizes: 2 2 2\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
                    b"kinds: domain domain domain\nencoding: raw\nspace origin: (0,0,0)\n"
                    b"Segment0_Color:=0.2 0.6 0.3\nSegment0_ID:=Segment_1\nSegment0_LabelValue:=1\nSegment0_Layer:=0\n"
                    b"Segment0_Name:=kidney\nSegment1_Color:=0.9 0.5 0.1\nSegment1_ID:=Segment_2\n"
                    b"Segment1_LabelValue:=4\nSegment1_Layer:=0\nSegment1_Name:=tumour\n\n"
                    + bytes([0, 1, 1, 4, 0, 0, 4, 1]),
}


def mutate_color_table(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A byte-level change, or a line's word replaced by a bad token (or a line dropped, duplicated,
    swapped, the text cut: :func:`mutate_lines`)."""
    if rnd.random() < 0.4:
        return mutate_bytes(blob, rnd)
    if rnd.random() < 0.5:
        return mutate_lines(blob, rnd)
    words = list(re.finditer(rb"[^\s:=]+", blob))
    m = rnd.choice(words)
    token = rnd.choice(BAD_TOKENS + ["256", "-1", "1.5", "99999999999999999999", '"', "16777217"]).encode("utf-8")
    return blob[:m.start()] + token + blob[m.end():], f"word at {m.start()} -> {token!r}"


def check_color_table(path: Path) -> str:
    """``user error`` or ``table`` (labels distinct integers, colours and opacities in [0, 1]); any other
    exception (or a hang) propagates."""
    from dvr_gl.labels import read_color_table

    printed = io.StringIO()
    try:
        with active(Sandbox(max_bytes=BUDGET)), time_limit(TIMEOUT), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            table = read_color_table(path)
    except DvrError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return "user error"
    finally:
        assert not printed.getvalue(), f"printed {printed.getvalue()[:200]!r}"
    assert len(table) > 0 and np.all(np.diff(table.labels) > 0)
    assert np.all((table.colors >= 0) & (table.colors <= 1)) and np.all((table.opacity >= 0) & (table.opacity <= 1))
    assert np.isfinite(table.texture_table()).all()
    return "table"
