"""The splats of a grid, on the host: one per sample, their order along the view, and the slabs.

The Gaussian field sums the kernels of the grid's samples with the taps clamped
(:mod:`dvr_gl.fields.reconstruction`): beyond the grid the border samples repeat.  So the
splats are the samples and, around them, ``ghost`` layers of copies of the border samples
(as many as the kernel reaches, ``ceil(R)``), each splat integrated only over the part of the
ray inside the box: the same field, clipped where every renderer clips.

Pre-classified, a splat whose voxel is transparent (``sigma = 0``) adds nothing and is left
out.  Post-classified a transparent voxel's value still moves the field around it, so culling
works on regions (:func:`post_visibility`): a sample is *core* where the field within a voxel of
it can take a value the transfer function makes opaque (its range there is bounded by the samples
within the kernel's reach, widened by the kernels' ripple and the table's spacing); a splat is
kept within ``R + L + 1`` voxels of a core sample (``L``: the longest part of a ray in a slab).
The sheet buffer also counts the core samples that a slab part passes within half a voxel's
diagonal (``sqrt 3 / 2``) of; a part with none is transparent: each of its points lies that close
to its nearest sample, which is not core, so its true field is transparent there.  A part with one
comes within ``sqrt 3 / 2`` of a core sample, so every splat that reaches any of its points lies
within ``R + L + 1`` of it and is kept: the part's mean is exact, and the image is the one without
culling.
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


def lattice(values: np.ndarray, ghost: int) -> np.ndarray:
    """The grid's samples (``(nz, ny, nx[, C])``) with ``ghost`` layers of copies of its border around them."""
    return np.pad(values, [(ghost, ghost)] * 3 + [(0, 0)] * (values.ndim - 3), mode="edge")


class Splats:
    """The splats of ``volume`` (float32, world positions relative to ``centre``).

    ``values``: the value splatted, ``(n,)``; ``optics``: ``(n, 4)`` (sigma c, sigma) when
    pre-classified (then transparent voxels are left out), else None; ``visibility``: post-classified,
    the lattice's ``(keep, core)`` masks from :func:`post_visibility` (``core``: float32 flags of the
    kept splats), else every splat is kept.
    """

    def __init__(self, volume, radius: float, centre: np.ndarray, optics_of_voxels: np.ndarray | None = None,
                 visibility: tuple[np.ndarray, np.ndarray] | None = None):
        g = ghost_layers(radius)
        shape = tuple(n + 2 * g for n in volume.data.shape)
        self.total = shape[0] * shape[1] * shape[2]
        check_bytes(self.total * (BYTES_PER_SPLAT[optics_of_voxels is not None] + 24), "the splats",
                    "use a smaller volume")
        keep, self.core, self.optics = None, None, None
        if visibility is not None:
            keep = visibility[0].ravel()
            self.core = np.ascontiguousarray(visibility[1].ravel()[keep], dtype=np.float32)
        if optics_of_voxels is not None:
            optics = lattice(optics_of_voxels, g).reshape(-1, 4)
            keep = optics[:, 3] > 0
            self.optics = np.ascontiguousarray(optics[keep], dtype=np.float32)
        gz, gy, gx = np.indices(shape).reshape(3, -1) - g
        index = np.stack([gx, gy, gz], axis=1)
        values = lattice(volume.data, g).ravel()
        if keep is not None:
            index, values = index[keep], values[keep]
        self.index = index  # (n, 3) lattice indices (x, y, z), ghosts beyond 0 .. n - 1
        self.radius, self.spacing = radius, volume.spacing
        world = np.asarray(volume.origin) + index * np.asarray(volume.spacing)
        self.positions = world - centre  # float64 until uploaded
        self.values = values.astype(np.float64)

    def __len__(self) -> int:
        return len(self.values)

    def bounding_radii(self) -> float:
        """The splats' bounding sphere (world units): the kernel's support along the longest spacing."""
        return self.radius * float(np.max(self.spacing))

    def depths(self, eye, forward) -> np.ndarray:
        """View depth of each splat's centre (distance from the eye along the view axis)."""
        return (self.positions - eye) @ forward

    def attributes(self, order: np.ndarray) -> list[tuple[str, int, np.ndarray]]:
        """The instance attributes of the splats in ``order`` (name, floats, rows; float32): ``(centre,
        value)``, and ``(sigma c, sigma)`` (pre-classified) or core flags (post-classified with culling)."""
        first = np.empty((len(order), 4), np.float32)
        first[:, :3] = self.positions[order]
        first[:, 3] = self.values[order]
        out = [("in_splat", 4, first)]
        if self.optics is not None:
            out.append(("in_optics", 4, self.optics[order]))
        elif self.core is not None:
            out.append(("in_core", 1, self.core[order][:, None]))
        return out


def support_depth(radius: float, spacing, forward) -> float:
    """How far a kernel of ``radius`` voxels reaches along the view axis (world units): the ellipsoid's
    half-extent along ``forward``."""
    return float(radius * np.linalg.norm(np.asarray(spacing) * np.asarray(forward)))


def slabs(depth_lo: float, depth_hi: float, width: float) -> np.ndarray:
    """Slab boundaries ``(k + 1,)`` of ``width`` (world units) from view depth ``depth_lo`` to past
    ``depth_hi``: image-aligned sheets, fixed to the volume's nearest depth."""
    count = max(int(math.ceil((depth_hi - depth_lo) / width - 1e-9)), 1)
    return depth_lo + width * np.arange(count + 1)


def _window(array: np.ndarray, half: int, reduce) -> np.ndarray:
    """``reduce`` (np.minimum or np.maximum) over cubes of half-width ``half`` around every element, the
    array's border repeated beyond it (the clamped lattice)."""
    out = array
    for axis in range(3):
        padded = np.pad(out, [(half, half) if a == axis else (0, 0) for a in range(3)], mode="edge")
        n = out.shape[axis]
        acc = np.take(padded, range(0, n), axis=axis)
        for k in range(1, 2 * half + 1):
            acc = reduce(acc, np.take(padded, range(k, k + n), axis=axis))
        out = acc
    return out


def ripple(sigma: float | None) -> float:
    """How far the kernels' sum may stray from one, as a share of the samples' range the field lies
    within: the Gaussians' lattice ripple (``sigma``) and a margin for the truncation's; the cubic
    B-spline (``None``) is a partition of unity of non-negative weights, so its field lies within its
    taps' range: the margin only, for float32."""
    margin = 1e-4
    if sigma is None:
        return margin
    return (1.0 + 2.0 * math.exp(-2.0 * math.pi ** 2 * sigma ** 2)) ** 3 - 1.0 + margin


def post_visibility(volume, tf, radius: float, sigma: float | None, table_spacing: float, ghost: int,
                    part_voxels: float) -> tuple[np.ndarray, np.ndarray]:
    """Post-classified culling (module doc): the ``(keep, core)`` masks of the lattice with ``ghost``
    layers.  ``table_spacing``: the transfer-function table's spacing in data units (between its nodes
    the table may be opaque where the function is not); ``part_voxels``: the longest part of a ray in a
    slab, voxels."""
    samples = lattice(volume.data, ghost).astype(np.float64)
    near = int(math.ceil(radius)) + 1  # every tap of any point within a voxel of a sample
    lo, hi = _window(samples, near, np.minimum), _window(samples, near, np.maximum)
    widen = ripple(sigma) * np.maximum(np.abs(lo), np.abs(hi))
    core = tf.opaque_somewhere(lo - widen, hi + widen, margin=table_spacing)
    keep = _window(core, int(math.ceil(radius + part_voxels + 1.0)), np.maximum)
    return keep, core
