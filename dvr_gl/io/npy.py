"""NumPy ``.npy`` arrays, indexed ``[z, y, x]`` (no pickles).

The header (shape, dtype, order) is read and checked first, with numpy's own
parser; the array is read only when the file holds exactly the bytes it promises
and they fit the memory budget.
"""

from __future__ import annotations

import io
import tokenize
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_input_path
from .common import RawArray, check_dims, check_sample_type, promised_bytes
from .compression import read_data

MAX_HEADER = 1 << 16  # bytes: numpy refuses headers over 10000 bytes anyway


def read_npy(path: Path, color: bool = False) -> RawArray:
    """A ``.npy`` array ``[z, y, x]``; with ``color`` (``volume.role = "rgb"``) a colour volume's
    ``[z, y, x, 3|4]`` (r, g, b and perhaps alpha last: :mod:`dvr_gl.fields.color`)."""
    path = check_input_path(Path(path), ".npy file")
    name = str(path)
    try:
        with open(path, "rb") as f:
            # numpy reads as many bytes as the header says its header has (up to 4 GiB):
            # from a bounded copy of the file's start, a lying length is a short read, not an allocation
            fh = io.BytesIO(f.read(MAX_HEADER))
            version = np.lib.format.read_magic(fh)
            read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                           else np.lib.format.read_array_header_2_0)
            shape, fortran, dtype = read_header(fh)
            start = fh.tell()
    # numpy parses the header with ast and tokenize, whose errors pass through it unchanged
    except (ValueError, OSError, EOFError, SyntaxError, TypeError, tokenize.TokenError, RecursionError) as exc:
        raise VolumeError(f"{path}: not a readable .npy array ({exc})") from None
    if dtype.hasobject or dtype.fields is not None or dtype.subdtype is not None:
        raise VolumeError(f"{path}: holds {dtype} records or objects; save a plain numeric array")
    check_sample_type(dtype, name, "dtype", str(dtype))
    if color and (len(shape) != 4 or shape[3] not in (3, 4)):
        raise VolumeError(f"{path}: volume.role = rgb: expected colour indexed [z, y, x, c] with 3 (r, g, b) or 4 "
                          f"(r, g, b, alpha) components, got shape {shape}; or give the field role scalar")
    if not color and len(shape) != 3:
        rgb = " (colour [z, y, x, 3|4]: set volume.role = rgb)" if len(shape) == 4 and shape[3] in (3, 4) else ""
        raise VolumeError(f"{path}: expected a 3D array indexed [z, y, x], got shape {shape}{rgb}")
    nz, ny, nx = check_dims(shape[:3][::-1], name, "shape")[::-1]
    blob = read_data(path, promised_bytes(shape, dtype), name=name, start=start, what=".npy file",
                     promise=f"its header (shape {shape}, {dtype})")
    data = np.frombuffer(blob, dtype=dtype)
    data = data.reshape(shape[::-1]).T if fortran else data.reshape(shape)
    if color:  # the components last and together, as ColorVolume reads them
        data = np.ascontiguousarray(data)
    return RawArray(data)
