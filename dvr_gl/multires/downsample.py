"""Halving a node-centred grid with a low-pass filter: the step from one pyramid level to the next.

The grid's convention (:mod:`dvr_gl.fields.grid`): sample ``i`` sits at ``origin + i * spacing`` and the
box is the hull of the samples.  The default kernel, the tent ``[1 2 1] / 4`` (multigrid's "full
weighting", the adjoint of linear interpolation), is centred on the fine nodes: coarse sample ``j`` sits
on fine sample ``2j``, so a level keeps the origin, doubles the spacing of each halved axis and has
``n // 2 + 1`` samples along it.  For odd ``n`` its box is level 0's exactly; for even ``n`` the last
coarse sample lies one fine voxel beyond the last fine one, so a level's box covers level 0's and
exceeds it at the high end by less than one of its own voxels (a level never loses part of the box).
A level-``L`` voxel index is a level-0 index divided by ``2**L`` along the halved axes: what per-brick
level selection needs.  ``docs/multiresolution.md`` gives the measurements behind the choice (aliasing,
the error against the analytic Marschner-Lobb field and against full-resolution images, the box): every
low-pass kernel measured removes the aliasing of every-other-sample decimation about equally; the tent
keeps the most detail below the coarse Nyquist frequency.

Samples beyond the edges are reflected through the edge sample, ``f[-k] = 2 f[0] - f[k]`` (and alike at
the far end): a filter with symmetric weights then keeps linear functions exactly, up to and including
the edges (an even mirror, ``f[-k] = f[k]``, bends a ramp at the edge), and a constant volume exactly
constant.  On the nodes of the box every coarse sample is still a convex combination of fine ones (an
edge sample's reflected taps cancel: it equals the fine edge sample); only the extra sample beyond the
box of an even axis extrapolates, and it is clipped to the range of the fine samples it reads.  So a
level's values lie within the range of the fine samples under the kernel: no ringing, and level 0's
per-brick minimum and maximum, widened by the kernel's reach (one fine voxel), bound the coarse levels too.
(The clip costs ramps exactness in the last coarse cell of an even axis.)  Integer data is rounded to
the nearest integer in its own type; float data stays float32.  The sums are taken in float64.

Anisotropic spacing: an axis is halved when its spacing is less than ``sqrt(2)`` times the finest one (so
``(0.5, 0.5, 2)`` becomes ``(1, 1, 2)``, then ``(2, 2, 2)``, then isotropic halving); an axis with fewer
than 3 samples is never halved (it could not shrink).  OME-Zarr's per-axis ``scale`` records the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..fields.grid import Volume


@dataclass(frozen=True)
class Kernel:
    """A separable downsampling kernel: coarse sample ``j`` is ``sum(w[t] * f[2j + offsets[t]])``, and
    sits at fine index ``2j + shift`` (0: on the fine nodes; 0.5: between two)."""

    key: str
    name: str
    offsets: tuple[int, ...]
    weights: tuple[float, ...]
    shift: float = 0.0

    def response(self, frequency: float) -> float:
        """The magnitude of the kernel's frequency response at ``frequency`` (cycles per fine voxel):
        how much of a sinusoid survives (above the coarse Nyquist 0.25, the part that aliases)."""
        f = np.asarray(self.offsets, dtype=np.float64) - self.shift
        w = np.asarray(self.weights, dtype=np.float64)
        return float(abs(np.sum(w * np.exp(-2j * np.pi * frequency * f))))


TENT = Kernel("tent", "tent [1 2 1]/4 on the nodes (full weighting)", (-1, 0, 1), (0.25, 0.5, 0.25))
#: The kernels ``dvr bench scale --part levels`` compares; the pyramid uses :data:`TENT`.
KERNELS = {k.key: k for k in (
    Kernel("nearest", "every other sample (OME-Zarr's default, here on all three axes)", (0,), (1.0,)),
    TENT,
    Kernel("binomial", "binomial [1 4 6 4 1]/16 on the nodes", (-2, -1, 0, 1, 2),
           (1 / 16, 4 / 16, 6 / 16, 4 / 16, 1 / 16)),
    Kernel("box", "box [1 1]/2 between the nodes", (0, 1), (0.5, 0.5), 0.5),
    Kernel("cubic", "binomial [1 3 3 1]/8 between the nodes", (-1, 0, 1, 2), (1 / 8, 3 / 8, 3 / 8, 1 / 8), 0.5))}

#: An axis is halved while its spacing is below this factor times the finest spacing.
ANISOTROPY = math.sqrt(2.0)
#: An axis with fewer samples is never halved.
MIN_SAMPLES = 3


def halved_axes(dims, spacing) -> tuple[bool, bool, bool]:
    """Which of the x, y, z axes the next level halves (see the module doc)."""
    live = [n >= MIN_SAMPLES for n in dims]
    if not any(live):
        return (False, False, False)
    finest = min(s for s, ok in zip(spacing, live) if ok)
    return tuple(bool(ok and s < ANISOTROPY * finest) for s, ok in zip(spacing, live))


def coarse_count(n: int, kernel: Kernel = TENT) -> int:
    """Samples of a halved axis of ``n``: ``n // 2 + 1`` on the nodes (the box covered), ``n // 2``
    between them (the box shrinks by half a fine voxel at each end)."""
    return n // 2 + 1 if kernel.shift == 0 else max(n // 2, 1)


def level_geometry(dims, spacing, origin, kernel: Kernel = TENT):
    """``(dims, spacing, origin, halved)`` of the next level (x, y, z order)."""
    halved = halved_axes(dims, spacing)
    new_dims = tuple(coarse_count(n, kernel) if h else n for n, h in zip(dims, halved))
    new_spacing = tuple(2.0 * s if h else s for s, h in zip(spacing, halved))
    new_origin = tuple(o + kernel.shift * s if h else o for o, s, h in zip(origin, spacing, halved))
    return new_dims, new_spacing, new_origin, halved


def mirrored(index: np.ndarray, n: int) -> np.ndarray:
    """Fine indices mirrored about the edge samples into ``0 .. n - 1`` (``-k -> k``, ``n - 1 + k -> n - 1 - k``)."""
    if n == 1:
        return np.zeros_like(index)
    period = 2 * (n - 1)
    index = np.mod(index, period)
    return np.where(index >= n, period - index, index)


def fine_span(j0: int, j1: int, n: int, kernel: Kernel = TENT) -> tuple[int, int]:
    """The fine samples ``[lo, hi)`` that coarse samples ``j0 .. j1 - 1`` of a halved axis of ``n`` read
    (the edge sample included where a tap is reflected through it)."""
    index = 2 * np.arange(j0, j1)[:, None] + np.asarray(kernel.offsets)[None, :]
    used = mirrored(index, n)
    lo, hi = int(used.min()), int(used.max())
    return (0 if index.min() < 0 else lo), (n if index.max() > n - 1 else hi + 1)


def filter_axis(data: np.ndarray, axis: int, n: int, lo: int, j0: int, j1: int,
                kernel: Kernel = TENT) -> np.ndarray:
    """Coarse samples ``j0 .. j1 - 1`` along ``axis`` of ``data`` (float64), which holds fine samples
    ``lo ..`` of an axis of ``n`` (at least :func:`fine_span`'s); taps beyond an edge reflected through it."""
    coarse = 2 * np.arange(j0, j1)
    edge = {-1: np.take(data, [0 - lo], axis=axis) if coarse[0] + min(kernel.offsets) < 0 else None,
            1: np.take(data, [n - 1 - lo], axis=axis) if coarse[-1] + max(kernel.offsets) > n - 1 else None}
    shape = [1] * data.ndim
    shape[axis] = len(coarse)
    out, low, high = None, None, None
    for offset, weight in zip(kernel.offsets, kernel.weights):
        index = coarse + offset
        taken = np.take(data, mirrored(index, n) - lo, axis=axis)
        if n > 1:
            for side, beyond in ((-1, index < 0), (1, index > n - 1)):
                if beyond.any():
                    taken = np.where(beyond.reshape(shape), 2.0 * edge[side] - taken, taken)
        out = taken * weight if out is None else out + taken * weight
    outside = 2 * np.arange(j0, j1) + kernel.shift > n - 1  # beyond the box: an extrapolation, clipped
    if outside.any():
        pick = np.flatnonzero(outside)
        real = [np.take(data, mirrored(coarse[pick] + o, n) - lo, axis=axis) for o in kernel.offsets]
        low, high = np.minimum.reduce(real), np.maximum.reduce(real)
        clipped = np.clip(np.take(out, pick, axis=axis), low, high)
        index = [slice(None)] * data.ndim
        index[axis] = pick
        out[tuple(index)] = clipped
    return out


def downsample_block(data: np.ndarray, lo, dims, out_lo, out_dims, halved, kernel: Kernel = TENT) -> np.ndarray:
    """Coarse samples ``out_lo .. out_lo + out_dims - 1`` (x, y, z) from ``data``, the ``[z, y, x]`` fine
    samples from ``lo`` of a grid of ``dims``, covering :func:`fine_span` along each halved axis."""
    out = np.asarray(data, dtype=np.float64)
    for xyz in (2, 1, 0):  # z first: in a z-slab that shrinks the most data first
        axis = 2 - xyz
        j0, j1 = out_lo[xyz], out_lo[xyz] + out_dims[xyz]
        if halved[xyz]:
            out = filter_axis(out, axis, dims[xyz], lo[xyz], j0, j1, kernel)
        else:
            out = np.take(out, np.arange(j0, j1) - lo[xyz], axis=axis)
    return out


def to_type(values: np.ndarray, dtype) -> np.ndarray:
    """Float64 ``values`` in the grid's scalar type: integers rounded to nearest (and clipped to the type,
    which a positive kernel never needs but rounding of a sum may graze), float32 otherwise."""
    dtype = np.dtype(dtype)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(np.rint(values), info.min, info.max).astype(dtype)
    return values.astype(np.float32)


def downsample(volume, kernel: Kernel = TENT) -> Volume:
    """The next coarser level of an in-memory ``volume``: a :class:`~dvr_gl.fields.grid.Volume` with the
    spacing, origin and dims of :func:`level_geometry` (the volume itself when no axis can be halved)."""
    dims, spacing, origin, halved = level_geometry(volume.dims, volume.spacing, volume.origin, kernel)
    if not any(halved):
        return volume
    data = volume.read((0, 0, 0), volume.dims) if hasattr(volume, "read") else volume.data
    values = downsample_block(data, (0, 0, 0), volume.dims, (0, 0, 0), dims, halved, kernel)
    return Volume(to_type(values, volume.dtype), spacing=spacing, origin=origin, name=volume.name,
                  direction=volume.direction)
