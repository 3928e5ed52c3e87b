"""The same-slices reference of ``fourier``: the spectrum interpolated in float64 numpy at the positions
the GL slice samples (the same kernel, wrap-around and Hermitian half), then the same host steps
(:mod:`.projection`).  Its difference from the renderer is the spectrum's float32 texture and the
shader's float32 weights; the model itself is judged by closed forms and the references
(``tests/test_fourier.py``)."""

from __future__ import annotations

import numpy as np

from .projection import Frame, channels, finish
from .spectrum import Spectrum


def bspline_weights(f: np.ndarray) -> list[np.ndarray]:
    """The cubic B-spline's weights of the taps ``-1 .. 2`` around ``floor(g)`` at fractions ``f``."""
    return [(1.0 - f) ** 3 / 6.0, (3.0 * f ** 3 - 6.0 * f ** 2 + 4.0) / 6.0,
            (-3.0 * f ** 3 + 3.0 * f ** 2 + 3.0 * f + 1.0) / 6.0, f ** 3 / 6.0]


def interpolate(half: np.ndarray, dims, g: np.ndarray, interpolation: str) -> np.ndarray:
    """``S`` at grid positions ``g`` ``(..., 3)`` (x, y, z) from the half spectrum ``half`` ``(Mz, My, Mx // 2
    + 1)``: periodic, and ``S(-k)`` the conjugate of ``S(k)`` for the half not stored."""
    m = np.asarray(dims)
    base = np.floor(g).astype(np.int64)
    f = g - base
    if interpolation == "trilinear":
        offsets, weights = (0, 1), [[1.0 - f[..., a], f[..., a]] for a in range(3)]
    else:
        offsets, weights = (-1, 0, 1, 2), [bspline_weights(f[..., a]) for a in range(3)]
    out = np.zeros(g.shape[:-1], complex)
    for iz, oz in enumerate(offsets):
        for iy, oy in enumerate(offsets):
            for ix, ox in enumerate(offsets):
                k = np.mod(base + np.array([ox, oy, oz]), m)
                mirrored = k[..., 0] > m[0] // 2
                k = np.where(mirrored[..., None], np.mod(-k, m), k)
                value = half[k[..., 2], k[..., 1], k[..., 0]]
                value = np.where(mirrored, np.conj(value), value)
                out += weights[2][iz] * weights[1][iy] * weights[0][ix] * value
    return out


def reference(scene) -> np.ndarray:
    """The image ``(H, W, 4)`` float64 that ``fourier`` must match."""
    r = scene.renderer
    data, offsets, border = channels(scene)
    spectrum = Spectrum(data, r.slice_interpolation, r.padding, border)
    frame = Frame(scene)
    g = frame.grid_positions(spectrum)
    slices = [interpolate(s, spectrum.dims, g, r.slice_interpolation) for s in spectrum.spectra]
    return finish(scene, frame, spectrum, slices, offsets)
