"""DICOM series (a folder, a list of files or a glob) through pydicom (extra ``dicom``).

pydicom reads each file's header and pixels; the series is assembled here, from the headers'
geometry only (file names and InstanceNumber say nothing reliable about position):

* slices are ordered by ImagePositionPatient projected on the slice normal
  (ImageOrientationPatient's row direction x column direction);
* the spacing between slices comes from those positions, which must be evenly spaced (within
  :data:`GAP_TOLERANCE`): a missing slice is named, not stretched over;
* the in-plane spacing from PixelSpacing (row spacing, then column spacing: y, then x);
* :attr:`Volume.direction`'s columns are the row direction, the column direction and the normal,
  in DICOM's patient frame, LPS; the origin is the first slice's ImagePositionPatient;
* RescaleSlope and RescaleIntercept (per slice) are applied: int16 when every value is an integer that
  int16 holds, float32 otherwise; without rescaling the stored type is kept.

Refused in one line: several series in the files (each named, with how to choose one), slices of
different size, spacing or orientation, positions that step sideways (a tilted gantry: a sheared grid),
two slices at one position, colour or multi-frame images, and compressed transfer syntaxes that pydicom
cannot decode without a plugin (naming the package that decodes it).

Every tag the reader uses is checked before it is used, and a bad one is named with its file: Rows and
Columns (1 to 65535), SamplesPerPixel and NumberOfFrames (integers, 1), PhotometricInterpretation (grey:
MONOCHROME1 or 2), ImageOrientationPatient (two perpendicular unit vectors), PixelSpacing (two numbers > 0),
ImagePositionPatient, RescaleSlope (finite, not 0) and RescaleIntercept (finite); a rescale whose values
float32 cannot hold or tell apart is refused naming both tags.

Each file counts against the memory budget (pydicom holds it whole); a deflated dataset, which pydicom
inflates whole, is first inflated here in chunks and refused past the budget.

A folder's or a glob's members are each checked against the sandbox (symlinks followed) before any is
opened, so a member linked to a file outside the roots is refused, not read.

A folder's DICOM files are found by content (the ``DICM`` marker after the 128-byte preamble), so a
folder of TIFF slices still reads as a TIFF stack (:func:`is_dicom`).
"""

from __future__ import annotations

import glob
import math
from pathlib import Path

import numpy as np

from .. import progress
from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path, memory_budget
from .common import ORTHOGONALITY, RawArray, axes_geometry, require
from .series import is_pattern

GAP_TOLERANCE = 0.01  # relative: gaps between slice positions may differ by 1% of the median gap
ORIENTATION_TOLERANCE = 1e-4  # ImageOrientationPatient's numbers, written to about 6 decimals
UNIT_TOLERANCE = 1e-3  # how far from 1 the length of its directions may be (some writers keep 4 decimals)
GREY = ("MONOCHROME1", "MONOCHROME2")  # PhotometricInterpretation of grey values (not palette indices)
MEDIA_DIRECTORY = "1.2.840.10008.1.3.10"  # DICOMDIR: an index of files, not an image
# The tags the reader uses (beyond the pixel data and the file meta's UIDs)
USED = ("Rows", "Columns", "SamplesPerPixel", "PhotometricInterpretation", "BitsAllocated", "BitsStored",
        "PixelRepresentation", "NumberOfFrames", "ImageOrientationPatient", "ImagePositionPatient", "PixelSpacing",
        "RescaleSlope", "RescaleIntercept", "SliceThickness", "SpacingBetweenSlices", "SeriesInstanceUID",
        "SeriesNumber", "SeriesDescription")
# An image's pixel module: a file with none of these is no image; one with some, but short of Rows, is broken
IMAGE_PIXEL = ("Rows", "Columns", "SamplesPerPixel", "PhotometricInterpretation", "BitsAllocated", "BitsStored",
               "PixelRepresentation")


