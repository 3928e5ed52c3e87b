"""From a slice of the spectrum to the image: the frame, the filter, the phase and the inverse transform.

The orthographic image's pixel ``(i, j)`` (row ``j`` from the top) is the line through ``X_00 + i p R + j p
D`` along the view (``R`` right, ``D`` down, ``p`` the pixel's width, ``X_00`` the top-left pixel's centre on
the eye's plane).  The projection ``P`` of the field along the view has the 2D transform ``F(u R + v D)``
(the projection-slice theorem), so

    P(X_ij) = sum_kl F(w_kl) exp(2 pi i w_kl.X_00) exp(2 pi i (k i / W' + l j / H')) du dv

over the frequencies ``w_kl = u_k R + v_l D``, ``u_k = k / (W' p)`` (numpy's ``fftfreq``): an inverse 2D DFT of
``W' x H'`` samples.  Its period ``W' p`` (``H' p``) spans the image and the field's projected support, so
no copy of the projection wraps into the image.  The frequencies stop at the grid's Nyquist limit
``1 / 2p``; the references point-sample the projection, whose frequencies go on (the filter's transform
decays, the voxels' spectrum is periodic), so where pixels are wider than voxels the grid is ``K`` times
finer than the pixels (:func:`oversampling`) and the image is every ``K``-th sample: the frequencies
between the pixels' limit and the grid's alias into it as they do into point samples.

``F(w) = exp(-2 pi i w.x_c) S(w M h) Phi(w)`` (:mod:`.spectrum`): the renderer interpolates ``S`` at the
slice's grid positions ``g = w M h`` in GL, the oracle in numpy; the rest is here, in float64.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ...gl.geometry import box_corners
from ...rays import RayBatch
from ...reference.model import gradient_magnitudes
from ...scene.model import GAUSSIAN_RADIUS
from ...transfer_function import ALPHA_MAX, projected_rgba
from .spectrum import fft_module, padded_length


def filter_transform(scene, w: np.ndarray) -> np.ndarray:
    """``Phi(w)``: the reconstruction filter's transform at world frequencies ``w`` ``(..., 3)`` (cycles
    per world unit), times the voxel's volume: the tent's ``sinc^2``, the cubic B-spline's ``sinc^4``, the
    Gaussian's ``exp(-2 pi^2 sigma^2 |w h|^2)`` per axis."""
    r, h = scene.renderer, np.asarray(scene.volume.spacing, float)
    wh = [w[..., a] * h[a] for a in range(3)]  # axis by axis: reductions along a short last axis are slow
    if r.filter == "gaussian":
        phi = np.exp(-2.0 * math.pi ** 2 * r.kernel_width ** 2 * (wh[0] ** 2 + wh[1] ** 2 + wh[2] ** 2))
    else:
        power = {"linear": 2, "cubic_bspline": 4}[r.filter]
        phi = (np.sinc(wh[0]) * np.sinc(wh[1]) * np.sinc(wh[2])) ** power
    return phi * float(np.prod(h))


def oversampling(scene) -> int:
    """``K``: the slice's grid is ``K`` times finer than the pixels, so that its frequencies reach
    ``renderer.slice_bandwidth`` times the voxels' Nyquist limit (the pixels' ``1 / 2p``, the voxels'
    ``1 / 2h`` along their finest axis)."""
    cam, img = scene.camera, scene.image
    pixel = 2.0 * cam.half_extent(img.width / img.height)[1] / img.height
    ratio = scene.renderer.slice_bandwidth * pixel / float(np.min(scene.volume.spacing))
    return max(1, int(math.ceil(ratio - 1e-9)))


