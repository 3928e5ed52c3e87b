"""NIfTI-1/2 (``.nii``, ``.nii.gz``) through nibabel.

The voxel grid is used as stored (the voxel order is kept, x fastest).  Its place in the
patient comes from the sform when ``sform_code > 0``, else from the qform when
``qform_code > 0`` (NIfTI's methods 3 and 2): the affine's columns are the index axes'
steps (their lengths the spacing, their directions :attr:`Volume.direction`), its
translation the origin.  NIfTI states both in RAS; they are turned into LPS by negating
the first two rows.  With both codes 0 (method 1) the file states no orientation: spacing
from ``pixdim[1..3]``, origin 0, identity direction.

Before nibabel reads the voxels the header is checked here: 3 dimensions of at
least 1 voxel, a scalar ``datatype``, finite positive ``pixdim`` (nibabel would
silently take the absolute value of a negative one), the promised bytes against the
memory budget and, uncompressed, against the file's size.  nibabel's log messages
about headers it repairs are kept off the terminal.
"""

from __future__ import annotations

import contextlib
import math
import zlib
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path
from .common import RAS_TO_LPS, RawArray, axes_geometry, check_sample_type, check_spacing, require

MAX_GZIP_OFFSET = 64 << 20  # bytes: header and extensions; seeking a .nii.gz decodes all of them


def read_nifti(path: Path) -> RawArray:
    nib = require("nibabel", "nibabel", "nifti")
    path = check_input_path(Path(path), "NIfTI file")
    errors = (EOFError, zlib.error, OSError, ValueError, OverflowError, TypeError, IndexError, KeyError,
              nib.filebasedimages.ImageFileError, nib.spatialimages.HeaderDataError)
    try:
        with _quiet(nib.imageglobals.logger):
            img = nib.load(str(path))
            shape, scaled, spacing = _check_header(nib, img, path)
            proxy = img.dataobj
            arr = np.asarray(proxy) if scaled else np.asarray(proxy.get_unscaled())
            affine, field = _patient_affine(img.header)
    except errors as exc:
        raise VolumeError(f"{path}: NIfTI file is truncated or corrupt ({exc})") from None
    data = np.ascontiguousarray(arr.reshape(shape).transpose(2, 1, 0))  # nibabel indexes (i, j, k): x first
    if affine is None:
        return RawArray(data, spacing, (0.0, 0.0, 0.0))
    lps = RAS_TO_LPS @ affine[:3]
    origin = tuple(float(v) for v in lps[:, 3])
    if not all(math.isfinite(v) for v in origin):
        raise VolumeError(f"{path}: the {field} offsets give origin {origin}; they must be finite")
    spacing, direction = axes_geometry(lps[:, :3].T, str(path), field)
    return RawArray(data, spacing, origin, direction)


def _patient_affine(header):
    """The affine that places the voxels in the patient (RAS, mm) and the field it comes from: the sform
    when its code is > 0, else the qform when its code is > 0, else None (no orientation stated)."""
    if int(header["sform_code"]) > 0:
        return header.get_sform(), "sform (srow_x, srow_y, srow_z)"
    if int(header["qform_code"]) > 0:
        return header.get_qform(), "qform (quatern_b/c/d, pixdim, qoffset)"
    return None, None


@contextlib.contextmanager
def _quiet(logger):
    """Keep nibabel's messages about headers it repairs off the terminal (its own
    LoggingOutputSuppressor removes the handler, and Python's last-resort handler prints them)."""
    disabled, logger.disabled = logger.disabled, True
    try:
        yield
    finally:
        logger.disabled = disabled


def _check_header(nib, img, path: Path) -> tuple[tuple, bool, tuple]:
    """The 3D shape, whether the data is scaled and the spacing, after the header's checks."""
    header = img.header
    shape = tuple(int(s) for s in header.get_data_shape())
    if len(shape) < 3 or any(s != 1 for s in shape[3:]) or min(shape) < 1:
        raise VolumeError(f"{path}: dim gives shape {shape}; a volume needs 3 dimensions of at least 1 voxel "
                          f"(extract one 3D volume first)")
    shape = shape[:3]
    dtype = header.get_data_dtype()
    check_sample_type(dtype, str(path), "datatype", str(dtype))
    # nibabel's loaded header has negative pixdim already made positive: check the stored one
    with nib.openers.ImageOpener(str(path)) as stored:
        pixdim = type(header).from_fileobj(stored, check=False)["pixdim"]
    spacing = check_spacing(pixdim[1:4], str(path), "pixdim[1..3]")
    proxy = img.dataobj
    slope, inter = getattr(proxy, "slope", 1.0), getattr(proxy, "inter", 0.0)
    scaled = not (np.isnan(slope) or slope in (0.0, 1.0)) or not (np.isnan(inter) or inter == 0.0)
    count = math.prod(shape)
    nbytes = count * dtype.itemsize
    check_bytes(nbytes + 8 * count * scaled, f"{path}: the {shape} volume its header promises",
                "check dim in the header, or raise the memory budget")
    offset = int(proxy.offset)  # after nibabel's repair of a vox_offset of 0
    if path.name.lower().endswith(".gz"):
        if offset > MAX_GZIP_OFFSET:
            raise VolumeError(f"{path}: vox_offset {offset} is beyond any header and extensions "
                              f"({MAX_GZIP_OFFSET} bytes); fix the header")
    elif path.stat().st_size < offset + nbytes:
        raise VolumeError(f"{path}: the file holds {path.stat().st_size} bytes, but vox_offset {offset} and "
                          f"{shape} of {dtype} need {offset + nbytes}; the file is truncated or the header wrong")
    return shape, scaled, spacing