def is_dicom(path: Path) -> bool:
    """Whether ``path`` is a DICOM Part 10 file: ``DICM`` at byte 128."""
    try:
        with open(path, "rb") as fh:
            return fh.read(132)[128:] == b"DICM"
    except OSError:
        return False


def members(path: Path) -> list[Path]:
    """The regular files a folder or a glob names, in name order, each allowed by the sandbox (symlinks
    followed) before anything reads it: a member linked to a file outside the roots is refused, not
    skipped, as is a glob reaching outside them."""
    text = str(path)
    if is_pattern(text):
        found = [Path(p) for p in sorted(glob.glob(text))]
    elif path.is_dir():
        found = sorted(path.iterdir())
    else:
        return []
    return [check_input_path(f, "file of the series folder or glob") for f in found if f.is_file()]


def series_candidates(path) -> list[Path]:
    """The DICOM files that ``path`` names: a list of files, a folder's files (by content) or a glob's."""
    if isinstance(path, (list, tuple)):
        files = [Path(p) for p in path]
        for f in files:
            check_input_path(f, "DICOM file")
            if not is_dicom(f):
                raise VolumeError(f"{f}: not a DICOM file (no DICM marker at byte 128); leave it out of the list")
        return files
    path = Path(path)
    found = members(path) if path.is_dir() or is_pattern(path) else \
        [check_input_path(path, "DICOM file")]
    files = [f for f in found if is_dicom(f)]
    if not files:
        raise VolumeError(f"{path}: no DICOM files (none has the DICM marker at byte 128)")
    return files


def folder_holds_dicom(path: Path) -> bool:
    """Whether a folder (or a glob) names at least one DICOM file, by content."""
    return any(is_dicom(p) for p in members(Path(path)))


def _value(ds, keyword: str, f: Path):
    """A tag's value as pydicom gives it; None when the tag is absent or empty."""
    try:
        value = ds.get(keyword)
    except Exception as exc:  # noqa: BLE001 - pydicom converts lazily, and may raise any kind here
        raise VolumeError(f"{f}: {keyword} cannot be read ({exc}); fix the tag") from None
    if value is None or isinstance(value, (str, bytes)) and not value.strip() or \
            isinstance(value, (list, tuple)) and not len(value):
        return None
    return value


def _numbers(ds, keyword: str, count: int, f: Path, positive: bool = False, default=None):
    """``count`` finite numbers of a tag (each > 0 if ``positive``); ``default`` when absent or empty
    (None: the tag is required)."""
    value = _value(ds, keyword, f)
    if value is None:
        if default is not None:
            return np.array(default, dtype=float)
        raise VolumeError(f"{f}: {keyword} is missing; a slice of a volume needs it (is this a localizer or a "
                          f"secondary capture?)")
    many = not isinstance(value, (str, bytes)) and hasattr(value, "__len__")
    try:
        values = [float(v) for v in (value if many else [value])]
    except (TypeError, ValueError):
        values = []
    if len(values) != count or not all(math.isfinite(v) and (v > 0 or not positive) for v in values):
        what = (f"hold {count} finite numbers" if count > 1 else "be a finite number") + (" > 0" if positive else "")
        raise VolumeError(f"{f}: {keyword} must {what}, got {_shown(value)}; fix the tag")
    return np.array(values)


def _integer(ds, keyword: str, f: Path, default: int | None = None, maximum: int = 2**31 - 1) -> int:
    """A tag's integer, 1 to ``maximum``; ``default`` when absent (an empty tag is refused: it is there,
    but says nothing)."""
    if keyword not in ds:
        if default is None:
            raise VolumeError(f"{f}: {keyword} is missing; an image slice needs it: fix the header")
        return default
    value = _value(ds, keyword, f)
    try:
        number = int(str(value).strip()) if value is not None else None
    except ValueError:
        number = None
    if number is None or not 1 <= number <= maximum:
        bound = f"from 1 to {maximum}" if maximum < 2**31 - 1 else ">= 1"
        raise VolumeError(f"{f}: {keyword} must be an integer {bound}, got "
                          f"{'nothing (empty)' if value is None else _shown(value)}; fix the tag")
    return number


