"""Large test volumes written to disk in slabs, with a detached NRRD header (``dvr bench scale``, tests).

The volume is deterministic and has what out-of-core rendering must handle: empty space (zeros, so
that empty bricks can be skipped), a thin spherical shell (structure at every scale along a ray) and
a few Gaussian blobs, in the box's unit cube ``[0, 1]^3`` whatever the dims.  Values lie in
``[0, 1]`` times the type's scale (255 for uint8, 65535 for uint16, 32767 for int16, 1 for float32).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import VolumeError

SCALES = {"uint8": 255.0, "uint16": 65535.0, "int16": 32767.0, "float32": 1.0}
NRRD_TYPES = {"uint8": "uint8", "uint16": "uint16", "int16": "int16", "float32": "float"}
SLAB_BYTES = 64 << 20  # float32 work arrays per slab: the writer's memory does not grow with the volume
# (centre x, y, z in the unit cube, standard deviation, peak value in [0, 1])
BLOBS = ((0.30, 0.35, 0.40, 0.06, 1.0), (0.65, 0.60, 0.55, 0.08, 0.8), (0.50, 0.70, 0.30, 0.04, 0.6))
SHELL = (0.5, 0.5, 0.5, 0.42, 0.015, 0.5)  # centre, radius, half thickness (unit cube), value


def synthetic_slab(dims, z0: int, z1: int, dtype: str = "uint8") -> np.ndarray:
    """Planes ``z0 .. z1 - 1`` of the synthetic volume as ``[z, y, x]`` of ``dtype``."""
    nx, ny, nz = dims
    x = (np.arange(nx, dtype=np.float32) + 0.5) / nx
    y = (np.arange(ny, dtype=np.float32) + 0.5) / ny
    z = (np.arange(z0, z1, dtype=np.float32) + 0.5) / nz
    out = np.zeros((z1 - z0, ny, nx), dtype=np.float32)
    cx, cy, cz, radius, half, value = SHELL
    rxy = (x[None, :] - cx) ** 2 + (y[:, None] - cy) ** 2
    for k, zk in enumerate(z):
        r = np.sqrt(rxy + (zk - cz) ** 2)
        out[k][np.abs(r - radius) < half] = value
    for bx, by, bz, sigma, peak in BLOBS:  # each blob only within 3 sigma (beyond: below 1.2 % of its peak)
        zs = np.abs(z - bz) < 3 * sigma
        if not zs.any():
            continue
        ys = np.flatnonzero(np.abs(y - by) < 3 * sigma)
        xs = np.flatnonzero(np.abs(x - bx) < 3 * sigma)
        if not len(ys) or not len(xs):
            continue
        gy = np.exp(-((y[ys] - by) ** 2) / (2 * sigma ** 2))
        gx = np.exp(-((x[xs] - bx) ** 2) / (2 * sigma ** 2))
        for k in np.flatnonzero(zs):
            g = peak * np.exp(-((z[k] - bz) ** 2) / (2 * sigma ** 2)) * gy[:, None] * gx[None, :]
            window = out[k, ys[0]:ys[-1] + 1, xs[0]:xs[-1] + 1]
            np.maximum(window, g, out=window)
    out *= SCALES[dtype]
    if dtype != "float32":
        np.rint(out, out=out)
    return out.astype(dtype)


def write_synthetic_raw(path, dims, dtype: str = "uint8", *, header: bool = True, slab_bytes: int = SLAB_BYTES,
                        progress_label: str | None = None) -> Path:
    """Write the synthetic volume of ``dims = (nx, ny, nz)`` to ``path`` (raw, little-endian, x fastest),
    slab by slab (memory bounded by ``slab_bytes`` of float32 work arrays, not by the volume), and with
    ``header`` a detached NRRD header ``<path minus suffix>.nhdr`` naming it.  Returns the header's path
    (or the raw file's without a header).  The file is written under a temporary name and renamed when
    complete, so an interrupted write leaves no partial volume under the final name."""
    from .. import progress

    if dtype not in SCALES:
        raise VolumeError(f"synthetic volume: dtype {dtype!r}; use one of {', '.join(SCALES)}")
    nx, ny, nz = (int(d) for d in dims)
    if min(nx, ny, nz) < 1:
        raise VolumeError(f"synthetic volume: dims must be three integers >= 1, got {list(dims)}")
    path = Path(path)
    planes = max(1, slab_bytes // (4 * nx * ny))
    item = np.dtype(dtype).itemsize
    partial = path.with_name(path.name + ".partial")
    with progress.task(progress_label or f"writing {path.name}", nx * ny * nz * item, "B") as step, \
            open(partial, "wb") as fh:
        for z0 in range(0, nz, planes):
            z1 = min(nz, z0 + planes)
            slab = synthetic_slab((nx, ny, nz), z0, z1, dtype)
            fh.write(slab.astype(slab.dtype.newbyteorder("<"), copy=False).data)
            step(z1 * nx * ny * item)
    os.replace(partial, path)
    if not header:
        return path
    nhdr = path.with_suffix(".nhdr")
    nhdr.write_text(f"NRRD0004\ntype: {NRRD_TYPES[dtype]}\ndimension: 3\nsizes: {nx} {ny} {nz}\n"
                    f"spacings: 1 1 1\nendian: little\nencoding: raw\ndata file: {path.name}\n")
    return nhdr
