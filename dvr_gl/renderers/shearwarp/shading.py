"""Shear-warp's shading by lookup tables (Lacroute and Levoy 1994; Lacroute's thesis, 1995).

Every voxel's gradient (central differences one voxel apart, the references' gradient at a voxel
centre) is encoded once per volume: its normal quantized to one of ``NORMAL_GRID^2`` directions
(the octahedral map: the unit sphere folded onto a square, cells of nearly equal solid angle), plus
one code for "no normal" (a gradient at most the shading epsilon), and its gradient-magnitude
opacity factor ``min(1, |g| / reference)``.  Per frame, one Blinn-Phong table over the codes holds a
diffuse factor ``D`` (ambient plus the lights' diffuse terms, RGB) and a specular term ``S`` (RGB):
a voxel of colour ``c`` shades to ``c D + S``.

The view vector of the table is the camera's axis: exact for orthographic views; under perspective a
pixel's own view vector differs by up to half the field of view (Lacroute's approximation; the
reference makes the same).  Shading happens at the voxels and is interpolated with the slice's
bilinear weights: pre-classified voxels carry ``(sigma f (c D + S), sigma f)``, post-classified
samples take the interpolated ``D``, ``S`` and ``f`` (``colour(value) D + S``, ``sigma(value) f``).
:class:`VoxelShadedModel` is the same in float64 for the same-slices reference.
"""

from __future__ import annotations

import importlib

import numpy as np

from ...fields import gradient_epsilon
from ...shading import blinn_phong

#: Octahedral cells per side: 16384 directions (15 bits with the "no normal" code; Lacroute used 13);
#: a unit vector lies within 1.89 degrees of its code's direction, 0.67 on average (measured over 2e6
#: random directions, tests/test_shearwarp.py); in the image that is RMS 1e-4 to 2.3e-4 against the
#: voxels' own normals on the 64^3 demos (dvr_gl/renderers/shearwarp/README.md).
NORMAL_GRID = 128
NO_NORMAL = NORMAL_GRID * NORMAL_GRID


def encode_normals(normals: np.ndarray) -> np.ndarray:
    """Codes ``(N,)`` int32 of unit vectors ``(N, 3)`` (zero vectors: :data:`NO_NORMAL`): the octahedral
    map's cell ``(row, column)`` as ``row * NORMAL_GRID + column``."""
    n = np.asarray(normals, dtype=np.float64)
    norm1 = np.abs(n).sum(axis=1)
    zero = norm1 == 0
    p = n / np.where(zero, 1.0, norm1)[:, None]
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    # the lower hemisphere folded over the diagonals
    fx = np.where(z < 0, (1.0 - np.abs(y)) * np.where(x >= 0, 1.0, -1.0), x)
    fy = np.where(z < 0, (1.0 - np.abs(x)) * np.where(y >= 0, 1.0, -1.0), y)
    col = np.clip(np.floor((fx + 1.0) * 0.5 * NORMAL_GRID), 0, NORMAL_GRID - 1).astype(np.int32)
    row = np.clip(np.floor((fy + 1.0) * 0.5 * NORMAL_GRID), 0, NORMAL_GRID - 1).astype(np.int32)
    return np.where(zero, NO_NORMAL, row * NORMAL_GRID + col).astype(np.int32)


def decode_normals() -> np.ndarray:
    """``(NORMAL_GRID^2 + 1, 3)``: every code's direction (its cell's centre, unfolded), the last zero."""
    centres = (np.arange(NORMAL_GRID) + 0.5) / NORMAL_GRID * 2.0 - 1.0
    fy, fx = (a.ravel() for a in np.meshgrid(centres, centres, indexing="ij"))
    z = 1.0 - np.abs(fx) - np.abs(fy)
    x = np.where(z < 0, (1.0 - np.abs(fy)) * np.where(fx >= 0, 1.0, -1.0), fx)
    y = np.where(z < 0, (1.0 - np.abs(fx)) * np.where(fy >= 0, 1.0, -1.0), fy)
    v = np.stack([x, y, z], axis=1)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return np.concatenate([v, np.zeros((1, 3))])