def _shown(value) -> str:
    """A tag's value as DICOM writes it (several values apart by backslashes), shortened."""
    many = not isinstance(value, (str, bytes)) and hasattr(value, "__len__")
    text = "\\".join(str(v) for v in value) if many else str(value)
    return "'" + (text if len(text) <= 60 else text[:57] + "...") + "'"


def _unit_axes(iop: np.ndarray, f: Path) -> None:
    """ImageOrientationPatient's row and column directions: unit vectors, written to a few decimals."""
    for what, axis in (("row", iop[:3]), ("column", iop[3:])):
        length = float(np.linalg.norm(axis))
        if abs(length - 1) > UNIT_TOLERANCE:
            raise VolumeError(f"{f}: ImageOrientationPatient's {what} direction {axis.tolist()} has length "
                              f"{length:.6g}; each of its two directions must be a unit vector: fix the tag")
    cos = abs(float(iop[:3] @ iop[3:]))
    if cos > ORTHOGONALITY:
        raise VolumeError(f"{f}: ImageOrientationPatient's row and column directions are "
                          f"{np.degrees(np.arccos(min(cos, 1.0))):.3g} degrees apart; they must be perpendicular: "
                          f"fix the tag")


def _headers(pydicom, files):
    """Each file's header (pixels not read), DICOMDIR and image-less files left out."""
    out = []
    with progress.task("reading DICOM headers", len(files), "file") as step:
        for number, f in enumerate(files, 1):
            _header(pydicom, f, out)
            step(number)
    return out


def _header(pydicom, f: Path, out: list) -> None:
    """Append ``(f, its header)`` to ``out`` if ``f`` is an image."""
    _check_held(f)
    try:
        ds = pydicom.dcmread(str(f), stop_before_pixels=True)
    except Exception as exc:  # pydicom raises many kinds for a damaged file
        raise VolumeError(f"{f}: not a readable DICOM file ({str(exc).splitlines()[0] if str(exc) else exc!r})") \
            from None
    # pydicom decodes an element when it is first used: decode the ones used here, where a damaged one
    # is named (the others may stay damaged, as a viewer would let them)
    meta = getattr(ds, "file_meta", None)
    for keyword in USED:
        _value(ds, keyword, f)
    for keyword in ("MediaStorageSOPClassUID", "TransferSyntaxUID"):
        if meta is not None:
            _value(meta, keyword, f)
    sop = str(getattr(meta, "MediaStorageSOPClassUID", ""))
    if sop == MEDIA_DIRECTORY or not any(keyword in ds for keyword in IMAGE_PIXEL):
        return  # not an image (an index, a report, a presentation state); an image short of Rows is named
    out.append((f, ds))


DEFLATED = "1.2.840.10008.1.2.1.99"  # Deflated Explicit VR Little Endian: the dataset is one deflate stream


def _check_held(f: Path) -> None:
    """Refuse a file whose dataset pydicom would hold over the memory budget: it holds the whole file, and a
    deflated dataset inflated whole (a 300 KB file inflating to 300 MB took 1.3 GB under a 50 MB budget);
    the inflated size is measured here first, in chunks, stopping past the budget."""
    import zlib

    from pydicom.filereader import _read_file_meta_info, read_preamble

    size = f.stat().st_size
    check_bytes(2 * size, f"{f}: the DICOM file", "raise the memory budget")
    try:
        with open(f, "rb") as fh:
            read_preamble(fh, False)
            syntax = str(_read_file_meta_info(fh).get("TransferSyntaxUID", ""))
            if syntax != DEFLATED:
                return
            limit = memory_budget() // 2 + 1
            inflater, inflated = zlib.decompressobj(-zlib.MAX_WBITS), 0
            while inflated < limit and (chunk := fh.read(1 << 20)):
                while chunk and inflated < limit:
                    inflated += len(inflater.decompress(chunk, 1 << 24))
                    chunk = inflater.unconsumed_tail
    except Exception:  # noqa: BLE001 - a damaged file: pydicom's own read, next, names it
        return
    check_bytes(2 * inflated, f"{f}: its deflated dataset, inflated,",
                "raise the memory budget, or store the file uncompressed")


