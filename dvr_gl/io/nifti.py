"""NIfTI-1/2 (``.nii``, ``.nii.gz``) through nibabel.

The voxel grid is used as stored (the voxel order is kept, x fastest).  Its place in the
patient comes from the sform when ``sform_code > 0``, else from the qform when
``qform_code > 0`` (NIfTI's methods 3 and 2): the affine's columns are the index axes'
steps (their lengths the spacing, their directions :attr:`Volume.direction`), its
translation the origin.  NIfTI states both in RAS; they are turned into LPS by negating
the first two rows.  With both codes 0 (method 1) the file states no orientation: spacing
from ``pixdim[1..3]``, origin 0, identity direction.

A 4D or 5D file (:mod:`.channels`): the 4th axis (``dim[4]``) is time, or channels where the header's
``intent_code`` says each voxel holds a vector (:data:`VECTOR_INTENTS`: NIFTI_INTENT_DISPVECT 1006,
NIFTI_INTENT_VECTOR 1007, NIFTI_INTENT_RGB_VECTOR 2003, NIFTI_INTENT_RGBA_VECTOR 2004); ``volume.fourth_axis``
(``auto``, ``channel``, ``time``) overrides the intent.  A 5D file's 5th axis (``dim[5]``, NIfTI's place for
a vector's components) is channels and its 4th time.  The seconds between steps are ``pixdim[4]`` in the
time unit of ``xyzt_units`` (none where the unit is not one of time).  Only the chosen step (and channel) is
read, through nibabel's array proxy (a ``.nii.gz`` is decompressed up to it, never kept whole).

A colour volume (``volume.role = "rgb"``, :mod:`dvr_gl.fields.color`): a ``datatype`` of RGB24 or RGBA32
(its components), or a vector of 3 or 4 components along the channel axis above, read together as
``[z, y, x, 3|4]`` (integer codes sRGB-decoded there, floats taken as linear).

Before nibabel reads the voxels the header is checked here: 3 to 5 dimensions of at
least 1 voxel (a 6th or 7th of more than one is refused), a scalar ``datatype``, finite positive ``pixdim``
(nibabel would silently take the absolute value of a negative one), the bytes read against the
memory budget and, uncompressed, the promised bytes against the file's size.  nibabel's log messages
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
from .channels import Axes, RawChannels, channel_names, check_count, pick_channel, pick_step, seconds
from .common import RAS_TO_LPS, RawArray, axes_geometry, check_sample_type, check_spacing, require

MAX_GZIP_OFFSET = 64 << 20  # bytes: header and extensions; seeking a .nii.gz decodes all of them
#: The intent codes that make a 4D file's 4th axis the components of a vector (channels), not time.
VECTOR_INTENTS = {1006: "NIFTI_INTENT_DISPVECT", 1007: "NIFTI_INTENT_VECTOR", 2003: "NIFTI_INTENT_RGB_VECTOR",
                  2004: "NIFTI_INTENT_RGBA_VECTOR"}
FOURTH_AXIS = ("auto", "channel", "time")
#: xyzt_units' time bits (0x38) -> seconds per unit (Hz, ppm and rad/s are not time).
TIME_UNITS = {8: 1.0, 16: 1e-3, 24: 1e-6}


def read_nifti(path: Path, channel: int | None = None, time: int | None = None, fourth_axis: str | None = None,
               color: bool = False):
    """The volume, or the chosen step of a 4D/5D file: its chosen channel, or a
    :class:`.channels.RawChannels` of every channel; ``color``: the step's colour ``[z, y, x, 3|4]``."""
    nib = require("nibabel", "nibabel", "nifti")
    path = _checked_files(nib, path)
    errors = _errors(nib)
    try:
        with _quiet(nib.imageglobals.logger):
            img = nib.load(str(path))
            axes, where = _layout(img.header, path, fourth_axis)
            if color:
                return _read_colour(nib, img, path, axes, where, channel, time)
            if img.header.get_data_dtype().names:
                raise VolumeError(f"{path}: datatype {img.header.get_data_dtype().names} holds a colour a voxel "
                                  f"(RGB24/RGBA32); read it as a colour volume: volume.role = rgb")
            chosen, step = pick_channel(channel, axes, str(path)), pick_step(time, axes, str(path))
            reads = 1 if axes.channels == 0 or chosen is not None else axes.channels
            shape, scaled, spacing = _check_header(nib, img, path, reads)
            proxy = img.dataobj
            if where is None:  # a 3D file, read as always
                arrays = [np.asarray(proxy) if scaled else np.asarray(proxy.get_unscaled())]
            else:
                arrays = _read_step(proxy, where, step, chosen, axes.channels)
            affine, field = _patient_affine(img.header)
    except errors as exc:
        raise VolumeError(f"{path}: NIfTI file is truncated or corrupt ({exc})") from None
    # nibabel indexes (i, j, k): x first
    volumes = [np.ascontiguousarray(np.asarray(a).reshape(shape).transpose(2, 1, 0)) for a in arrays]
    geometry = _geometry(affine, field, spacing, path)
    if axes.channels == 0 or chosen is not None:
        return RawArray(volumes[0], *geometry)
    return RawChannels([RawArray(v, *geometry) for v in volumes], channel_names((), axes.channels))


