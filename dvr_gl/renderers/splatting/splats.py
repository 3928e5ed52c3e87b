"""The splats of a grid, on the host: one per sample, their order along the view, and the slabs.

The Gaussian field sums the kernels of the grid's samples with the taps clamped
(:mod:`dvr_gl.fields.reconstruction`): beyond the grid the border samples repeat.  So the
splats are the samples and, around them, ``ghost`` layers of copies of the border samples
(as many as the kernel reaches, ``ceil(R)``), each splat integrated only over the part of the
ray inside the box: the same field, clipped where every renderer clips.

Pre-classified, a splat whose voxel is transparent (``sigma = 0``) adds nothing and is left
out.  Post-classified every splat counts: a transparent voxel's value still moves the field
around it.
"""

from __future__ import annotations

import math

import numpy as np

from ...sandbox import check_bytes

#: Bytes a splat takes on the host and in its buffer: centre and value, and (sigma c, sigma) when
#: pre-classified; float32.
BYTES_PER_SPLAT = {False: 16, True: 32}


def ghost_layers(radius: float) -> int:
    """Layers of border copies a kernel of ``radius`` voxels reaches into the box from."""
    return int(math.ceil(radius))


class Splats:
    """The splats of ``volume`` (float32, world positions relative to ``centre``).

    ``values``: the value splatted, ``(n,)``; ``optics``: ``(n, 4)`` (sigma c, sigma) when
    pre-classified (then transparent voxels are left out), else None.
    """

    def __init__(self, volume, radius: float, centre: np.ndarray, optics_of_voxels: np.ndarray | None = None):
        g = ghost_layers(radius)
        nx, ny, nz = volume.dims
        check_bytes((nx + 2 * g) * (ny + 2 * g) * (nz + 2 * g) * (BYTES_PER_SPLAT[optics_of_voxels is not None] + 24),
                    "the splats", "use a smaller volume")
        # lattice indices from -g to n - 1 + g per axis; the clamped index is the sample copied
        axes = [np.arange(-g, n + g) for n in (nx, ny, nz)]
        clamped = [np.clip(a, 0, n - 1) for a, n in zip(axes, (nx, ny, nz))]
        iz, iy, ix = np.meshgrid(clamped[2], clamped[1], clamped[0], indexing="ij")
        keep = None
        if optics_of_voxels is not None:
            optics = optics_of_voxels[iz, iy, ix].reshape(-1, 4)
            keep = optics[:, 3] > 0
            self.optics = np.ascontiguousarray(optics[keep], dtype=np.float32)
        else:
            self.optics = None
        gz, gy, gx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        index = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
        values = volume.data[iz, iy, ix].ravel()
        if keep is not None:
            index, values = index[keep], values[keep]
        world = np.asarray(volume.origin) + index * np.asarray(volume.spacing)
        self.positions = world - centre  # float64 until uploaded
        self.values = values.astype(np.float64)
        self.total = (nx + 2 * g) * (ny + 2 * g) * (nz + 2 * g)

    def __len__(self) -> int:
        return len(self.values)

    def depths(self, eye, forward) -> np.ndarray:
        """View depth of each splat's centre (distance from the eye along the view axis)."""
        return (self.positions - eye) @ forward

    def packed(self, order: np.ndarray) -> tuple[bytes, bytes | None]:
        """The splats in ``order``: ``(centre, value)`` rows and ``(sigma c, sigma)`` rows, float32."""
        first = np.empty((len(order), 4), np.float32)
        first[:, :3] = self.positions[order]
        first[:, 3] = self.values[order]
        second = self.optics[order].tobytes() if self.optics is not None else None
        return first.tobytes(), second


def support_depth(radius: float, spacing, forward) -> float:
    """How far a kernel of ``radius`` voxels reaches along the view axis (world units): the ellipsoid's
    half-extent along ``forward``."""
    return float(radius * np.linalg.norm(np.asarray(spacing) * np.asarray(forward)))


def slabs(depth_lo: float, depth_hi: float, width: float) -> np.ndarray:
    """Slab boundaries ``(k + 1,)`` of ``width`` (world units) from view depth ``depth_lo`` to past
    ``depth_hi``: image-aligned sheets, fixed to the volume's nearest depth."""
    count = max(int(math.ceil((depth_hi - depth_lo) / width - 1e-9)), 1)
    return depth_lo + width * np.arange(count + 1)
