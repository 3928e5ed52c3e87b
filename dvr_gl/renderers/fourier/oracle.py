"""The same-slices reference of ``fourier``: the spectrum interpolated in float64 numpy at the positions
the GL slice samples (the same kernel, wrap-around and Hermitian half) times the filter's transform,
then the same host steps (:mod:`.projection`).  Its difference from the renderer is the renderer's
complex64 spectrum and float32 texture, the shader's float32 weights (the windowed kernels' from a
table, within 1e-7) and filter; the model itself is judged by closed forms and the references
(``tests/test_fourier.py``)."""

from __future__ import annotations

import numpy as np

from .projection import Frame, channels, clips_exactly, filtered, finish, shell_integrals, weighted
from .spectrum import WINDOWED, Spectrum, kernel


def bspline_weights(f: np.ndarray, derivative: bool = False) -> list[np.ndarray]:
    """The cubic B-spline's weights of the taps ``-1 .. 2`` around ``floor(g)`` at fractions ``f`` (or
    their derivatives in ``f``)."""
    if derivative:
        return [-(1.0 - f) ** 2 / 2.0, (3.0 * f ** 2 - 4.0 * f) / 2.0, (-3.0 * f ** 2 + 2.0 * f + 1.0) / 2.0,
                f ** 2 / 2.0]
    return [(1.0 - f) ** 3 / 6.0, (3.0 * f ** 3 - 6.0 * f ** 2 + 4.0) / 6.0,
            (-3.0 * f ** 3 + 3.0 * f ** 2 + 3.0 * f + 1.0) / 6.0, f ** 3 / 6.0]


def _offsets(interpolation: str, taps: int) -> tuple[int, ...]:
    """The taps' offsets from ``floor(g)``."""
    if interpolation == "trilinear":
        return (0, 1)
    count = taps if interpolation in WINDOWED else 4
    return tuple(range(1 - count // 2, count // 2 + 1))


def _weights(interpolation: str, f: np.ndarray, derivative: bool = False, padding: float = 2.0, taps: int = 4):
    if interpolation == "trilinear":
        return [-np.ones_like(f), np.ones_like(f)] if derivative else [1.0 - f, f]
    if interpolation in WINDOWED:  # the tap at offset o lies f - o away
        k = kernel(interpolation, padding, taps)
        return [k(f - o, derivative) for o in _offsets(interpolation, taps)]
    return bspline_weights(f, derivative)


def interpolate(half: np.ndarray, dims, g: np.ndarray, interpolation: str, direction=None,
                padding: float = 2.0, taps: int = 4) -> np.ndarray:
    """``S`` at grid positions ``g`` ``(..., 3)`` (x, y, z) from the half spectrum ``half`` ``(Mz, My, Mx // 2
    + 1)``: periodic, and ``S(-k)`` the conjugate of ``S(k)`` for the half not stored; with ``direction``
    (index units), the interpolant's derivative along it instead."""
    m = np.asarray(dims)
    base = np.floor(g).astype(np.int64)
    f = g - base
    offsets = _offsets(interpolation, taps)
    plain = [_weights(interpolation, f[..., a], padding=padding, taps=taps) for a in range(3)]
    if direction is None:
        weights = plain
    else:  # the derivative along `direction` of the tensor product: one factor differentiated at a time
        slopes = [_weights(interpolation, f[..., a], True, padding, taps) for a in range(3)]
    out = np.zeros(g.shape[:-1], complex)
    for iz, oz in enumerate(offsets):
        for iy, oy in enumerate(offsets):
            for ix, ox in enumerate(offsets):
                k = np.mod(base + np.array([ox, oy, oz]), m)
                mirrored = k[..., 0] > m[0] // 2
                k = np.where(mirrored[..., None], np.mod(-k, m), k)
                value = half[k[..., 2], k[..., 1], k[..., 0]]
                value = np.where(mirrored, np.conj(value), value)
                if direction is None:
                    out += weights[2][iz] * weights[1][iy] * weights[0][ix] * value
                else:
                    wx, wy, wz = plain[0][ix], plain[1][iy], plain[2][iz]
                    out += (direction[0] * slopes[0][ix] * wy * wz + direction[1] * wx * slopes[1][iy] * wz
                            + direction[2] * wx * wy * slopes[2][iz]) * value
    return out


def oracle(scene) -> np.ndarray:
    """The image ``(H, W, 4)`` float64 that ``fourier`` must match."""
    r = scene.renderer
    data, offsets, border = channels(scene)
    spectrum = Spectrum(data, r.slice_interpolation, r.padding, border, r.slice_taps)
    frame = Frame(scene)
    g = frame.grid_positions(spectrum)
    slices = [interpolate(s, spectrum.dims, g, r.slice_interpolation, padding=r.padding, taps=r.slice_taps)
              for s in spectrum.spectra]
    derivatives = None
    if r.depth_cue < 1.0:
        direction = frame.depth_direction(spectrum)
        derivatives = {c: interpolate(spectrum.spectra[c], spectrum.dims, g, r.slice_interpolation, direction,
                                      r.padding, r.slice_taps)
                       for c in weighted(scene)}
    slices, derivatives = filtered(scene, frame, slices, derivatives)
    shell = shell_integrals(scene, data, border) if clips_exactly(scene) else None
    return finish(scene, frame, spectrum, slices, offsets, derivatives, shell)