def _read_colour(nib, img, path: Path, axes: Axes, where, channel, time) -> RawArray:
    """A colour volume's step: RGB24/RGBA32 voxels, or a vector of 3 or 4 components, as ``[z, y, x, 3|4]``."""
    names = img.header.get_data_dtype().names
    components = len(names) if names else axes.channels
    if channel is not None:
        raise VolumeError(f"{path}: volume.role = rgb reads a colour's components together; remove volume.channel")
    if components not in (3, 4) or names and axes.channels:
        raise VolumeError(f"{path}: volume.role = rgb: a NIfTI colour volume has a datatype of RGB24 or RGBA32, or a "
                          f"vector of 3 or 4 components (intent_code 1007 or 2003/2004, or volume.fourth_axis = "
                          f"channel); this one has {components or 'no'} components: give it the role scalar")
    step = pick_step(time, axes, str(path))
    shape, _, spacing = _check_header(nib, img, path, 1 if names else components)
    proxy = img.dataobj
    if names:
        index = [slice(None)] * 3 + [0] * (len(proxy.shape) - 3)
        if where is not None and where[0] is not None:
            index[where[0]] = step
        voxels = np.asarray(proxy[tuple(index)]).reshape(shape)
        parts = [voxels[n] for n in names]
    else:
        parts = [np.asarray(a).reshape(shape) for a in _read_step(proxy, where, step, None, components)]
    data = np.ascontiguousarray(np.stack(parts, axis=-1).transpose(2, 1, 0, 3))  # [z, y, x, component]
    return RawArray(data, *_geometry(*_patient_affine(img.header), spacing, path))


def _geometry(affine, field, spacing, path) -> tuple:
    """(spacing, origin, direction) from the affine that places the voxels (none: pixdim, origin 0)."""
    if affine is None:
        return spacing, (0.0, 0.0, 0.0), None
    lps = RAS_TO_LPS @ affine[:3]
    origin = tuple(float(v) for v in lps[:, 3])
    if not all(math.isfinite(v) for v in origin):
        raise VolumeError(f"{path}: the {field} offsets give origin {origin}; they must be finite")
    spacing, direction = axes_geometry(lps[:, :3].T, str(path), field)
    return spacing, origin, direction


def nifti_axes(path: Path, fourth_axis: str | None = None) -> Axes:
    """The channels and time steps the header states (no voxel read)."""
    nib = require("nibabel", "nibabel", "nifti")
    path = _checked_files(nib, path)
    try:
        with _quiet(nib.imageglobals.logger):
            header = nib.load(str(path)).header
    except _errors(nib) as exc:
        raise VolumeError(f"{path}: NIfTI file is truncated or corrupt ({exc})") from None
    return _layout(header, path, fourth_axis)[0]


#: A NIfTI pair's two files (nibabel's ``types_filenames``: ``x.hdr`` and ``x.img``, the case kept, compressed alike).
PAIR_TYPES = (("image", ".img"), ("header", ".hdr"))
PAIR_SUFFIXES = (".gz", ".bz2", ".zst")


def _checked_files(nib, path) -> Path:
    """``path``, after the sandbox's check of every file nibabel will open: a ``.nii`` alone, a pair's header
    and image both (given either, nibabel opens the other by name: a companion linked outside the sandbox's
    roots, or a FIFO, must be refused as the named file is)."""
    path = check_input_path(Path(path), "NIfTI file")
    name = path.name.lower()
    for suffix in ("",) + PAIR_SUFFIXES:
        if name.endswith((".hdr" + suffix, ".img" + suffix)):
            companions = nib.filename_parser.types_filenames(str(path), PAIR_TYPES, trailing_suffixes=PAIR_SUFFIXES)
            for kind, other in companions.items():
                check_input_path(Path(other), f"NIfTI pair's {kind} file")
            break
    return path


def _errors(nib) -> tuple:
    """What nibabel raises on a damaged file (each becomes one line naming the file)."""
    return (EOFError, zlib.error, OSError, ValueError, OverflowError, TypeError, IndexError, KeyError,
            nib.filebasedimages.ImageFileError, nib.spatialimages.HeaderDataError, nib.wrapstruct.WrapStructError)


