"""NRRD (``.nrrd`` and detached ``.nhdr``) through pynrrd.

pynrrd handles the raw, gzip and bzip2 encodings, byte/line skips and
endianness.  The one thing added here: a detached data file that is split
into ``.part1, .part2, ...`` (see :mod:`.compression`) is joined in memory.
"""

from __future__ import annotations

import io
import zlib
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .common import RawArray, require
from .compression import read_stored_bytes, split_parts


def _geometry(header) -> tuple:
    spacing = origin = None
    if "spacings" in header:
        sp = np.asarray(header["spacings"], dtype=np.float64)
        if np.all(np.isfinite(sp)):
            spacing = tuple(float(s) for s in sp[-3:])
    elif "space directions" in header:
        dirs = np.asarray(header["space directions"], dtype=np.float64)
        rows = dirs[np.all(np.isfinite(dirs), axis=1)]
        if len(rows) == 3:
            spacing = tuple(float(v) for v in np.linalg.norm(rows, axis=1))
    if "space origin" in header:
        origin = tuple(float(v) for v in np.asarray(header["space origin"], dtype=np.float64))
    return spacing, origin


def read_nrrd(path: Path) -> RawArray:
    nrrd = require("nrrd", "pynrrd", "nrrd")
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            header = nrrd.read_header(fh)
            datafile = header.get("data file", header.get("datafile"))
            target = path.parent / datafile if datafile else None
            if target is not None and not target.exists() and split_parts(target):
                header = {k: v for k, v in header.items() if k not in ("data file", "datafile")}
                data = nrrd.read_data(header, io.BytesIO(read_stored_bytes(target)), index_order="C")
            else:
                if target is not None and not target.exists():
                    raise VolumeError(f"{path}: its data file {target} was not found")
                data = nrrd.read_data(header, fh, filename=str(path), index_order="C")
    except nrrd.NRRDError as exc:
        raise VolumeError(f"{path}: not a readable NRRD file ({exc}); if the data is compressed it may be "
                          f"truncated") from exc
    except (EOFError, zlib.error, OSError, ValueError) as exc:
        raise VolumeError(f"{path}: NRRD data is truncated or corrupt ({exc})") from exc
    if data.ndim != 3:
        squeezed = np.squeeze(data)
        if squeezed.ndim != 3:
            raise VolumeError(f"{path}: expected 3 dimensions, the NRRD has sizes {list(header['sizes'])}")
        data = squeezed
    spacing, origin = _geometry(header)
    return RawArray(data, spacing, origin)
