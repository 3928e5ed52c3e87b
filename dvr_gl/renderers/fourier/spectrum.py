"""The spectrum Fourier volume rendering slices: pre-multiplied, zero-padded, transformed once.

Conventions (``dvr_gl/renderers/fourier/README.md``).  The volume's samples ``u[n]`` (``n`` per axis ``0 .. N - 1``)
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

import functools
import math

import numpy as np

#: The slice interpolation kernels (``renderer.slice_interpolation``).
INTERPOLATIONS = ("trilinear", "cubic_bspline", "windowed_sinc", "kaiser_bessel")
#: The windowed sinc: ``sinc(x)`` under a Kaiser window of shape ``KAISER_BETA`` (the window's side lobes
#: against its main lobe's width).  The Kaiser-Bessel kernel is the window alone, of the shape
#: :func:`kaiser_bessel_beta` gives for the padding.  Both reach ``taps / 2`` samples a side
#: (``renderer.slice_taps``: 4, the cubic's, or 6).
KAISER_BETA = 6.0
WINDOWED = ("windowed_sinc", "kaiser_bessel")


def kaiser_bessel_beta(padding: float, taps: int = 4) -> float:
    """The Kaiser-Bessel kernel's shape for ``W = taps`` and oversampling ``padding`` (Beatty, Nishimura
    and Pauly 2005): ``pi sqrt((W / s)^2 (s - 1/2)^2 - 0.8)``, 9.0 at the default padding 2 and 4 taps,
    13.9 with 6.  It puts the kernel's transform's first zero where the nearest replica's edge falls,
    so the replicas the interpolation ghosts in are smallest."""
    return math.pi * math.sqrt((taps / padding) ** 2 * (padding - 0.5) ** 2 - 0.8)


def kaiser_window(x: np.ndarray, beta: float, derivative: bool = False, half_width: float = 2.0) -> np.ndarray:
    """``I0(beta sqrt(1 - (x / a)^2)) / I0(beta)`` for ``|x| < a`` (``a`` the half-width; 0 beyond), or its
    derivative in ``x``."""
    x = np.asarray(x, dtype=np.float64)
    u = np.clip(x / half_width, -1.0, 1.0)
    root = np.sqrt(np.maximum(1.0 - u * u, 0.0))
    inside = np.abs(x) < half_width
    if not derivative:
        return np.where(inside, np.i0(beta * root) / np.i0(beta), 0.0)
    # d/dx I0(beta sqrt(1 - u^2)) = I1(.) beta (-u / sqrt(1 - u^2)) / a, and I1 = I0'
    safe = np.where(root > 1e-12, root, 1.0)
    slope = np.where(root > 1e-12, _i1(beta * root) * beta * (-u / safe) / half_width, 0.0)
    return np.where(inside, slope / np.i0(beta), 0.0)


def windowed_sinc(x: np.ndarray, derivative: bool = False, half_width: float = 2.0) -> np.ndarray:
    """The windowed-sinc kernel at ``x`` (spectrum samples), zero beyond ``half_width``; or its derivative
    (by the product rule, in float64)."""
    x = np.asarray(x, dtype=np.float64)
    window = kaiser_window(x, KAISER_BETA, False, half_width)
    s = np.sinc(x)
    if not derivative:
        return s * window
    with np.errstate(invalid="ignore", divide="ignore"):
        ds = np.where(np.abs(x) > 1e-8, (np.cos(np.pi * x) - s) / np.where(x == 0, 1.0, x), 0.0)
    return ds * window + s * kaiser_window(x, KAISER_BETA, True, half_width)


def kernel(interpolation: str, padding: float, taps: int = 4):
    """The windowed kernels ``k(x, derivative=False)`` of ``taps`` samples (the trilinear's and the cubic's
    weights are polynomials, :mod:`.oracle`)."""
    half = taps / 2.0
    if interpolation == "windowed_sinc":
        return lambda x, derivative=False: windowed_sinc(x, derivative, half)
    beta = kaiser_bessel_beta(padding, taps)
    return lambda x, derivative=False: kaiser_window(x, beta, derivative, half)


def _i1(z: np.ndarray) -> np.ndarray:
    """The modified Bessel function I1 by its power series (z <= 16: 30 terms reach float64)."""
    z = np.asarray(z, dtype=np.float64)
    term = z / 2.0
    total = term.copy()
    for k in range(1, 30):
        term = term * (z / 2.0) ** 2 / (k * (k + 1))
        total = total + term
    return total


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


@functools.lru_cache(maxsize=4)
def _gauss_legendre(n: int):
    """Gauss-Legendre nodes and weights on [-1, 1], once a process: 200 points take an eigenvalue problem,
    about 0.1 s on the busy machine, where each axis's pre-multiplication asked for them again."""
    x, w = np.polynomial.legendre.leggauss(n)
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def kernel_transform(interpolation: str, xi: np.ndarray, padding: float = 2.0, taps: int = 4) -> np.ndarray:
    """What interpolating the spectrum with the kernel multiplies the samples by, at ``xi`` (positions
    over the period): the kernel's transform, ``sinc^2`` for the tent (trilinear), ``sinc^4`` for the cubic
    B-spline, by quadrature for the windowed sinc and the Kaiser-Bessel kernel (whose shape depends on the
    padding and the taps)."""
    s = np.sinc(xi)
    if interpolation == "trilinear":
        return s * s
    if interpolation == "cubic_bspline":
        return s ** 4
    if interpolation in WINDOWED:  # Gauss-Legendre over the support (even: a cosine)
        half = taps / 2.0
        x, w = _gauss_legendre(200)
        x, w = half * (x + 1.0) / 2.0, w * half / 2.0
        xi = np.asarray(xi, dtype=np.float64)
        k = kernel(interpolation, padding, taps)
        return 2.0 * (np.cos(2.0 * math.pi * xi[..., None] * x) * (w * k(x))).sum(axis=-1)
    raise ValueError(f"unknown slice interpolation {interpolation!r}; choose one of {', '.join(INTERPOLATIONS)}")


