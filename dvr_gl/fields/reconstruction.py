"""Reconstruction filters in float64: the continuous field a regular grid stands for.

Voxel coordinate ``u = (p - origin) / spacing`` per axis; sample ``i`` sits at
``u = i``.  Out-of-range taps are clamped to the edge (as GL's
CLAMP_TO_EDGE), so the field is defined on and slightly beyond the box.

* ``nearest``: the sample at ``floor(u + 0.5)``.
* ``linear``: trilinear interpolation between the 8 surrounding samples.
* ``cubic_bspline``: the uniform cubic B-spline applied to the samples (an
  approximating, smoothing, C2 filter; the GPU evaluates it with 8 trilinear
  fetches, Sigg & Hadwiger 2005).
* ``catmull_rom``: the interpolating Catmull-Rom cubic (C1; may overshoot).
* ``gaussian``: a footprint kernel (object-order renderers integrate it along rays).  Each sample
  carries a 3D Gaussian of standard deviation ``kernel_width`` voxels (per axis, so an ellipsoid in
  world units where the spacing is anisotropic), truncated at :data:`GAUSSIAN_RADIUS` standard deviations (a sphere
  in voxel units) and scaled to unit integral, and the field is the sum of the kernels
  ``sum_i v_i K(u - i)`` with the taps clamped like the others' (beyond the grid the border
  samples repeat), so that a splatter's footprints add up to it: linear in the samples, the
  X-ray of the field is the sum of the samples' footprints.  The kernels sum to one within
  ``(1 + 2 exp(-2 pi^2 sigma^2))^3 - 1`` (the lattice's ripple: 3.8e-4 at the default 0.7, 1.6e-8
  at 1), so a constant is constant to that; the model keeps the ripple rather than divide it out (Shepard's
  normalisation would make the X-ray no longer a sum of footprints).

The ray-space structure of each field is known: the filter is a polynomial
between *knots* (``u`` integer; half-integer for nearest), which the
converged integrator uses to split rays into smooth pieces.  The Gaussian is
smooth everywhere but at its truncation spheres (jumps of at most
``exp(-GAUSSIAN_RADIUS^2 / 2)`` = 3.7e-6 of a kernel's peak); its knots are the
voxel planes, which keep pieces to a voxel, the scale on which it varies, and its
``degree`` is that of the Chebyshev interpolant the converged reference fits to a
piece (:data:`GAUSSIAN_DEGREE`, measured in ``tests/renderers/test_gaussian_filter.py``).

"""

from __future__ import annotations

import math

import numpy as np

from ..scene.model import DEFAULT_KERNEL_WIDTH, FILTERS, GAUSSIAN_RADIUS
from .ragged import joined_knots, ranges

#: The degree of the polynomial the converged reference fits to a Gaussian field's piece (at most a
#: voxel long) for the exact extremum, first hit and breakpoints, as for the cubics: measured on random
#: data and rays, the interpolant is off by at most 1.5e-5 of the value range at sigma 0.7 (2.7e-5 at
#: 0.5), the same at degree 15 or 19: the truncation's jumps inside a piece set that floor.
GAUSSIAN_DEGREE = 9
#: Points a chunk of :meth:`SampledField._trilinear` (its temporaries stay in the cache).
CHUNK = 1 << 16
# Degree of the field as a polynomial of the ray parameter between knots.
DEGREE = {"nearest": 0, "linear": 3, "cubic_bspline": 9, "catmull_rom": 9, "gaussian": GAUSSIAN_DEGREE}


