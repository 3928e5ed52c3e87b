"""NIfTI-1/2 (``.nii``, ``.nii.gz``) through nibabel.

The voxel grid is used as stored: spacing from the header's zooms, origin
from the affine's translation.  A rotation or flip in the affine is not
applied (the renderer's volumes are axis-aligned); the voxel order is
kept, x fastest.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from .common import RawArray, require


def read_nifti(path: Path) -> RawArray:
    nib = require("nibabel", "nibabel", "nifti")
    path = Path(path)
    try:
        img = nib.load(str(path))
        shape = img.shape
        if len(shape) < 3 or any(s != 1 for s in shape[3:]):
            raise VolumeError(f"{path}: expected a 3D image, the NIfTI has shape {shape}; "
                              f"extract one 3D volume first")
        proxy = img.dataobj
        slope, inter = getattr(proxy, "slope", 1.0), getattr(proxy, "inter", 0.0)
        scaled = not (np.isnan(slope) or slope in (0.0, 1.0)) or not (np.isnan(inter) or inter == 0.0)
        arr = np.asarray(proxy) if scaled else np.asarray(proxy.get_unscaled())
    except VolumeError:
        raise
    except (EOFError, zlib.error, OSError, ValueError, nib.filebasedimages.ImageFileError) as exc:
        raise VolumeError(f"{path}: NIfTI file is truncated or corrupt ({exc})") from exc
    arr = arr.reshape(shape[:3])
    data = np.ascontiguousarray(arr.transpose(2, 1, 0))  # nibabel indexes (i, j, k): x first
    spacing = tuple(float(z) for z in img.header.get_zooms()[:3])
    origin = tuple(float(v) for v in img.affine[:3, 3])
    return RawArray(data, spacing, origin)