def _choose_series(entries, path, series):
    groups: dict[str, list] = {}
    for f, ds in entries:
        groups.setdefault(str(ds.get("SeriesInstanceUID", "?")), []).append((f, ds))
    groups = dict(sorted(groups.items(), key=lambda item: (str(item[1][0][1].get("SeriesNumber", "")), item[0])))
    if series is not None:
        chosen = {uid: g for uid, g in groups.items()
                  if series in (uid, str(g[0][1].get("SeriesNumber", "")))}
        if not chosen:
            raise VolumeError(f"{path}: no series {series!r} among {_names(groups)}; give a SeriesInstanceUID or "
                              f"SeriesNumber from those")
        groups = chosen
    if len(groups) > 1:
        raise VolumeError(f"{path}: {len(groups)} series: {_names(groups)}; choose one with volume.series "
                          f"(its number or UID), a glob, or a list of its files")
    return next(iter(groups.values()))


def _names(groups) -> str:
    parts = []
    for uid, g in groups.items():
        ds = g[0][1]
        label = f"number {ds.get('SeriesNumber', '?')}"
        if ds.get("SeriesDescription"):
            label += f" {str(ds.SeriesDescription)!r}"
        parts.append(f"{label} ({len(g)} files, UID {uid})")
    return "; ".join(parts)


def _same(entries, keyword, f0, values, tolerance=0.0):
    for (f, _), v in zip(entries, values):
        if np.abs(np.asarray(v) - np.asarray(values[0])).max() > tolerance:
            raise VolumeError(f"{f}: {keyword} {np.asarray(v).tolist()} differs from {f0.name}'s "
                              f"{np.asarray(values[0]).tolist()}; the slices of one volume must match "
                              f"(choose the files of one series)")


def read_dicom_series(path, series: str | None = None) -> RawArray:
    """A volume from the DICOM files that ``path`` names (see the module doc); ``series``: a
    SeriesInstanceUID or SeriesNumber when the files hold several series."""
    pydicom = require("pydicom", "pydicom", "dicom")
    entries = _headers(pydicom, series_candidates(path))
    if not entries:
        raise VolumeError(f"{path}: the DICOM files hold no images (only a DICOMDIR or other objects)")
    entries = _choose_series(entries, path, series)
    f0, ds0 = entries[0]
    for f, ds in entries:
        samples = _integer(ds, "SamplesPerPixel", f, default=1)
        if samples != 1:
            raise VolumeError(f"{f}: {samples} samples per pixel (colour); a volume needs grey slices")
        frames = _integer(ds, "NumberOfFrames", f, default=1)
        if frames != 1:
            raise VolumeError(f"{f}: a multi-frame image ({frames} frames); only series of "
                              f"single-frame slices are read: convert it (e.g. with dcm2niix) first")
        photometric = _value(ds, "PhotometricInterpretation", f)
        if photometric is not None and str(photometric).strip().upper() not in GREY:
            raise VolumeError(f"{f}: PhotometricInterpretation {_shown(photometric)}: the pixels are not grey "
                              f"values (MONOCHROME1 or MONOCHROME2); a volume needs grey slices")
    sizes = [(_integer(ds, "Rows", f, maximum=65535), _integer(ds, "Columns", f, maximum=65535))
             for f, ds in entries]
    _same(entries, "size (Rows, Columns)", f0, sizes)
    iop = [_numbers(ds, "ImageOrientationPatient", 6, f) for f, ds in entries]
    for (f, _), axes in zip(entries, iop):
        _unit_axes(axes, f)
    _same(entries, "ImageOrientationPatient", f0, iop, ORIENTATION_TOLERANCE)
    pixel = [_numbers(ds, "PixelSpacing", 2, f, positive=True) for f, ds in entries]
    _same(entries, "PixelSpacing", f0, pixel, 1e-6 * max(pixel[0]))
    scales = [_rescale(ds, f) for f, ds in entries]
    row, col = iop[0][:3], iop[0][3:]
    normal = np.cross(row, col)
    positions = np.array([_numbers(ds, "ImagePositionPatient", 3, f) for f, ds in entries])
    order = np.argsort(positions @ normal, kind="stable")
    entries, positions = [entries[i] for i in order], positions[order]
    gap = _slice_gap(entries, positions, normal, ds0)
    spacing, direction = axes_geometry([row * pixel[0][1], col * pixel[0][0], normal * gap], str(f0),
                                       "PixelSpacing and the slice positions (ImagePositionPatient)")
    data = _pixels(pydicom, entries, [scales[i] for i in order], path)
    return RawArray(data, spacing, tuple(float(v) for v in positions[0]), direction)