def _axis_taps(u: np.ndarray, n: int, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Tap indices and weights ``(N, taps)`` along one axis."""
    if kind == "nearest":
        i = np.clip(np.floor(u + 0.5), 0, n - 1).astype(np.int64)
        return i[:, None], np.ones((len(u), 1))
    if kind == "linear":
        uc = np.clip(u, 0.0, n - 1)
        i0 = np.clip(np.floor(uc), 0, max(n - 2, 0)).astype(np.int64)
        f = uc - i0
        idx = np.stack([i0, np.minimum(i0 + 1, n - 1)], axis=1)
        return idx, np.stack([1.0 - f, f], axis=1)
    i = np.floor(u)
    f = u - i
    f2, f3 = f * f, f * f * f
    if kind == "cubic_bspline":
        w = np.stack([(1 - f) ** 3 / 6.0, (3 * f3 - 6 * f2 + 4) / 6.0,
                      (-3 * f3 + 3 * f2 + 3 * f + 1) / 6.0, f3 / 6.0], axis=1)
    elif kind == "catmull_rom":
        w = np.stack([(-f3 + 2 * f2 - f) / 2.0, (3 * f3 - 5 * f2 + 2) / 2.0,
                      (-3 * f3 + 4 * f2 + f) / 2.0, (f3 - f2) / 2.0], axis=1)
    else:
        raise ValueError(f"unknown filter {kind!r}; choose one of {', '.join(FILTERS)}")
    idx = np.clip(i.astype(np.int64)[:, None] + np.arange(-1, 3)[None, :], 0, n - 1)
    return idx, w


_erf = np.vectorize(math.erf, otypes=[np.float64])  # numpy has no erf; tables are small


class GaussianKernel:
    """The truncated 3D Gaussian in voxel units: ``K(d) = exp(-|d|^2 / (2 sigma^2)) / M`` for
    ``|d| <= R = a sigma`` (``a`` = ``radius_in_sigmas``, the scene's ``renderer.kernel_radius``, by default
    :data:`GAUSSIAN_RADIUS`), zero beyond; ``M`` makes its integral one (the truncated mass, in closed form),
    so its line integral is a footprint of unit area."""

    def __init__(self, sigma: float, radius_in_sigmas: float | None = None):
        if not sigma > 0:
            raise ValueError(f"the Gaussian's kernel_width must be positive, got {sigma!r}")
        a = GAUSSIAN_RADIUS if radius_in_sigmas is None else float(radius_in_sigmas)
        if not a > 0:
            raise ValueError(f"the Gaussian's kernel_radius must be positive, got {radius_in_sigmas!r}")
        self.sigma = float(sigma)
        self.radius = a * self.sigma
        # The standard normal's mass inside a sphere of radius a (the chi distribution of 3 degrees).
        inside = math.erf(a / math.sqrt(2.0)) - math.sqrt(2.0 / math.pi) * a * math.exp(-0.5 * a * a)
        self.scale = 1.0 / ((2.0 * math.pi) ** 1.5 * self.sigma ** 3 * inside)
        # Taps per axis: offsets -reach+1 .. reach from floor(u) hold every sample within the radius.
        self.reach = int(math.ceil(self.radius))

    def __call__(self, d2: np.ndarray) -> np.ndarray:
        """The kernel at squared distances ``d2`` (voxels squared)."""
        return np.where(d2 <= self.radius ** 2, self.scale * np.exp(-0.5 * d2 / self.sigma ** 2), 0.0)

    def footprint(self, rho2: np.ndarray) -> np.ndarray:
        """The kernel's integral along a line at squared distance ``rho2`` from its centre (voxels):
        a 2D Gaussian cut by the sphere, ``exp(-rho^2 / 2 sigma^2) erf(sqrt(R^2 - rho^2) / (sigma
        sqrt 2)) / (2 pi sigma^2)``, over the truncated mass (the kernel's footprint)."""
        rho2 = np.asarray(rho2, dtype=np.float64)
        half = np.sqrt(np.maximum(self.radius ** 2 - rho2, 0.0)) / (self.sigma * math.sqrt(2.0))
        # scale * sqrt(2 pi) sigma: the 3D kernel's peak times the full 1D Gaussian's integral
        return (self.scale * math.sqrt(2.0 * math.pi) * self.sigma * np.exp(-0.5 * rho2 / self.sigma ** 2)
                * _erf(half))

    def kernel_sum(self, flat: np.ndarray, dims, u: np.ndarray) -> np.ndarray:
        """``sum_i v_i K(u - i)`` at voxel coordinates ``u`` ``(N, 3)`` for values ``flat``
        ``(nz * ny * nx, C)``, the taps clamped to the grid (its border samples repeat beyond it)."""
        nx, ny, nz = dims
        base = np.floor(u).astype(np.int64)
        frac = u - base
        offsets = np.arange(-self.reach + 1, self.reach + 1)
        # Per axis: squared distances to the taps (N, T) and the Gaussian's factor there (it is
        # separable; only its truncation is not).
        d2 = [(frac[:, axis, None] - offsets[None, :]) ** 2 for axis in range(3)]
        g = [np.exp(-0.5 * d / self.sigma ** 2) for d in d2]
        # The nearest any point of a cell comes to each tap: tap rows beyond the radius are skipped.
        near = np.maximum(np.maximum(offsets - 1, -offsets), 0).astype(np.float64) ** 2
        r2 = self.radius ** 2
        xs = np.clip(base[:, 0, None] + offsets[None, :], 0, nx - 1)
        scalar = flat.shape[1] == 1
        total = np.zeros((len(u), flat.shape[1]))
        for c, oz in enumerate(offsets):
            iz = np.clip(base[:, 2] + oz, 0, nz - 1)
            for b, oy in enumerate(offsets):
                if near[c] + near[b] > r2:
                    continue
                row = (np.clip(base[:, 1] + oy, 0, ny - 1) + iz * ny) * nx
                x = np.nonzero(near <= r2 - near[c] - near[b])[0]  # the row's taps that can be near enough
                x = slice(x[0], x[-1] + 1)
                w = ((g[2][:, c] * g[1][:, b])[:, None] * g[0][:, x]
                     * ((d2[2][:, c, None] + d2[1][:, b, None] + d2[0][:, x]) <= r2))
                taps = flat[row[:, None] + xs[:, x]]
                total += (w * taps[..., 0]).sum(axis=1)[:, None] if scalar else np.einsum("nt,ntc->nc", w, taps)
        return self.scale * total


class SampledField:
    """A volume (scalar ``(nz, ny, nx)`` or multi-channel ``(nz, ny, nx, C)``) reconstructed by a filter.

    ``kernel_width``: the Gaussian's standard deviation in voxels, ``kernel_radius`` where it is cut, in
    standard deviations (``gaussian`` only; :class:`GaussianKernel`).
    """

    def __init__(self, values: np.ndarray, spacing, origin, kind: str = "linear",
                 kernel_width: float | None = None, kernel_radius: float | None = None):
        if kind not in DEGREE:
            raise ValueError(f"unknown filter {kind!r}; choose one of {', '.join(FILTERS)}")
        self.values = values
        self.channels = values.shape[3] if values.ndim == 4 else 0
        self.flat = values.reshape(values.shape[0] * values.shape[1] * values.shape[2], -1)
        self.nz, self.ny, self.nx = values.shape[:3]
        self.spacing = np.asarray(spacing, dtype=np.float64)
        self.origin = np.asarray(origin, dtype=np.float64)
        self.kind = kind
        self.degree = DEGREE[kind]
        self.kernel = GaussianKernel(kernel_width or DEFAULT_KERNEL_WIDTH, kernel_radius) if kind == "gaussian" \
            else None

    def sample(self, points: np.ndarray) -> np.ndarray:
        """Field values at world points ``(N, 3)``: ``(N,)`` or ``(N, C)`` float64."""
        u = (np.asarray(points, dtype=np.float64) - self.origin) / self.spacing
        if self.kernel is not None:
            out = self.kernel.kernel_sum(self.flat, (self.nx, self.ny, self.nz), u)
            return out if self.channels else out[:, 0]
        if self.kind == "linear" and not self.channels:
            return self._trilinear(u)
        ix, wx = _axis_taps(u[:, 0], self.nx, self.kind)
        iy, wy = _axis_taps(u[:, 1], self.ny, self.kind)
        iz, wz = _axis_taps(u[:, 2], self.nz, self.kind)
        out = np.zeros((len(u), self.flat.shape[1]))
        for c in range(iz.shape[1]):
            for b in range(iy.shape[1]):
                row = (iz[:, c] * self.ny + iy[:, b]) * self.nx
                wzy = wz[:, c] * wy[:, b]
                for a in range(ix.shape[1]):
                    out += (wzy * wx[:, a])[:, None] * self.flat[row + ix[:, a]]
        return out if self.channels else out[:, 0]

    def _trilinear(self, u: np.ndarray) -> np.ndarray:
        """A scalar field's trilinear values at voxel coordinates ``u`` ``(N, 3)``: :meth:`sample`'s taps (clamped
        to the edge) combined axis by axis, a chunk of :data:`CHUNK` points at a time (its arrays stay in the cache;
        4-5x the general taps' speed, the same values to float64 rounding)."""
        flat = self.flat[:, 0]
        dims = np.array([self.nx, self.ny, self.nz])
        strides = np.array([1, self.nx, self.nx * self.ny])
        step = strides * (dims > 1)  # the next sample along each axis (none along an axis of one sample)
        out = np.empty(len(u))
        for start in range(0, len(u), CHUNK):
            c = np.clip(u[start:start + CHUNK], 0.0, dims - 1)
            i0 = np.minimum(np.floor(c), np.maximum(dims - 2, 0))
            f = c - i0
            fx, fy, fz = f[:, 0], f[:, 1], f[:, 2]
            base = i0.astype(np.int64) @ strides
            row = lambda b: flat[b] * (1.0 - fx) + flat[b + step[0]] * fx  # noqa: E731  along x at row b
            near = row(base) * (1.0 - fy) + row(base + step[1]) * fy
            far = row(base + step[2]) * (1.0 - fy) + row(base + step[2] + step[1]) * fy
            out[start:start + CHUNK] = near * (1.0 - fz) + far * fz
        return out

    def taps(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The samples :meth:`sample` weighs at world points (spline filters): ``(N, T)`` flat indices
        into ``data[z, y, x]`` and their weights; other values at the samples interpolate alike."""
        if self.kernel is not None:
            raise ValueError("taps: the Gaussian and particle kernels have no fixed taps")
        u = (np.asarray(points, dtype=np.float64) - self.origin) / self.spacing
        ix, wx = _axis_taps(u[:, 0], self.nx, self.kind)
        iy, wy = _axis_taps(u[:, 1], self.ny, self.kind)
        iz, wz = _axis_taps(u[:, 2], self.nz, self.kind)
        rows = (iz[:, :, None, None] * self.ny + iy[:, None, :, None]) * self.nx + ix[:, None, None, :]
        weights = wz[:, :, None, None] * wy[:, None, :, None] * wx[:, None, None, :]
        return rows.reshape(len(u), -1), weights.reshape(len(u), -1)

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """Central differences one voxel apart along each world axis, ``(N, 3)`` in value/world unit."""
        p = np.asarray(points, dtype=np.float64)
        g = np.empty((len(p), 3))
        for axis in range(3):
            h = np.zeros(3)
            h[axis] = self.spacing[axis]
            g[:, axis] = (self.sample(p + h) - self.sample(p - h)) / (2.0 * self.spacing[axis])
        return g

    def knots(self, origins: np.ndarray, directions: np.ndarray, t0: np.ndarray, t1: np.ndarray):
        """Ray parameters in ``(t0, t1)`` where a ray crosses a knot plane of the filter.

        Returns ``(ray_index, t)`` arrays (unsorted).  Between consecutive knots
        the field is a polynomial along the ray (smooth).
        """
        shift = 0.5 if self.kind == "nearest" else 0.0
        rays, ts = [], []
        for axis, n in enumerate((self.nx, self.ny, self.nz)):
            d = directions[:, axis] / self.spacing[axis]
            u0 = (origins[:, axis] - self.origin[axis]) / self.spacing[axis] - shift
            moving = np.abs(d) > 0
            ua = np.where(moving, u0 + t0 * d, 0.0)
            ub = np.where(moving, u0 + t1 * d, 0.0)
            lo = np.ceil(np.minimum(ua, ub))
            hi = np.floor(np.maximum(ua, ub))
            # Only knots inside the grid matter: beyond it the field is clamped (constant per axis).
            lo = np.maximum(lo, 0.0)
            hi = np.minimum(hi, n - 1)
            count = np.where(moving, np.maximum(hi - lo + 1, 0), 0).astype(np.int64)
            if count.sum() == 0:
                continue
            ray = np.repeat(np.arange(len(d)), count)
            knot = ranges(lo, count)
            t = (knot - u0[ray]) / d[ray]
            inside = (t > t0[ray]) & (t < t1[ray])
            rays.append(ray[inside])
            ts.append(t[inside])
        return joined_knots(rays, ts)


def smooth_pieces(field: SampledField, origins, directions, t0, t1):
    """The pieces ``(ray, a, b)`` of rays ``origins + t directions`` over ``[t0, t1]`` between the filter's
    knots (:meth:`SampledField.knots`; the field is a polynomial on each), sorted along each ray; ``ray``
    indexes the rays given.  Rays with ``t1 <= t0`` have none."""
    count = len(t0)
    k_ray, k_t = field.knots(origins, directions, t0, t1)
    local = np.concatenate([np.arange(count), np.arange(count), k_ray])
    t = np.concatenate([t0, t1, k_t])
    order = np.lexsort((t, local))
    local, t = local[order], t[order]
    keep = (local[1:] == local[:-1]) & (t[1:] > t[:-1])
    return local[:-1][keep], t[:-1][keep], t[1:][keep]