def voxel_gradients(data: np.ndarray, spacing) -> np.ndarray:
    """``(nz, ny, nx, 3)`` float64 gradients (x, y, z) at the voxels: central differences one voxel
    apart, the edge voxels' outer neighbour clamped (as the references sample outside the grid)."""
    v = np.asarray(data, dtype=np.float64)
    out = np.empty(v.shape + (3,))
    for axis, array_axis in ((0, 2), (1, 1), (2, 0)):
        n = v.shape[array_axis]
        up = np.take(v, np.minimum(np.arange(n) + 1, n - 1), axis=array_axis)
        down = np.take(v, np.maximum(np.arange(n) - 1, 0), axis=array_axis)
        out[..., axis] = (up - down) / (2.0 * spacing[axis])
    return out


def unit_normals(gradients: np.ndarray, epsilon: float) -> np.ndarray:
    """``-g / |g|`` (``(..., 3)``), zero where ``|g|`` is at most ``epsilon`` (the shading convention)."""
    magnitude = np.linalg.norm(gradients, axis=-1, keepdims=True)
    return np.where(magnitude > epsilon, -gradients / np.maximum(magnitude, 1e-300), 0.0)


def diffuse_specular(normals: np.ndarray, view_direction, shading) -> tuple[np.ndarray, np.ndarray]:
    """Blinn-Phong split as ``c D + S``: the diffuse factor ``D`` (ambient included) and the specular
    term ``S``, ``(N, 3)`` each, of unit ``normals`` seen along ``view_direction``."""
    direction = np.broadcast_to(np.asarray(view_direction, dtype=np.float64), normals.shape)
    specular = blinn_phong(np.zeros_like(normals), normals, direction, shading)
    return blinn_phong(np.ones_like(normals), normals, direction, shading) - specular, specular


def compiled():
    """:mod:`.normals_compiled` (numba) when numba is installed, else ``None`` (the numpy passes here)."""
    try:
        return importlib.import_module(".normals_compiled", __package__)
    except ImportError:
        return None


class VoxelNormals:
    """A volume's encoded normals ``codes`` (int16) and, with a gradient-opacity reference, its factors
    ``factor`` (float32; else None), ``(nz, ny, nx)`` each: made once per volume and reference, in slabs
    of z to bound the float64 gradients' memory."""

    SLAB = 16
    use_compiled = True  # False: the numpy passes (the compiled loop's judge in the tests)

    def __init__(self, volume, gradient_reference: float | None):
        data = np.asarray(volume.data)
        nz = data.shape[0]
        epsilon = gradient_epsilon(volume)
        self.codes = np.empty(data.shape, np.int16)
        self.factor = None if gradient_reference is None else np.empty(data.shape, np.float32)
        readable = data.dtype.kind in "iu" or data.dtype in (np.float32, np.float64)  # numba reads no float16
        fast = compiled() if self.use_compiled and readable else None
        if fast is not None:
            with_factor = self.factor is not None
            fast.voxel_codes(data, np.asarray(volume.spacing, np.float64), float(epsilon), NORMAL_GRID, NO_NORMAL,
                             float(gradient_reference) if with_factor else 1.0, self.codes,
                             self.factor if with_factor else np.empty((1, 1, 1), np.float32), with_factor)
            return
        for z0 in range(0, nz, self.SLAB):
            lo, hi = max(z0 - 1, 0), min(z0 + self.SLAB + 1, nz)  # a neighbour slice either side
            g = voxel_gradients(data[lo:hi], volume.spacing)[z0 - lo:z0 - lo + min(self.SLAB, nz - z0)]
            normals = unit_normals(g, epsilon)
            self.codes[z0:z0 + len(g)] = encode_normals(normals.reshape(-1, 3)).reshape(g.shape[:-1])
            if self.factor is not None:
                self.factor[z0:z0 + len(g)] = np.minimum(1.0, np.linalg.norm(g, axis=-1) / gradient_reference)