def _layout(header, path: Path, fourth_axis) -> tuple[Axes, tuple | None]:
    """What the 4th and 5th axes hold: ``(Axes, where)`` with ``where`` ``(time axis, channel axis)`` of
    nibabel's array (None each where absent), or None for a 3D file."""
    if fourth_axis not in (None, *FOURTH_AXIS):
        raise VolumeError(f"{path}: volume.fourth_axis must be one of {', '.join(FOURTH_AXIS)}, got {fourth_axis!r}")
    shape = tuple(int(s) for s in header.get_data_shape())
    if len(shape) < 3 or min(shape) < 1 or any(s != 1 for s in shape[5:]):
        raise VolumeError(f"{path}: dim gives shape {shape}; a volume needs 3 dimensions of at least 1 voxel, a 4th of "
                          f"time or channels and a 5th of channels at most (extract one 3D volume first)")
    fourth, fifth = (list(shape[3:5]) + [1, 1])[:2]
    if len(shape) <= 3 or fourth == fifth == 1:
        if fourth_axis not in (None, "auto"):
            raise VolumeError(f"{path}: volume.fourth_axis = {fourth_axis}: this NIfTI file is 3D; remove it")
        return Axes(), None
    if fifth > 1:  # 5D: dim[5] the vector's components, dim[4] time
        if fourth_axis == "channel" and fourth > 1:
            raise VolumeError(f"{path}: volume.fourth_axis = channel: this 5D file holds its channels in dim[5] and "
                              f"time in dim[4]; remove it")
        return Axes(check_count(fifth, str(path), "channels (dim[5])"), (), check_count(fourth, str(path),
                    "time steps (dim[4])"), _interval(header) if fourth > 1 else None), (3, 4)
    intent = int(header.get("intent_code", 0))
    as_channels = fourth_axis == "channel" or fourth_axis in (None, "auto") and intent in VECTOR_INTENTS
    count = check_count(fourth, str(path), "channels (dim[4])" if as_channels else "time steps (dim[4])")
    if as_channels:
        return Axes(count), (None, 3)
    return Axes(steps=count, interval=_interval(header)), (3, None)


def _interval(header) -> float | None:
    """pixdim[4] in the time unit of xyzt_units, in seconds (None: no time unit)."""
    factor = TIME_UNITS.get(int(header.get("xyzt_units", 0)) & 0x38)
    return None if factor is None else seconds(float(header["pixdim"][4]) * factor, "s")


def _read_step(proxy, where, step: int, chosen, channels: int) -> list:
    """The arrays ``[i, j, k]`` of step ``step``: the chosen channel, or each channel, sliced from the proxy
    (only that part read)."""
    time_axis, channel_axis = where
    index = [slice(None)] * 3 + [0] * (len(proxy.shape) - 3)
    if time_axis is not None:
        index[time_axis] = step
    wanted = range(channels) if chosen is None and channel_axis is not None else [chosen or 0]
    arrays = []
    for c in wanted:
        if channel_axis is not None:
            index[channel_axis] = c
        arrays.append(np.asarray(proxy[tuple(index)]))
    return arrays


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


def _check_header(nib, img, path: Path, reads: int = 1) -> tuple[tuple, bool, tuple]:
    """The 3D shape, whether the data is scaled and the spacing, after the header's checks (``reads``: the 3D
    volumes read, each counted against the memory budget)."""
    header = img.header
    whole = tuple(int(s) for s in header.get_data_shape())
    shape = whole[:3]
    dtype = header.get_data_dtype()
    if not dtype.names or any(dtype[n] != np.uint8 for n in dtype.names):  # RGB24, RGBA32: a colour's codes
        check_sample_type(dtype, str(path), "datatype", str(dtype))
    # nibabel's loaded header has negative pixdim already made positive: check the stored one (a pair's in its
    # header file, whichever of the two was named)
    files = img.file_map  # a .nii: "image" only
    header_file = Path(files.get("header", files["image"]).filename or path)
    image_file = Path(files["image"].filename or path)
    with nib.openers.ImageOpener(str(header_file)) as stored:
        pixdim = type(header).from_fileobj(stored, check=False)["pixdim"]
    spacing = check_spacing(pixdim[1:4], str(path), "pixdim[1..3]")
    proxy = img.dataobj
    slope, inter = getattr(proxy, "slope", 1.0), getattr(proxy, "inter", 0.0)
    scaled = not (np.isnan(slope) or slope in (0.0, 1.0)) or not (np.isnan(inter) or inter == 0.0)
    count = math.prod(shape) * reads
    nbytes = math.prod(whole) * dtype.itemsize  # what the file must hold
    check_bytes(count * dtype.itemsize + 8 * count * scaled,
                f"{path}: the {shape} volume{f's of {reads} channels' if reads > 1 else ''} its header promises",
                "check dim in the header, or raise the memory budget")
    offset = int(proxy.offset)  # after nibabel's repair of a vox_offset of 0
    if path.name.lower().endswith(".gz"):
        if offset > MAX_GZIP_OFFSET:
            raise VolumeError(f"{path}: vox_offset {offset} is beyond any header and extensions "
                              f"({MAX_GZIP_OFFSET} bytes); fix the header")
    elif image_file.stat().st_size < offset + nbytes:
        raise VolumeError(f"{image_file}: the file holds {image_file.stat().st_size} bytes, but vox_offset {offset} "
                          f"and {shape} of {dtype} need {offset + nbytes}; the file is truncated or the header wrong")
    return shape, scaled, spacing