def _slice_gap(entries, positions, normal, ds0) -> float:
    """The distance between slices, from their positions: evenly spaced, along the normal."""
    if len(entries) == 1:
        for key in ("SpacingBetweenSlices", "SliceThickness"):
            value = _numbers(ds0, key, 1, entries[0][0], default=[0.0])[0]
            if value > 0:  # 0 or negative (some writers' sign convention): say nothing
                return float(value)
        return 1.0
    along = positions @ normal
    gaps = np.diff(along)
    for i, g in enumerate(gaps):
        if g <= 1e-6 * max(1.0, abs(along[i])):
            raise VolumeError(f"{entries[i][0].name} and {entries[i + 1][0].name}: two slices at one position "
                              f"({positions[i].tolist()}); several acquisitions, echoes or time points? choose "
                              f"one with a glob or a list of files")
    median = float(np.median(gaps))
    bad = np.flatnonzero(np.abs(gaps - median) > GAP_TOLERANCE * median)
    if bad.size:
        i = int(bad[0])
        raise VolumeError(f"{entries[i][0].name} and {entries[i + 1][0].name}: slices {gaps[i]:.6g} mm apart, "
                          f"the others {median:.6g} mm (a missing slice?); the slices of a volume must be evenly "
                          f"spaced: give the whole series")
    step = (positions[-1] - positions[0]) / (len(positions) - 1)
    sideways = np.linalg.norm(step - (step @ normal) * normal)
    if sideways > GAP_TOLERANCE * median:
        raise VolumeError(f"{entries[0][0].name}: each slice is shifted {sideways:.3g} mm sideways from the one "
                          f"before (a tilted gantry: a sheared grid); resample the series onto a rectangular "
                          f"grid first")
    return float(np.mean(gaps))


def _rescale(ds, f: Path) -> tuple[float, float]:
    """RescaleSlope and RescaleIntercept (1 and 0 when absent or empty): finite, the slope not 0."""
    slope = float(_numbers(ds, "RescaleSlope", 1, f, default=[1.0])[0])
    intercept = float(_numbers(ds, "RescaleIntercept", 1, f, default=[0.0])[0])
    if slope == 0:
        raise VolumeError(f"{f}: RescaleSlope is 0, which maps every stored value to the intercept; fix the tag")
    return slope, intercept