def shading_table(shading, view_direction) -> tuple[np.ndarray, np.ndarray]:
    """``(D, S)``, each ``(NORMAL_GRID^2 + 1, 3)`` float64: the diffuse factor and specular term of
    every code, seen along ``view_direction`` (the camera's axis)."""
    return diffuse_specular(decode_normals(), view_direction, shading)


def frame_table(scene):
    """The frame's ``(D, S)`` table, or None where the scene does not shade (gradient opacity alone
    needs none)."""
    r = scene.renderer
    if not r.shading.enabled or not r.shading.lights:
        return None
    return shading_table(r.shading, scene.camera.basis()[0])


def unquantized_shades(scene, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(D, S)`` ``rows.shape + (3,)`` at the voxels ``rows`` (flat indices) from their own normals (no
    quantization): what the encoding's error is measured against."""
    r, volume = scene.renderer, scene.volume
    data = np.asarray(volume.data)
    nz, ny, nx = data.shape
    flat = rows.ravel()
    k, j, i = flat // (nx * ny), (flat // nx) % ny, flat % nx
    g = np.empty((len(flat), 3))
    for axis, (index, n, stride) in enumerate(((i, nx, 1), (j, ny, nx), (k, nz, nx * ny))):
        up = flat + (np.minimum(index + 1, n - 1) - index) * stride
        down = flat - (index - np.maximum(index - 1, 0)) * stride
        g[:, axis] = (data.ravel()[up].astype(np.float64) - data.ravel()[down]) / (2.0 * volume.spacing[axis])
    d, s = diffuse_specular(unit_normals(g, gradient_epsilon(volume)), scene.camera.basis()[0], r.shading)
    return d.reshape(rows.shape + (3,)), s.reshape(rows.shape + (3,))


class VoxelShadedModel:
    """The reference's optical model with shear-warp's shading (see the module doc): ``emission`` as
    :class:`dvr_gl.reference.model.OpticalModel`'s, shading and gradient opacity at the voxels, weighed
    by the filter's taps as the field is (only the voxels a sample reads: any volume size); everything
    else from ``base``.  ``quantized=False``: the voxels' own normals instead of their codes'."""

    def __init__(self, base, scene, quantized: bool = True):
        self.base, self.scene, self.quantized = base, scene, quantized
        r = scene.renderer
        self.voxels = VoxelNormals(scene.volume, r.gradient_opacity_reference if r.gradient_opacity else None)
        self.table = frame_table(scene)
        self.pre = r.classification == "pre"
        self.data = np.asarray(scene.volume.data).ravel()

    def __getattr__(self, name):
        return getattr(self.base, name)

    def _shades(self, rows):
        """``D``, ``S`` ``(N, T, 3)`` and ``f`` ``(N, T, 1)`` at the taps."""
        f = np.ones(rows.shape + (1,)) if self.voxels.factor is None else \
            self.voxels.factor.ravel()[rows].astype(np.float64)[..., None]
        if self.table is None:
            return np.ones(rows.shape + (3,)), np.zeros(rows.shape + (3,)), f
        if not self.quantized:
            return (*unquantized_shades(self.scene, rows), f)
        codes = self.voxels.codes.ravel()[rows]
        return self.table[0][codes], self.table[1][codes], f

    def emission(self, points, directions, cells=None):
        rows, w = self.base.scalar.taps(points)
        d, s, f = self._shades(rows)
        w = w[..., None]
        if self.pre:  # (sigma f (c D + S), sigma f) at the voxels, interpolated
            colour, sigma = self.scene.transfer_function.evaluate(self.data[rows].astype(np.float64))
            sigma = sigma[..., None] * f
            emitted = np.sum(w * sigma * (colour * d + s), axis=1)
            sigma = np.maximum(np.sum(w * sigma, axis=1)[:, 0], 0.0)
            with np.errstate(invalid="ignore", divide="ignore"):
                colour = np.where(sigma[:, None] > 0, np.maximum(emitted, 0.0) / sigma[:, None], 0.0)
            return colour, sigma
        colour, sigma = self.base.classify(points, None)
        return colour * np.sum(w * d, axis=1) + np.sum(w * s, axis=1), sigma * np.sum(w * f, axis=1)[:, 0]