class Frame:
    """The slice's frequency grid for ``scene`` (orthographic): ``size`` ``(W', H')``, ``oversampling`` ``K``,
    ``pixel`` the grid's spacing (the image pixel's width over ``K``), ``right``/``down`` the image's axes,
    ``origin`` ``X_00``, and ``w`` ``(H', W', 3)`` the frequencies.  The image is the inverse transform's
    every ``K``-th sample from ``X_00``."""

    #: Voxels of margin around the box's projection: the filters' reach (the Gaussian's 5 sigma at the
    #: default width is 3.5) and the band-limited interpolant's ringing, which falls off with distance
    MARGIN_VOXELS = 8.0

    def __init__(self, scene, made: dict | None = None):
        cam, img = scene.camera, scene.image
        w, h = img.width, img.height
        forward, right, up = (np.asarray(v, float) for v in cam.basis())
        hx, hy = cam.half_extent(w / h)
        self.oversampling = oversampling(scene)
        self.image_pixel = 2.0 * hy / h
        self.pixel = self.image_pixel / self.oversampling
        self.spacing = np.asarray(scene.volume.spacing, float)
        self.right, self.down, self.forward = right, -up, forward
        eye = np.asarray(cam.eye, float)
        self.origin = eye + (-hx + 0.5 * self.image_pixel) * right + (hy - 0.5 * self.image_pixel) * up
        lo, hi = scene.volume.bounds
        corners = box_corners(lo, hi) - self.origin
        margin = self.MARGIN_VOXELS * float(np.max(scene.volume.spacing))
        sizes = []
        for axis, count in ((self.right, w), (self.down, h)):
            along = corners @ axis
            first = min(0.0, float(along.min()) - margin)
            last = max((count - 1) * self.image_pixel, float(along.max()) + margin)
            samples = (last - first) / self.pixel
            # beyond MAX_SLICE the size is only refused (the GL limits): not rounded to a fast length, a
            # search that took minutes for a view height of 1e-9 (the grid of fftfreq: 59 GiB for 1e9)
            count = int(math.ceil(samples)) + 1 if math.isfinite(samples) else 2 ** 62
            sizes.append(padded_length(count, 1.0) if count < self.MAX_SLICE else count)
        self.size = tuple(sizes)
        self.kept = self._kept(scene)
        # what depends on the view, image and volume only (chords, the short chords' rays, the phases), not on
        # the cutoff: ``made``, a dict shared by the frames of one view, or a fresh one
        self._made = {} if made is None else made

    #: Samples a side past which the slice is not laid out: more than any GL's texture side (16384 on llvmpipe).
    MAX_SLICE = 1 << 16

    def _kept(self, scene) -> tuple[int, int, int]:
        """``renderer.slice_cutoff``'s low-pass: the half slice's first columns, first rows and last rows kept
        (those whose frequency is at most the cutoff times the voxels' Nyquist limit ``1 / 2h``, ``h`` the finest
        spacing, along the image's rows and columns); every one without a cutoff."""
        cutoff = scene.renderer.slice_cutoff
        columns, rows = self.size[0] // 2 + 1, self.size[1]
        if cutoff is None:
            return columns, rows, 0
        limit = cutoff / (2.0 * float(np.min(self.spacing))) * (1.0 + 1e-9)
        v = self.v
        kept = (int(np.count_nonzero(np.abs(self.u) <= limit)), int(np.count_nonzero((v >= 0) & (v <= limit))),
                int(np.count_nonzero((v < 0) & (v >= -limit))))
        return (columns, rows, 0) if kept[0] == columns and kept[1] + kept[2] == rows else kept

    def cut(self, values: np.ndarray) -> np.ndarray:
        """``values`` ``(H', W' / 2 + 1, ...)`` on the half slice, zero where the cutoff leaves the slice out
        (:meth:`_kept`; what the GL pass does not draw)."""
        columns, low, high = self.kept
        out = np.zeros_like(values)
        out[:low, :columns] = values[:low, :columns]
        if high:
            out[-high:, :columns] = values[-high:, :columns]
        return out

    @functools.cached_property
    def u(self) -> np.ndarray:
        """The grid's frequencies along the image's rows (cycles per world unit): the first ``W' / 2 + 1`` of
        ``fftfreq`` (the projection is real, its transform Hermitian: the other half is the conjugate of
        this one mirrored, and the inverse is ``irfft2``)."""
        return np.fft.fftfreq(self.size[0], self.pixel)[:self.size[0] // 2 + 1]

    @functools.cached_property
    def v(self) -> np.ndarray:
        """The grid's frequencies down the image's columns."""
        return np.fft.fftfreq(self.size[1], self.pixel)

    @functools.cached_property
    def w(self) -> np.ndarray:
        """The slice's world frequencies ``(H', W' / 2 + 1, 3)`` (made when first asked: the limits need only
        the size)."""
        return self.u[None, :, None] * self.right + self.v[:, None, None] * self.down

    @property
    def columns(self) -> int:
        """The half slice's columns, ``W' / 2 + 1``: what the GL pass draws."""
        return self.size[0] // 2 + 1

    def chords(self, scene) -> tuple[np.ndarray, np.ndarray]:
        """``(H, W)`` each pixel's chord through the volume's box (0 where it misses) and its midpoint's view
        depth from the eye, in float64: the rays are parallel and start on the eye's plane, so the slabs'
        parameters are sums of a row's and a column's term (a few ms at 512x512, where the general rays'
        took 150).  Made once a frame (the renderer keeps its frame while the view, image and volume hold)."""
        if "chords" not in self._made:
            self._made["chords"] = self._chords(scene)
        return self._made["chords"]

    def short_chords(self, scene) -> tuple[np.ndarray, RayBatch | None]:
        """``(H, W)`` the pixels whose chord is shorter than :data:`SHORT_CHORD_VOXELS` (integrated in the
        spatial domain) and their rays (None where there are none); made once a frame."""
        if "short" not in self._made:
            chord, _ = self.chords(scene)
            img = scene.image
            short = (chord > 0) & (chord < SHORT_CHORD_VOXELS * float(np.min(scene.volume.spacing)))
            rays = (RayBatch.for_camera(scene.camera, img.width, img.height, scene.volume.bounds,
                                        pixels=np.flatnonzero(short)) if short.any() else None)
            self._made["short"] = (short, rays)
        return self._made["short"]

    def _chords(self, scene) -> tuple[np.ndarray, np.ndarray]:
        img = scene.image
        lo, hi = (np.asarray(v, float) for v in scene.volume.bounds)
        i = np.arange(img.width) * self.image_pixel
        j = np.arange(img.height) * self.image_pixel
        enter, leave = np.full((img.height, img.width), -np.inf), np.full((img.height, img.width), np.inf)
        for a in range(3):
            o = self.origin[a] + j[:, None] * self.down[a] + i[None, :] * self.right[a]  # (H, W)
            d = self.forward[a]
            if d == 0.0:  # along the slab: inside while the origin is
                outside = (o < lo[a]) | (o > hi[a])
                leave = np.where(outside, -np.inf, leave)
                continue
            ta, tb = (lo[a] - o) / d, (hi[a] - o) / d
            enter, leave = np.maximum(enter, np.minimum(ta, tb)), np.minimum(leave, np.maximum(ta, tb))
        chord = np.maximum(leave - enter, 0.0)
        return chord, np.where(chord > 0.0, 0.5 * (enter + leave), 0.0)

    def scale(self, centre: np.ndarray, dtype=np.complex128) -> np.ndarray:
        """``exp(2 pi i w.(X_00 - x_c)) / p^2`` ``(H', W' / 2 + 1)``: the phase that moves the transform's
        origin from the spectrum's centre ``x_c`` to the image's first pixel, times the inverse transform's
        ``du dv W' H' = 1 / p^2``; computed in float64 (the phase reaches thousands of turns), kept as
        ``dtype`` (complex64 for the GL's float32 slices); made once a frame, centre and dtype."""
        key = ("scale", tuple(np.asarray(centre, float)), np.dtype(dtype))
        if key not in self._made:
            shift = self.origin - centre
            phase = (np.exp(2j * math.pi * self.v * (shift @ self.down))[:, None]  # separable in u and v
                     * np.exp(2j * math.pi * self.u * (shift @ self.right))[None, :])
            self._made[key] = (phase / (self.pixel * self.pixel)).astype(dtype)
        return self._made[key]

    def depth_direction(self, spectrum) -> np.ndarray:
        """The view axis in the spectrum's index units per world frequency (``f M h``, x, y, z): the
        direction the depth cue differentiates along."""
        return self.forward * np.asarray(spectrum.dims, float) * self.spacing

    def grid_positions(self, spectrum) -> np.ndarray:
        """``g = w M h``: where the slice samples the spectrum, in its index units ``(H', W' / 2 + 1, 3)``."""
        return self.w * (np.asarray(spectrum.dims, float) * self.spacing)


def channels(scene, dtype=np.float64) -> tuple[np.ndarray, np.ndarray, int]:
    """What is transformed ``(nz, ny, nx, C)`` with its ghost layers (:func:`with_ghosts`), the constants
    taken out ``(C,)`` and the ghost layers' count: the average's scalar, or the X-ray's classified voxels
    ``(sigma c, sigma)`` (associated), then with hemispherical shading the gradient magnitudes of the
    :func:`shaded_channels`; each less the mean of its border samples (a constant's line integral is
    that constant times the chord, added back exactly).  ``dtype``: float64 (the oracle's) or float32 (the
    renderer's: its spectrum is complex64; the X-ray classified by ``TransferFunction.classify_voxels`` in
    float32, each channel contiguous, a ``(C, nz, ny, nx)`` array seen as ``(nz, ny, nx, C)``)."""
    single = np.dtype(dtype) == np.float32
    if scene.renderer.compositing == "xray":
        values = scene.transfer_function.classify_voxels(scene.volume.data if single else
                                                         np.asarray(scene.volume.data, np.float64), True, dtype)
    else:
        values = np.asarray(scene.volume.data, dtype=dtype)[..., None]
    if scene.renderer.hemispherical_shading:  # the shaded channels' gradient magnitudes, transformed too
        shaded = values[..., list(shaded_channels(scene))]
        values = np.concatenate([values, gradient_magnitudes(shaded, scene.volume.spacing).astype(values.dtype)],
                                axis=-1)
    faces = [values[0], values[-1], values[:, 0], values[:, -1], values[:, :, 0], values[:, :, -1]]
    offsets = np.mean(np.concatenate([f.reshape(-1, values.shape[-1]) for f in faces]), axis=0, dtype=np.float64)
    offsets = offsets.astype(values.dtype).astype(np.float64)  # what is taken out is what is added back
    if np.shares_memory(values, scene.volume.data):  # the volume's own samples: a copy, never changed
        values = values - offsets.astype(values.dtype)
    else:  # made here (classified, converted, with the gradient magnitudes): in place, no second copy
        values -= offsets.astype(values.dtype)
    ghosted, border = with_ghosts(scene, values, 0 if clips_exactly(scene) else MOMENTS)
    return ghosted, offsets, border


def _profile(scene):
    """The filter's 1D profile along an axis (voxels) and its reach."""
    r = scene.renderer
    if r.filter == "gaussian":
        sigma = r.kernel_width
        return (lambda x: np.exp(-0.5 * (x / sigma) ** 2) / (sigma * math.sqrt(2.0 * math.pi))), GAUSSIAN_RADIUS * sigma
    if r.filter == "cubic_bspline":
        def bspline(x):
            a = np.abs(x)
            return np.where(a < 1, 2.0 / 3.0 - a * a + 0.5 * a ** 3,
                            np.where(a < 2, (2.0 - np.minimum(a, 2.0)) ** 3 / 6.0, 0.0))
        return bspline, 2.0
    return (lambda x: np.maximum(1.0 - np.abs(x), 0.0)), 1.0


#: Compensating ghost layers per face: they cancel the spill's first MOMENTS moments along the normal.
#: Cancelling the first moment too (2) was measured worse: its alternating layers are larger and their
#: band-limited image rings (blobs 32^3 at 48x48, RMS against reference-converged: the X-ray 3.3e-4 -> 2.3e-4,
#: but the average 1.2e-4 -> 2.1e-3; the ramp 0.117 -> 0.277 average).
MOMENTS = 1


def ghost_layers(scene) -> int:
    """How many ghost layers :func:`with_ghosts` puts on each face (the filter's reach, then the moments')."""
    _, reach = _profile(scene)
    return max(int(math.ceil(reach)) - 1, 0) + (0 if clips_exactly(scene) else MOMENTS)


def with_ghosts(scene, values: np.ndarray, moments: int | None = None) -> tuple[np.ndarray, int]:
    """``values`` ``(nz, ny, nx, C)`` with ghost layers on every face, and their count.  The references clip
    the rays at the box (the first and last samples' planes) and clamp the taps beyond it; Fourier
    rendering integrates whole lines.  So, per axis: the layers the filter reaches into the box from
    (``ceil(reach) - 1``) repeat the border sample, as the clamped taps do, and the next ``moments``
    layers cancel the first moments of what the field puts beyond the face along the axis
    (``sum_j c_j S_m(R + j) = -sum_n u_n S_m(n)``, ``S_m(n)`` the ``m``-th moment of a sample's profile
    beyond the face): with one, its integral.  Along the normal the spill is then zero; an oblique ray
    through the layers meets the field's variation along the face times the profile's first moment, an
    error of first order in the obliquity (``dvr_gl/renderers/fourier/README.md``)."""
    moments = MOMENTS if moments is None else moments
    profile, reach = _profile(scene)
    clamped = max(int(math.ceil(reach)) - 1, 0)
    if clamped + moments == 0:  # no layers (the trilinear field, clipped exactly): no copies of the channels
        return values, 0
    x = np.linspace(0.0, reach + clamped + moments + 2.0, 40001)
    sigma = scene.renderer.kernel_width

    def beyond(n, m):  # S_m(n): the m-th moment beyond the face (at 0, outward positive) of a sample at n
        if scene.renderer.filter == "gaussian" and m <= 1:
            # in closed form: the quadrature's grid cannot resolve a Gaussian narrower than its step (a
            # kernel_width of 1e-9 made the system singular)
            below = 0.5 * math.erfc(-n / (sigma * math.sqrt(2.0)))  # the share beyond the face
            return below if m == 0 else n * below + sigma / math.sqrt(2.0 * math.pi) * math.exp(-0.5 * (n / sigma) ** 2)
        return float(np.trapezoid(x ** m * profile(x - n), x))

    reach_in = int(math.ceil(reach))
    spilling = range(-reach_in, clamped + 1)  # the inside samples within reach of the face, then the clamped
    shares = np.array([[beyond(n, m) for n in spilling] for m in range(moments)])         # (moments, samples)
    solve = np.linalg.inv(np.array([[beyond(clamped + j, m) for j in range(1, moments + 1)]
                                    for m in range(moments)]).reshape(moments, moments))  # (layers, moments)
    out = values
    for axis in range(3):
        n = out.shape[axis]
        faces = []
        for side in (0, -1):
            take = lambda i: np.take(out, [i], axis=axis)  # noqa: E731
            edge = take(0 if side == 0 else n - 1)
            inside = [take(min(reach_in - k, n - 1) if side == 0 else max(n - 1 - reach_in + k, 0))
                      for k in range(reach_in + 1)]
            samples = inside + [edge] * clamped
            spill = [sum(s * u for s, u in zip(shares[m], samples)) for m in range(moments)]
            layers = [-sum(solve[j, m] * spill[m] for m in range(moments)) for j in range(moments)]
            faces.append([edge] * clamped + layers)
        out = np.concatenate(faces[0][::-1] + [out] + faces[1], axis=axis)
    return out, clamped + moments


def filter_derivative(scene, w: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """``direction . grad Phi(w)``: the filter's transform differentiated along ``direction`` (world)."""
    r, h = scene.renderer, np.asarray(scene.volume.spacing, float)
    wh = w * h
    phi = filter_transform(scene, w)
    if r.filter == "gaussian":
        return phi * (-4.0 * math.pi ** 2 * r.kernel_width ** 2) * (wh * h * direction).sum(axis=-1)
    power = {"linear": 2, "cubic_bspline": 4}[r.filter]
    s = np.sinc(wh)
    with np.errstate(invalid="ignore", divide="ignore"):
        ds = np.where(np.abs(wh) > 1e-8, (np.cos(math.pi * wh) - s) / np.where(wh == 0, 1.0, wh), 0.0)
    out = np.zeros(w.shape[:-1])
    for a in range(3):
        others = np.prod([s[..., b] ** power for b in range(3) if b != a], axis=0)
        out += direction[a] * h[a] * power * s[..., a] ** (power - 1) * ds[..., a] * others
    return out * float(np.prod(h))


def shaded_channels(scene) -> tuple[int, ...]:
    """What the model shades and weights by depth: the average's scalar, the X-ray's emission (not its
    extinction)."""
    return (0,) if scene.renderer.compositing == "average" else (0, 1, 2)


def weighted(scene) -> tuple[int, ...]:
    """The channels the depth cue weights: the shaded ones, and with hemispherical shading their gradient
    magnitudes (after the transformed channels: 1 for the average, 4 .. 6 for the X-ray)."""
    shaded = shaded_channels(scene)
    if not scene.renderer.hemispherical_shading:
        return shaded
    first = 1 if scene.renderer.compositing == "average" else 4
    return shaded + tuple(first + k for k in range(len(shaded)))


def filtered(scene, frame: Frame, slices: list[np.ndarray], derivatives=None):
    """``H = S Phi`` from the interpolated spectra ``S`` (``slices``), and with the depth cue's
    ``derivatives`` (channel -> ``d``, the interpolant's derivative along ``f M h``) ``f . grad H = d Phi + S
    (f . grad Phi)``: what the GL slice pass returns (``shaders/slice.frag``), in float64."""
    phi = filter_transform(scene, frame.w)
    if scene.renderer.slice_cutoff is not None:  # the low-pass: what the GL pass does not draw is zero
        phi = frame.cut(phi)
    out = [s * phi for s in slices]
    if derivatives is None:
        return out, None
    dphi = filter_derivative(scene, frame.w, frame.forward)
    if scene.renderer.slice_cutoff is not None:
        dphi = frame.cut(dphi)
    return out, {c: d * phi + slices[c] * dphi for c, d in derivatives.items()}


def finish(scene, frame: Frame, spectrum, slices: list[np.ndarray], offsets, derivatives=None,
           shell=None) -> np.ndarray:
    """The image ``(H, W, 4)`` float64 from the filtered slices ``slices`` (``H = S Phi``, :func:`filtered`;
    ``(H', W' / 2 + 1)`` complex, one per channel; the GL's complex64 are transformed in float32, 2x faster,
    within 1e-6 of the values here): the phase, the inverse transform (``irfft2``), the
    constants taken out before the transform (``offsets``, :func:`channels`) added back per chord, and the
    compositing mode's classification.

    Depth cueing (``renderer.depth_cue``, conventions: a weight ``a + b z`` linear in the view depth ``z``):
    the projection of ``((x - x_c).f) g`` has the transform ``(i / 2 pi) f.grad H`` on the slice (``H = S
    Phi``, Totsuka and Levoy), so ``derivatives`` (channel -> slice) holds ``f . grad H`` (:func:`filtered`)
    for the :func:`weighted` channels.

    Hemispherical shading (``renderer.hemispherical_shading``,
    :class:`dvr_gl.reference.model.HemisphericalShading`): ``ambient E + diffuse h (G + grad E . L) / 2``;
    the central differences along the axes are the multiplier ``i sum_a L_a sin(2 pi w_a h_a) / h_a`` on
    the slice, and ``G`` a transformed channel.

    ``shell`` ``(H, W, C)``: the whole lines' integrals beyond the box (:func:`shell_integrals`, weighted as
    the channels are), taken off when the channels have no compensating ghost layer (:func:`clips_exactly`)."""
    img, r = scene.image, scene.renderer
    w, h = img.width, img.height
    centre = spectrum.centre(scene.volume)
    scale = frame.scale(centre, slices[0].dtype)
    chord, middle = frame.chords(scene)
    cued = derivatives is not None
    if cued:
        forward = frame.forward
        eye = np.asarray(scene.camera.eye, float)
        a, b = cue_line(scene)
        z_c = float((centre - eye) @ forward)
        chord_weight = a + b * middle  # the mean weight over each chord: w is linear
    fft, _ = fft_module()
    threads = {"workers": -1} if fft is not np.fft else {}

    def project(spectral):
        k = frame.oversampling
        columns = spectral.shape[1]
        if columns == frame.columns:
            image = fft.irfft2(spectral * scale, s=frame.size[::-1], **threads)
            return image[:(h - 1) * k + 1:k, :(w - 1) * k + 1:k]
        # a cutoff's first columns (the rest zero): the columns' transforms of those only, then the rows' of the
        # image's rows only (irfft2 pads the columns with zeros and transforms them too)
        rows = fft.ifft(spectral * scale[:, :columns], axis=0, **threads)[:(h - 1) * k + 1:k]
        return fft.irfft(rows, n=frame.size[0], axis=1, **threads)[:, :(w - 1) * k + 1:k]

    def integral(c, slope=None, weight=cued):
        """The line integral of channel ``c`` (depth-weighted if ``weight``), or of its central differences
        along ``slope`` (toward the light; a constant has none)."""
        s = slices[c]
        k, dk, constant = 1.0, 0.0, offsets[c] * chord
        if slope is not None:
            spacing = np.asarray(scene.volume.spacing, float)
            wk = frame.w[:, :s.shape[1]]  # the columns read (a cutoff's first ones)
            k = 1j * np.sum(slope * np.sin(2.0 * math.pi * wk * spacing) / spacing, axis=-1)
            dk = 1j * np.sum(slope * 2.0 * math.pi * frame.forward * np.cos(2.0 * math.pi * wk * spacing), axis=-1)
            constant = 0.0
        outside = 0.0 if shell is None else shell[..., c]  # the whole lines' parts beyond the box (exact clip)
        plain = project(s if slope is None else k * s)
        if not weight:
            total = plain + constant
            # without the shell nothing to take off: no pass over the image for it (x - 0.0 is x, bit for bit)
            return total if shell is None else total - outside
        moment = project((1j / (2.0 * math.pi)) * (k * derivatives[c] + dk * s))
        return (a + b * z_c) * plain + b * moment + constant * chord_weight - outside

    shaded = shaded_channels(scene)
    if r.hemispherical_shading:
        from ...reference.model import toward_light

        light, sh = toward_light(scene), r.shading
        voxel = float(np.min(scene.volume.spacing))
        first = 1 if r.compositing == "average" else 4
        sums = {c: sh.ambient * integral(c) + sh.diffuse * voxel * 0.5 * (integral(first + k) + integral(c, light))
                for k, c in enumerate(shaded)}
    else:
        sums = {c: integral(c) for c in shaded}
    if r.compositing == "average":
        short, rays = frame.short_chords(scene)
        if rays is not None:
            sums[0][short] = direct_integrals(scene, rays, np.arange(len(rays.t0)))
        return average_rgba(scene.transfer_function, sums[0], chord)
    # the X-ray of the classified voxels: (sigma c, sigma) integrated; the band limit rings (Gibbs) where the
    # data jumps, which can take an integral of non-negative voxels below zero: clamped
    return _xray_image(sums, np.maximum(integral(3, weight=False), 0.0), chord > 0)


def compiled_average():
    """:mod:`.average_compiled` (numba) where numba is installed, else ``None`` (the numpy code here)."""
    try:
        from . import average_compiled
    except ImportError:
        return None
    return average_compiled


def average_rgba(tf, sums: np.ndarray, chord: np.ndarray) -> np.ndarray:
    """``(H, W, 4)`` premultiplied: each pixel's mean ``sums / chord`` classified (``projected_rgba``: one
    ``unit_distance``'s opacity), zero where the ray misses the box (``chord`` 0); in one compiled pass where
    numba is installed (:mod:`.average_compiled`, the same arithmetic)."""
    module = compiled_average()
    if module is not None:
        return module.average_rgba(tf, sums, chord, ALPHA_MAX)
    # every pixel classified, those off the box set to zero after: a masked scatter of (N, 4) rows took
    # 11-24 ms of a 512x512 view
    hit = chord > 0
    mean = np.where(hit, sums / np.where(hit, chord, 1.0), 0.0)
    out = projected_rgba(tf, mean.ravel()).reshape(sums.shape + (4,))
    out *= hit[..., None]  # zero off the box, in place (the classified colours are finite and not negative)
    return out


def _xray_image(sums, tau: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """``(H, W, 4)``: ``transfer_function.xray_rgba`` of the clamped emission integrals ``sums`` (channel ->
    ``(H, W)``) and ``tau`` (clamped), zero off the box (``hit``: there ``tau`` is set to zero, so alpha and
    the colour are).  ``sums`` and ``tau`` are this view's own arrays: clamped in place."""
    from ...transfer_function import xray_rgba

    emitted = [np.maximum(sums[c], 0.0, out=sums[c]) for c in range(3)]
    return xray_rgba(emitted, np.multiply(tau, hit, out=tau))


#: Gauss-Legendre points per piece of the shell pass: exact for the field's degree along a ray between
#: voxel planes (3 for the trilinear field, 9 for the cubic B-spline) times the depth cue's linear weight;
#: without the cue one fewer is exact (n points integrate degree 2n - 1).
SHELL_NODES = {"linear": 3, "cubic_bspline": 6}


def polynomial_nodes(r) -> int | None:
    """Gauss-Legendre points a piece that integrate the field exactly along a ray between the filter's knots
    (:data:`SHELL_NODES`; one fewer without the depth cue's linear weight), for the piecewise-polynomial
    filters without hemispherical shading; ``None`` otherwise (the Gaussian, or the gradient's magnitude,
    is no polynomial).  ``r``: the renderer's settings."""
    if r.filter not in SHELL_NODES or r.hemispherical_shading:
        return None
    return SHELL_NODES[r.filter] - (r.depth_cue >= 1.0)


def clips_exactly(scene) -> bool:
    """Whether the box's clip is exact: the channels get the clamped ghost layers only, and the whole
    lines' integrals beyond the box (:func:`shell_integrals`, the GL shell pass) are taken off.  For the
    piecewise-polynomial filters without hemispherical shading (whose central differences reach a voxel
    further), unless ``renderer.box_clip`` asks for the ghost layer (no pass a view); the Gaussian and the
    shaded channels keep the compensating ghost layer (:func:`with_ghosts`)."""
    return polynomial_nodes(scene.renderer) is not None and scene.renderer.box_clip == "exact"


class Shell:
    """Where the ghosted field lives: its samples zero-padded by ``pad`` (each tap of a point within the
    field's reach stays in the array), the padded array's first sample at world ``origin``, and the box
    ``outer`` beyond which the ghosted field is zero (the volume's box grown by the ghost layers and the
    filter's reach along each axis)."""

    def __init__(self, scene, border: int):
        _, reach = _profile(scene)
        self.pad = int(math.ceil(reach)) + 1
        self.border = border
        h = np.asarray(scene.volume.spacing, float)
        lo, hi = (np.asarray(v, float) for v in scene.volume.bounds)
        self.origin = lo - (border + self.pad) * h
        self.outer = (lo - (border + reach) * h, hi + (border + reach) * h)
        self.nodes = polynomial_nodes(scene.renderer)

    def padded(self, ghosted: np.ndarray) -> np.ndarray:
        return np.pad(ghosted, [(self.pad, self.pad)] * 3 + [(0, 0)])

    def empty(self, ghosted: np.ndarray) -> bool:
        """Whether the ghosted field is zero beyond the box: the ghost layers and the ``ceil(reach)``
        layers of samples next to each face, the only ones whose kernels reach beyond it, are all zero
        (as for data whose border is constant: the constant is taken out before the transform)."""
        k = self.pad - 1 + self.border
        faces = [ghosted[:k], ghosted[-k:], ghosted[:, :k], ghosted[:, -k:], ghosted[:, :, :k], ghosted[:, :, -k:]]
        return not any(np.any(f) for f in faces)


def shell_integrals(scene, ghosted: np.ndarray, border: int) -> np.ndarray:
    """``(H, W, C)``: each pixel's whole line's integral of the ghosted channels outside the volume's box,
    the :func:`weighted` channels times the depth cue's ``a + b z``; in float64 (the GL shell pass,
    ``shaders/shell.frag``, computes the same).  The field's pieces between the voxel planes
    (:func:`smooth_pieces`), each by Gauss-Legendre (:data:`SHELL_NODES`)."""
    from ...fields.reconstruction import SampledField, smooth_pieces
    from ...rays import intersect_box

    img, shell = scene.image, Shell(scene, border)
    if shell.empty(ghosted):
        return np.zeros((img.height, img.width, ghosted.shape[-1]))
    field = SampledField(shell.padded(ghosted), scene.volume.spacing, shell.origin, scene.renderer.filter)
    rays = RayBatch.for_camera(scene.camera, img.width, img.height, scene.volume.bounds)
    n = len(rays.t0)
    outer0, outer1 = intersect_box(rays.origins, rays.directions, *shell.outer)
    through = outer1 > outer0  # a ray along an axis beside the shell has infinite parameters: none
    outer0, outer1 = np.where(through, outer0, 0.0), np.where(through, outer1, 0.0)
    hit = rays.t1 > rays.t0
    # before the box and after it; a ray that misses the box: its whole stretch through the shell, once
    a = np.concatenate([outer0, np.where(hit, rays.t1, outer1)])
    b = np.concatenate([np.where(hit, rays.t0, outer1), np.where(hit, outer1, outer0)])
    owner = np.concatenate([np.arange(n), np.arange(n)])
    o, d = rays.origins[owner], rays.directions[owner]
    ray, pa, pb = smooth_pieces(field, o, d, a, np.maximum(a, b))
    x, w = np.polynomial.legendre.leggauss(shell.nodes)
    half = 0.5 * (pb - pa)
    t = pa[:, None] + half[:, None] * (x[None, :] + 1.0)
    points = o[ray][:, None, :] + t[..., None] * d[ray][:, None, :]
    values = field.sample(points.reshape(-1, 3)).reshape(len(ray), len(x), -1)
    cue_a, cue_b = cue_line(scene)
    forward, eye = np.asarray(scene.camera.basis()[0], float), np.asarray(scene.camera.eye, float)
    weight = np.ones_like(values)
    weight[..., list(weighted(scene))] = (cue_a + cue_b * ((points - eye) @ forward))[..., None]
    per_piece = np.einsum("pnc,pnc,n->pc", values, weight, w) * half[:, None]
    out = np.zeros((n, values.shape[-1]))
    np.add.at(out, owner[ray], per_piece)
    return out.reshape(img.height, img.width, -1)


#: The average of a chord shorter than this many voxels (of the finest spacing) is integrated in the
#: spatial domain: the band-limited line integral's error, of the order of the data's finest features
#: times a voxel, is divided by the chord, which goes to zero at the box's silhouette.
SHORT_CHORD_VOXELS = 4.0


def direct_integrals(scene, rays: RayBatch, rows: np.ndarray) -> np.ndarray:
    """The average's line integrals over the chords of ``rows`` in the spatial domain: the field's pieces
    between the filter's knots, each by Gauss-Legendre of what the model adds up
    (:meth:`OpticalModel.projected_values`: shaded and depth-cued if asked): :data:`SHELL_NODES`' points,
    exact for the polynomial pieces of the tent (degree 3) and the cubic B-spline (9) and with the depth
    cue's linear weight (2 points for the tent without a cue, where 6 took 8 of a cheap view's 30 ms); 6
    for the Gaussian and with hemispherical shading (the gradient's magnitude is no polynomial)."""
    from ...fields.reconstruction import smooth_pieces
    from ...reference.model import OpticalModel

    model = OpticalModel(scene, exact=True)
    o, d = rays.origins[rows], rays.directions[rows]
    x, weights = gauss_legendre(polynomial_nodes(scene.renderer) or 6)
    field = model.scalar
    module = compiled_average()
    trilinear = getattr(field, "kind", None) == "linear" and field.channels == 0  # a scalar grid's tent
    if module is not None and trilinear and model.hemispherical is None and model.depth_cue is None:
        # the trilinear field's integrals ray by ray (average_compiled.chord_integrals: the same pieces and nodes)
        return module.chord_integrals(field.values, field.spacing, field.origin, np.ascontiguousarray(o),
                                      np.ascontiguousarray(d), rays.t0[rows], rays.t1[rows], x, weights)
    ray, a, b = smooth_pieces(field, o, d, rays.t0[rows], rays.t1[rows])
    half = 0.5 * (b - a)
    t = a[:, None] + half[:, None] * (x[None, :] + 1.0)
    points = (o[ray][:, None, :] + t[..., None] * d[ray][:, None, :]).reshape(-1, 3)
    values = model.projected_values(points).reshape(len(ray), len(x))
    return np.bincount(ray, half * (values @ weights), minlength=len(rows))


@functools.lru_cache(maxsize=16)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1], kept (numpy's ``leggauss`` solves an eigenproblem each
    call: 0.75 ms of a cheap view's 25)."""
    x, weights = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = weights.flags.writeable = False
    return x, weights


def cue_line(scene) -> tuple[float, float]:
    """``(a, b)`` of the depth cue's weight ``a + b z`` (``z`` the view depth from the eye) between the box's
    nearest and farthest depths; ``(1, 0)`` without a cue."""
    from ...gl.geometry import box_corners
    from ...reference.model import depth_cue

    if scene.renderer.depth_cue >= 1.0:
        return 1.0, 0.0
    cue = depth_cue(scene)
    forward, eye = np.asarray(scene.camera.basis()[0], float), np.asarray(scene.camera.eye, float)
    depths = (box_corners(*scene.volume.bounds) - eye) @ forward
    near, far = max(float(depths.min()), scene.camera.near), float(depths.max())
    w_near, w_far = cue((eye + near * forward)[None, :])[0], cue((eye + far * forward)[None, :])[0]
    b = (w_far - w_near) / max(far - near, 1e-300)
    return float(w_near - b * near), float(b)