def _check_rescale(f: Path, stored: np.ndarray, slope: float, intercept: float) -> None:
    """Refuse a rescale whose values float32 cannot hold, or cannot tell apart: neighbouring stored
    integers must stay more than one float32 step apart (``RescaleIntercept 1e30`` turned a CT into one
    constant, and the message blamed the transfer function)."""
    low, high = float(stored.min()), float(stored.max())
    ends = (low * slope + intercept, high * slope + intercept)
    largest = max(abs(e) for e in ends)
    shown = f"RescaleSlope {slope:g} and RescaleIntercept {intercept:g}"
    if not math.isfinite(largest) or largest > float(np.finfo(np.float32).max):
        raise VolumeError(f"{f}: {shown} take the stored values {low:g} to {high:g} to {ends[0]:g} to {ends[1]:g}, "
                          f"outside the range of float32 (about 3.4e38); fix the tags")
    step = float(np.spacing(np.float32(largest)))
    if abs(slope) <= step:
        raise VolumeError(f"{f}: {shown} take the stored values {low:g} to {high:g} to values near {largest:.3g}, "
                          f"where float32 cannot tell neighbouring stored values apart (its step there is "
                          f"{step:.3g}); fix the tags")


def _pixels(pydicom, entries, scales, path) -> np.ndarray:
    ds0 = entries[0][1]
    rows, cols = int(ds0.Rows), int(ds0.Columns)
    check_bytes(len(entries) * rows * cols * 8, f"{path}: the {cols}x{rows}x{len(entries)} DICOM series",
                "read fewer slices, or raise the memory budget")
    slices = []
    with progress.task("reading DICOM pixels", len(entries), "slice") as step:
        for (f, _), (slope, intercept) in zip(entries, scales):
            slices.append(_slice_pixels(pydicom, f, rows, cols, slope, intercept))
            step(len(slices))
    stored = np.stack(slices)
    if all(s == (1.0, 0.0) for s in scales):
        return stored
    slope = np.array([s[0] for s in scales])[:, None, None]
    intercept = np.array([s[1] for s in scales])[:, None, None]
    values = stored * slope + intercept
    i16 = np.iinfo(np.int16)
    if np.all(values == np.round(values)) and values.min() >= i16.min and values.max() <= i16.max:
        return values.astype(np.int16)
    return values.astype(np.float32)


def _slice_pixels(pydicom, f: Path, rows: int, cols: int, slope: float, intercept: float) -> np.ndarray:
    """One slice's stored values, checked against its header and its rescale."""
    syntax = None
    try:
        ds = pydicom.dcmread(str(f))
        syntax = str(ds.file_meta.TransferSyntaxUID)
        pixels = ds.pixel_array
    except Exception as exc:  # a missing decoder and a damaged stream both end here
        raise VolumeError(_pixel_error(f, syntax, exc)) from None
    if pixels.shape != (rows, cols):
        raise VolumeError(f"{f}: pixel data of shape {pixels.shape}, the header says {(rows, cols)}")
    if (slope, intercept) != (1.0, 0.0) and pixels.size:
        _check_rescale(f, pixels, slope, intercept)
    return pixels


def _pixel_error(f, syntax, exc) -> str:
    """The line for pixels pydicom could not decode: the plugins it names when it has no decoder for the
    transfer syntax (JPEG lossless, JPEG-LS, JPEG 2000 without Pillow, ...), else the decoder's complaint."""
    from pydicom.pixels import get_decoder
    from pydicom.uid import UID

    try:
        decoder = get_decoder(UID(syntax)) if syntax else None
    except (NotImplementedError, ValueError):
        decoder = None
    try:
        compressed = bool(syntax) and UID(syntax).is_compressed
    except ValueError:  # not a transfer syntax's UID at all
        compressed = False
    if compressed and (decoder is None or not decoder.is_available):
        needs = "; ".join(decoder.missing_dependencies) if decoder else "no decoder is known"
        return (f"{f}: its transfer syntax {UID(syntax).name} is compressed, and pydicom decodes it only with a "
                f"plugin ({needs}): e.g. pip install pylibjpeg pylibjpeg-libjpeg pylibjpeg-openjpeg")
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return f"{f}: cannot decode the pixel data ({first})"
