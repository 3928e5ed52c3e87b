"""NumPy ``.npy`` arrays, indexed ``[z, y, x]`` (no pickles)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .common import RawArray


def read_npy(path: Path) -> RawArray:
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise VolumeError(f"{path}: not a readable .npy array ({exc})") from exc
    if not isinstance(data, np.ndarray):
        raise VolumeError(f"{path}: expected one array, found {type(data).__name__}")
    if data.ndim != 3:
        raise VolumeError(f"{path}: expected a 3D array indexed [z, y, x], got shape {data.shape}")
    return RawArray(data)