class Spectrum:
    """The half spectra ``(Mz, My, Mx // 2 + 1)`` of ``channels`` (``(nz, ny, nx, C)`` float),
    pre-multiplied for ``interpolation`` and zero-padded by ``padding``: complex128 from float64 (the
    oracle's), complex64 from ``dtype=np.float32`` (the renderer's, whose textures are float32 anyway: half
    the memory and about half the transform's time).  ``dims`` ``(Mx, My, Mz)``, ``start`` the volume's
    first index in the padded grid per axis (x, y, z), ``seconds`` and ``bytes`` what making it took.

    ``sink(c, half)``: each channel's half spectrum is handed to it instead of kept (``spectra`` stays
    empty, ``count`` says how many): ``half`` is a buffer the next channel overwrites, so the sink copies
    what it needs (the renderer, straight into its textures' layout), and the transform's buffers are
    allocated once a spectrum, not once a channel (at 256^3 each is 100-130 MB of fresh pages)."""

    def __init__(self, channels: np.ndarray, interpolation: str, padding: float, border: int = 0, taps: int = 4,
                 dtype=np.float64, sink=None):
        import time

        start_time = time.perf_counter()
        fft, self.library = fft_module()
        nz, ny, nx, self.count = channels.shape
        n = (nx, ny, nz)
        self.dims = tuple(padded_length(k, padding) for k in n)
        self.start = tuple((m - k) // 2 for m, k in zip(self.dims, n))
        mx, my, mz = self.dims
        # 1 / k(xi) per axis over the volume's samples (separable: applied along x before the x pass, and
        # along y and z to the x pass's lines, which they scale whole)
        weights = []
        for axis, (m, k, s) in enumerate(zip(self.dims, n, self.start)):
            xi = (np.arange(k) + s - m / 2.0) / m
            weights.append((1.0 / kernel_transform(interpolation, xi, padding, taps)).astype(dtype))
        self.spectra = []
        complex_type = np.complex64 if np.dtype(dtype) == np.float32 else np.complex128
        line = np.zeros((nz, ny, mx), dtype)  # the x pass's zero-padded lines, reused by every channel
        buffers = {} if sink is not None else None
        self.bytes = 0
        for c in range(self.count):
            spectrum = padded_rfftn(channels[..., c], (mz, my, mx), self.start[::-1], fft, self.library == "scipy.fft",
                                    line, weights[::-1], buffers).astype(complex_type, copy=False)
            self.bytes += spectrum.nbytes
            if sink is None:
                self.spectra.append(spectrum)
            else:
                sink(c, spectrum)
        self.border = border  # layers of ghosts around the volume's samples in ``channels``
        self.seconds = time.perf_counter() - start_time

    def centre(self, volume) -> np.ndarray:
        """``x_c``: the world point of the padded grid's centre (the transform's origin)."""
        h = np.asarray(volume.spacing, float)
        first = np.asarray(volume.origin, float) - self.border * h  # the first (ghost) sample transformed
        return first + (np.asarray(self.dims) / 2.0 - np.asarray(self.start)) * h


def padded_rfftn(block: np.ndarray, dims, start, fft, threads: bool, line: np.ndarray | None = None,
                 weights=None, buffers: dict | None = None):
    """``rfftn`` of ``block`` ``(nz, ny, nx)`` zero-padded to ``dims`` ``(Mz, My, Mx)`` at ``start`` and
    ``ifftshift``-ed (:func:`_place_shifted`), one axis at a time (x, then z, then y), each padded only before
    its own pass: the lines that hold nothing but zeros are not transformed (the x pass transforms ``ny nz``
    lines instead of ``My Mz``, the z pass ``ny (Mx / 2 + 1)`` instead of ``My (Mx / 2 + 1)``).  The same
    numbers as the whole grid's ``rfftn``; 256^3 at padding 2 measured 6.6-7.8 s against 9.3-10.3 s, the
    orders x, y, z 8.2-8.8 s (two busy cores).  ``line``: zeros ``(nz, ny, Mx)`` of the block's dtype for the
    x pass, or None; the pass writes only the block's own samples there and leaves the rest as it was, so
    the channels of one spectrum share one (it is not allocated and zeroed for each).  ``weights``: ``(wz,
    wy, wx)``, the block multiplied by ``wz[z] wy[y] wx[x]`` on the way (in the x and z passes' copies: no
    pre-multiplied copy of the block).  ``buffers``: a dict that keeps the z and y passes' grids for the
    next call (the returned array is then the y pass's grid, overwritten by the next call)."""
    options = {"workers": -1, "overwrite_x": True} if threads else {}
    nz, ny, nx = block.shape
    mz, my, mx = dims
    wz, wy, wx = weights if weights is not None else (None, None, None)
    if line is None:
        line = np.zeros((nz, ny, mx), block.dtype)
    _place_shifted(line, block, start, axes=(2,), scale=None if wx is None else wx[None, None, :])
    half = fft.rfft(line, axis=2, **({"workers": -1} if threads else {}))  # (nz, ny, Mx / 2 + 1); line kept
    rows = None if wz is None else (wz[:, None] * wy[None, :]).astype(half.real.dtype)[..., None]
    deep = _grid(buffers, "deep", (mz, ny, half.shape[2]), half.dtype, start, nz, axis=0)
    _place_shifted(deep, half, start, axes=(0,), scale=rows)
    del half
    deep = fft.fft(deep, axis=0, **options)
    whole = _grid(buffers, "whole", (mz, my, deep.shape[2]), deep.dtype, start, ny, axis=1)
    _place_shifted(whole, deep, start, axes=(1,))
    if buffers is not None:
        buffers["deep"] = deep  # the pass's output, in place where the library could
    del deep
    whole = fft.fft(whole, axis=1, **options)
    if buffers is not None:
        buffers["whole"] = whole
    return whole


def _grid(buffers, name: str, shape, dtype, start, n: int, axis: int) -> np.ndarray:
    """A zero-padded grid for a pass along ``axis``: new zeros, or (``buffers``) the last call's grid with the
    rows outside the block's ``n`` (placed at ``start[axis]``, shifted) zeroed again."""
    grid = None if buffers is None else buffers.get(name)
    if grid is None or grid.shape != shape or grid.dtype != dtype:
        return np.zeros(shape, dtype)
    m = shape[axis]
    lo = (start[axis] - m // 2 + n) % m  # the block's end after the shift: m - n zero rows from there, wrapping
    for rows in (slice(lo, min(lo + m - n, m)), slice(0, max(lo + m - n - m, 0))):
        index = [slice(None)] * 3
        index[axis] = rows
        grid[tuple(index)] = 0
    return grid


def _place_shifted(padded: np.ndarray, block: np.ndarray, start, axes=(0, 1, 2), scale=None) -> None:
    """``padded`` (zeros, even lengths ``M`` along ``axes``) gets ``block`` at ``start`` per axis, as
    ``ifftshift`` of the padded grid would hold it (the grid's centre ``M / 2`` at index 0): each axis's run
    of indices split where it wraps, so no second grid is made.  The other axes are copied as they are.
    ``scale``: an array broadcast against ``block`` that multiplies it on the way."""
    pieces = []
    for axis, (m, n, s) in enumerate(zip(padded.shape, block.shape, start)):
        first = s - m // 2  # the block's first index after the shift, possibly negative
        if axis not in axes:
            pieces.append([(slice(None), slice(None))])
        elif first >= 0:
            pieces.append([(slice(first, first + n), slice(0, n))])
        elif first + n <= 0:
            pieces.append([(slice(m + first, m + first + n), slice(0, n))])
        else:
            pieces.append([(slice(m + first, m), slice(0, -first)), (slice(0, first + n), slice(-first, n))])
    for (dz, sz) in pieces[0]:
        for (dy, sy) in pieces[1]:
            for (dx, sx) in pieces[2]:
                if scale is None:
                    padded[dz, dy, dx] = block[sz, sy, sx]
                else:  # the scale's own axes of length 1 are taken whole
                    part = tuple(p if n > 1 else slice(None) for p, n in zip((sz, sy, sx), np.shape(scale)))
                    np.multiply(block[sz, sy, sx], scale[part], out=padded[dz, dy, dx], casting="same_kind")
