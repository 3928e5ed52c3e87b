"""What a format reader returns, how readers find their optional library, and the strict
checks of header fields that every reader shares.

Header checks raise :class:`VolumeError` naming the file, the field as the format writes
it (``sizes``, ``DimSize``, ``DIMENSIONS``, ...), what is valid and what was found.
"""

from __future__ import annotations

import importlib
import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import VolumeError, install_hint

# Sample types a reader accepts: bool and integers of any width, floats of any width
# (Volume converts them to uint8, uint16, int16 or float32).  Complex, strings, records: no.
ACCEPTED_KINDS = "biuf"
_INTEGER = re.compile(r"[+-]?\d{1,18}\Z")  # longer is out of any range (and slow to parse)


@dataclass
class RawArray:
    """A reader's result: ``data[z, y, x]`` plus the geometry the file states (None: not stated)."""

    data: np.ndarray
    spacing: tuple[float, float, float] | None = None
    origin: tuple[float, float, float] | None = None
    direction: tuple | None = None  # 3x3, columns the index axes in the patient (LPS) frame; None: not stated


def require(module: str, package: str, extra: str):
    """Import an optional reader library, or say which extra installs it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise VolumeError(f"reading this format needs the {package} package: "
                          f"{install_hint(extra)}, or pip install {package}") from exc


def show(text) -> str:
    text = str(text)
    return repr(text if len(text) <= 60 else text[:57] + "...")


def integers(text: str, name: str, field: str, count: int | None = None, minimum: int | None = None):
    """The whitespace-separated integers of a header field (``32.5`` or ``1e3`` are not integers)."""
    tokens = str(text).split()
    if count is not None and len(tokens) != count:
        raise VolumeError(f"{name}: {field} must hold {count} integers, got {show(text)}; fix the header")
    if not all(_INTEGER.match(t) for t in tokens):
        raise VolumeError(f"{name}: {field} must hold integers, got {show(text)}; fix the header")
    values = tuple(int(t) for t in tokens)
    if minimum is not None and any(v < minimum for v in values):
        raise VolumeError(f"{name}: {field} must be >= {minimum}, got {show(text)}; fix the header")
    return values


def integer(text: str, name: str, field: str, minimum: int | None = None) -> int:
    return integers(text, name, field, 1, minimum)[0]


def numbers(text: str, name: str, field: str, count: int, allow_nan: bool = False):
    """``count`` finite numbers of a header field (NaN too where the format means "none")."""
    tokens = str(text).split()
    try:
        values = tuple(float(t) for t in tokens)
    except ValueError:
        values = ()
    if len(tokens) != count or len(values) != count or not all(
            math.isfinite(v) or allow_nan and math.isnan(v) for v in values):
        raise VolumeError(f"{name}: {field} must hold {count} finite numbers, got {show(text)}; "
                          f"fix the header")
    return values


def check_spacing(values, name: str, field: str) -> tuple[float, float, float]:
    """Three finite positive spacings (world units, x first), or an error naming ``field``."""
    try:
        values = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) and v > 0 for v in values):
        raise VolumeError(f"{name}: {field} must be three finite numbers > 0 (x, y, z), got "
                          f"{show(values or '?')}; fix it or set volume.spacing")
    return values


def check_dims(dims, name: str, field: str) -> tuple[int, int, int]:
    """Three positive sample counts ``(nx, ny, nz)``."""
    if len(dims) != 3 or min(dims) < 1:
        raise VolumeError(f"{name}: {field} must be three integers >= 1 (nx, ny, nz), got {list(dims)}; "
                          f"fix the header")
    return tuple(int(d) for d in dims)


def check_sample_type(dtype: np.dtype, name: str, field: str, written: str) -> np.dtype:
    """``dtype`` if a volume can hold it (integers, bool, floats); ``written`` is the header's word."""
    if dtype.kind not in ACCEPTED_KINDS:
        raise VolumeError(f"{name}: {field} {written} is not a scalar type a volume can hold; use unsigned "
                          f"or signed integers or floats (uint8, uint16, int16, float32 are kept as they are)")
    return dtype


def promised_bytes(dims, dtype: np.dtype) -> int:
    """Bytes of ``nx * ny * nz`` samples (Python integers: no overflow)."""
    return math.prod(int(d) for d in dims) * dtype.itemsize


def parse_ascii(text: bytes, count: int, dtype: np.dtype, name: str, field: str) -> np.ndarray:
    """The first ``count`` whitespace-separated numbers of ``text`` as ``dtype``."""
    tokens = text.split(maxsplit=count)[:count]
    if len(tokens) < count:
        raise VolumeError(f"{name}: the ASCII {field} holds {len(tokens)} of the {count} values the header "
                          f"promises; the file is truncated or the header is wrong")
    try:
        values = np.array(tokens, dtype=np.float64)
    except ValueError:
        raise VolumeError(f"{name}: the ASCII {field} holds a value that is not a number; fix the file") from None
    if dtype.kind in "iub":
        info = np.iinfo(dtype) if dtype.kind != "b" else None
        if not np.all(np.isfinite(values)) or info and (values.min() < info.min or values.max() > info.max):
            raise VolumeError(f"{name}: the ASCII {field} holds values outside the range of {dtype.name}")
    return values.astype(dtype)


# NIfTI and NRRD's "right-anterior-superior" state positions in RAS; the volume's frame is LPS (DICOM's
# and ITK's): x and y change sign, z does not.
RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])
ORTHOGONALITY = 1e-4  # largest |cos| between two index axes: headers written in float32 reach 1e-6


def axes_geometry(steps, name: str, field: str):
    """Spacing and direction from the three index-axis steps a header states (the vector in the patient
    frame from sample ``(0, 0, 0)`` to ``(1, 0, 0)``, ``(0, 1, 0)``, ``(0, 0, 1)``, x first): the spacing is
    each step's length, the direction's columns the unit steps.

    Axes that are not orthogonal (a sheared grid: gantry tilt, an affine with shear) are refused: the
    renderers sample rectangular grids, and taking the nearest rotation, as some tools do silently, would
    move every sample off the position the file gives it."""
    m = np.array(steps, dtype=np.float64).reshape(3, 3).T  # columns: the steps
    # each length scaled by its largest component first: the plain norm squares them, and a step of 1e200
    # overflowed to inf (its direction then came out 0, "90 degrees from orthogonal")
    scale = np.abs(m).max(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        lengths = scale * np.linalg.norm(m / np.where(scale > 0, scale, 1), axis=0)
    if not np.all(np.isfinite(m)) or not np.all(lengths > 0):
        raise VolumeError(f"{name}: {field} must give three finite, non-zero axis vectors; fix the header")
    d = m / lengths
    cos = np.abs(d.T @ d - np.eye(3)).max()
    if cos > ORTHOGONALITY:
        angle = 90.0 - np.degrees(np.arccos(min(cos, 1.0)))
        raise VolumeError(f"{name}: {field} gives index axes {angle:.3g} degrees from orthogonal (a sheared "
                          f"grid); resample it onto a rectangular grid first (e.g. with ITK's or Slicer's "
                          f"resampler)")
    spacing = check_spacing(lengths, name, field)
    return spacing, tuple(tuple(float(x) for x in row) for row in d)
