"""The spectrum Fourier volume rendering slices: pre-multiplied, zero-padded, transformed once.

Conventions (``docs/renderers/fourier.md``).  The volume's samples ``u[n]`` (``n`` per axis ``0 .. N - 1``)
sit in a zero grid of ``M = padding x N`` samples (rounded up to an even length the FFT likes), at
``s = (M - N) // 2``; the padded grid's centre ``M / 2`` is the origin of the transform, the world point
``x_c = origin + (M / 2 - s) h``.  Its discrete transform, at a continuous index ``g`` per axis,

    S(g) = sum_n u[n] exp(-2 pi i sum_a g_a (n_a - M_a / 2) / M_a)

is periodic in ``g`` (period ``M``) and Hermitian (``S(-g)`` is the conjugate of ``S(g)``), so only the
half ``g_x >= 0`` is stored (``rfftn``).  The field ``f(x) = sum_n u[n] phi(x - x_n)`` (``phi``: the
reconstruction filter, :mod:`.filters`) has the Fourier transform ``F(w) = exp(-2 pi i w.x_c) S(w M h)
Phi(w)`` (``w`` in cycles per world unit): the projection-slice theorem reads projections off it.

Between the grid's samples ``S`` is interpolated with a kernel ``K`` (the slice interpolation); in
space that multiplies the (periodic) volume by ``K``'s transform ``k(xi)``, ``xi = (n - M / 2) / M``, and
ghosts its replicas.  Pre-multiplication divides the samples by ``k(xi)`` first, so the central copy
comes out right.  For the cubic B-spline this also stands for its prefilter: whether the stored values
are made the B-spline coefficients of the pre-multiplied spectrum (a recursive filter along each axis,
in space a division by ``2/3 + cos(2 pi xi) / 3``) and that factor put back in the pre-multiplication,
or the samples taken as the coefficients, the coefficients' spatial signal is the volume over
``sinc^4`` either way: the same slices.  Multiplying by ``k`` instead of dividing is the common sign
slip (``tests/test_fourier.py`` shows what it costs).
"""

from __future__ import annotations

import math

import numpy as np

#: The slice interpolation kernels (``renderer.slice_interpolation``).
INTERPOLATIONS = ("trilinear", "cubic_bspline")


def fft_module():
    """``(module, name)``: scipy.fft (threads, the optional extra ``fourier``) or numpy.fft."""
    try:
        import scipy.fft as fft

        return fft, "scipy.fft"
    except ImportError:  # pragma: no cover - the extra is part of [all]
        return np.fft, "numpy.fft"


def padded_length(n: int, padding: float) -> int:
    """``padding x n`` rounded up to an even length of small prime factors (2, 3, 5): fast transforms."""
    target = max(int(math.ceil(padding * n)), n + 1)
    m = target + (target % 2)
    while True:
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        if k == 1:
            return m
        m += 2


def kernel_transform(interpolation: str, xi: np.ndarray) -> np.ndarray:
    """What interpolating the spectrum with the kernel multiplies the samples by, at ``xi`` (positions
    over the period): the kernel's transform, ``sinc^2`` for the tent (trilinear), ``sinc^4`` for the cubic
    B-spline."""
    s = np.sinc(xi)
    if interpolation == "trilinear":
        return s * s
    if interpolation == "cubic_bspline":
        return s ** 4
    raise ValueError(f"unknown slice interpolation {interpolation!r}; choose one of {', '.join(INTERPOLATIONS)}")


class Spectrum:
    """The half spectra ``(Mz, My, Mx // 2 + 1)`` complex128 of ``channels`` (``(nz, ny, nx, C)`` float),
    pre-multiplied for ``interpolation`` and zero-padded by ``padding``; ``dims`` ``(Mx, My, Mz)``,
    ``start`` the volume's first index in the padded grid per axis (x, y, z), ``seconds`` and ``bytes``
    what making it took."""

    def __init__(self, channels: np.ndarray, interpolation: str, padding: float, border: int = 0):
        import time

        start_time = time.perf_counter()
        fft, self.library = fft_module()
        nz, ny, nx, count = channels.shape
        n = (nx, ny, nz)
        self.dims = tuple(padded_length(k, padding) for k in n)
        self.start = tuple((m - k) // 2 for m, k in zip(self.dims, n))
        mx, my, mz = self.dims
        # 1 / k(xi) per axis over the volume's samples (separable)
        weights = []
        for axis, (m, k, s) in enumerate(zip(self.dims, n, self.start)):
            xi = (np.arange(k) + s - m / 2.0) / m
            weights.append(1.0 / kernel_transform(interpolation, xi))
        premultiply = weights[2][:, None, None] * weights[1][None, :, None] * weights[0][None, None, :]
        self.spectra = []
        for c in range(count):
            padded = np.zeros((mz, my, mx))
            sz, sy, sx = self.start[2], self.start[1], self.start[0]
            padded[sz:sz + nz, sy:sy + ny, sx:sx + nx] = channels[..., c] * premultiply
            # the padded grid's centre is the transform's origin: shift it to index 0
            shifted = np.fft.ifftshift(padded)
            kwargs = {"workers": -1} if self.library == "scipy.fft" else {}
            self.spectra.append(fft.rfftn(shifted, **kwargs))
        self.border = border  # layers of ghosts around the volume's samples in ``channels``
        self.seconds = time.perf_counter() - start_time
        self.bytes = sum(s.nbytes for s in self.spectra)

    def centre(self, volume) -> np.ndarray:
        """``x_c``: the world point of the padded grid's centre (the transform's origin)."""
        h = np.asarray(volume.spacing, float)
        first = np.asarray(volume.origin, float) - self.border * h  # the first (ghost) sample transformed
        return first + (np.asarray(self.dims) / 2.0 - np.asarray(self.start)) * h
