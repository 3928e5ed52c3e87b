"""Single scattering toward the eye, with shadows, in float64: what the lights add at a point.

Shared by both references (:class:`~dvr_gl.reference.model.OpticalModel` multiplies the colour by
:meth:`SingleScattering.factor`); they differ only in the transmittance toward a light:

* ``reference`` marches a shadow ray as a GPU renderer would: segments of the scene's sample distance
  from the point to where the ray leaves the box (or reaches a point light), the last one shortened,
  the extinction from the transfer-function table at each segment's midpoint; with ``method =
  "light_volume"`` it marches them from the nodes of the light volume (:func:`light_volume_nodes`)
  instead and interpolates their optical depths trilinearly, as the GPU samples its light volume; with
  ``"half_angle"`` it accumulates the light buffer of half-angle slicing (:mod:`dvr_gl.half_angle`)
  slice by slice as a half-angle slicer does, and looks a point up bilinearly in the buffer the slices
  nearer the light than it left;
* ``reference-converged`` integrates the optical depth between the field's knots by Gauss-Legendre,
  bisecting until its error at each point is within the share of the pixel's budget that point can
  spend (see :meth:`SingleScattering._tolerances`).

The model (:class:`dvr_gl.scene.model.ScatteringSpec`, ``docs/scattering.md``): the source term at ``x``
seen along a ray of unit direction ``d`` is ``sigma c ((1 - a) + a F(x))`` with

    F(x) = sum over lights of 4 pi p(cos theta) E(x) T(x)

``a`` the albedo, ``p`` the phase function normalised to 1 over the sphere, ``cos theta`` the cosine
between the direction the light travels at ``x`` and the direction toward the eye ``-d``, ``E`` the
light's irradiance (RGB: intensity times colour; a point light's divided by the squared distance,
which is at least half the smallest voxel) and ``T`` the transmittance from ``x`` to the light (1
without shadows).
"""

from __future__ import annotations

import numpy as np

from ..rays import intersect_box
from ..scene.settings import constant_albedo

FOUR_PI = 4.0 * np.pi
#: Bisection rounds of the converged optical depth before a piece is taken as it is.
MAX_ROUNDS = 40
#: Shadow samples evaluated at once (the march's points times their segments).
SAMPLES_PER_BATCH = 1 << 20


def isotropic(cos_theta: np.ndarray) -> np.ndarray:
    """The isotropic phase function, ``1 / (4 pi)`` per steradian."""
    return np.full(np.shape(cos_theta), 1.0 / FOUR_PI)


def henyey_greenstein(cos_theta: np.ndarray, g: float) -> np.ndarray:
    """Henyey-Greenstein, normalised to 1 over the sphere, mean cosine ``g`` in (-1, 1):
    ``(1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^(3/2))``.  The denominator is written as a sum of
    non-negative terms, ``(1 - g)^2 + 2 g (1 - cos)`` for ``g >= 0`` and ``(1 + g)^2 - 2 g (1 + cos)``
    otherwise, so that it keeps its digits where it is smallest (``g -> +-1``, ``cos -> +-1``)."""
    mu = np.clip(np.asarray(cos_theta, dtype=np.float64), -1.0, 1.0)
    if g >= 0.0:
        denom = (1.0 - g) ** 2 + 2.0 * g * (1.0 - mu)
    else:
        denom = (1.0 + g) ** 2 - 2.0 * g * (1.0 + mu)
    return (1.0 - g) * (1.0 + g) / (FOUR_PI * denom ** 1.5)


def phase_function(spec):
    """The scene's phase function as ``p(cos_theta)``."""
    if spec.phase == "isotropic":
        return isotropic
    return lambda mu: henyey_greenstein(mu, spec.g)


def phase_maximum(spec) -> float:
    """The largest value of ``4 pi p``: 1 (isotropic), ``(1 + |g|) / (1 - |g|)^2`` (Henyey-Greenstein)."""
    if spec.phase == "isotropic":
        return 1.0
    g = abs(spec.g)
    return (1.0 + g) / (1.0 - g) ** 2


class SingleScattering:
    """The factor ``(1 - a) + a F(x)`` (RGB) of a scene's lights at points.

    Args:
        scene: a resolved scene with ``renderer.scattering`` enabled.
        extinction: ``extinction(points, cells) -> sigma`` as the reference classifies (table or exact).
        pieces: ``pieces(origins, directions, t0, t1) -> (ray, a, b, cell)``, the smooth pieces of
            shadow rays (converged), or None to march them at ``step`` (same discretization).
        step: the march's segment length, world units.
        tolerance: the converged reference's per-pixel budget (with ``pieces``).
    """

    def __init__(self, scene, extinction, pieces=None, step: float | None = None, tolerance: float = 1e-4,
                 nodes: int = 4):
        self.spec = scene.renderer.scattering
        self.scene = scene
        self.buffers = None  # half-angle slicing: the light buffers, made when first needed
        self.grid = None  # the light volume's nodes and optical depths, made when first needed
        self.extinction = extinction
        self.pieces = pieces
        self.step = step
        self.tolerance = tolerance
        self.lo, self.hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
        self.min_distance = 0.5 * float(getattr(scene.field, "sample_spacing", 1.0))
        self.phase = phase_function(self.spec)
        self.x, self.w = np.polynomial.legendre.leggauss(nodes)
        self.stats = {"shadow_evaluations": 0}

    # --- the lights' geometry ---------------------------------------------------------------

    def _light(self, light, points):
        """``(toward (N, 3) unit vectors to the light, irradiance (N, 3), reach (N,))``: how far the
        shadow ray goes (to the box's exit, or to a point light inside it)."""
        irradiance = light.intensity * np.asarray(light.color, dtype=np.float64)
        if light.type == "directional":
            w = np.asarray(light.direction, dtype=np.float64)
            toward = np.broadcast_to(-w / np.linalg.norm(w), points.shape)
            energy = np.broadcast_to(irradiance, points.shape)
            distance = np.full(len(points), np.inf)
        else:
            v = np.asarray(light.position, dtype=np.float64) - points
            distance = np.linalg.norm(v, axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                toward = np.where(distance[:, None] > 0, v / distance[:, None], np.array([0.0, 0.0, 1.0]))
            energy = irradiance / np.maximum(distance, self.min_distance)[:, None] ** 2
        _, exit_t = intersect_box(points, np.ascontiguousarray(toward), self.lo, self.hi)
        reach = np.clip(np.minimum(exit_t, distance), 0.0, None)
        return np.ascontiguousarray(toward), energy, np.where(np.isfinite(reach), reach, 0.0)

    def factor(self, points: np.ndarray, directions: np.ndarray, albedo: np.ndarray | None = None) -> np.ndarray:
        """``(1 - a) + a F`` at ``points`` seen along unit ``directions`` (both ``(N, 3)``); ``albedo``: ``a``
        at each point (the transfer function's column), or None for the scene's number."""
        a = constant_albedo(self.scene.renderer) if albedo is None else np.asarray(albedo, np.float64)[:, None]
        points = np.asarray(points, dtype=np.float64)
        total = np.zeros(points.shape)
        lights = [self._light(light, points) for light in self.spec.lights]
        weights = []
        for light, (toward, energy, _) in zip(self.spec.lights, lights):
            cos_theta = np.sum(-toward * -np.asarray(directions, dtype=np.float64), axis=1)
            weights.append(FOUR_PI * self.phase(cos_theta)[:, None] * energy)
        depths = self._grid_depths(points)  # the light volume's or the light buffer's, if the method has one
        for i, ((toward, _, reach), weight, tol) in enumerate(zip(lights, weights, self._tolerances(weights, a))):
            lit = np.any(weight > 0, axis=1)
            t = np.zeros(len(points))
            if not self.spec.shadows:
                t[lit] = 1.0
            elif depths is not None:
                t[lit] = np.exp(-depths[i][lit])
            elif lit.any():
                t[lit] = self.transmittance(points[lit], toward[lit], reach[lit], tol[lit])
            total += weight * t[:, None]
        return (1.0 - a) + a * total

    def _grid_depths(self, points):
        """Per light, the optical depth at points from the method's grid: the light volume's, or half-angle
        slicing's light buffer (one light); None for shadow rays (and the converged reference)."""
        if not self.spec.shadows or self.pieces is not None:
            return None
        if self.spec.method == "light_volume":
            return self._light_volume_depths(points)
        if self.spec.method == "half_angle":
            return [self._light_buffer_depths(points)]
        return None

    def _light_buffer_depths(self, points) -> np.ndarray:
        """Half-angle slicing's light buffer at points: the optical depth the slices nearer the light than
        a point (by half a spacing or more: a point on slice k sees the slices before it) left,
        bilinear between the buffer's pixel centres."""
        from ..half_angle import half_angle

        if self.buffers is None:
            geometry = half_angle(self.scene.camera, (self.lo, self.hi), self.spec.lights[0].direction,
                                  self.scene.renderer.sample_distance, self.spec.light_buffer_size)
            self.buffers = (geometry, self._accumulated(geometry))
        geometry, cumulative = self.buffers
        offset = (np.asarray(points, dtype=np.float64) - geometry.eye) @ geometry.normal
        k_min = np.ceil((offset + 0.5 * geometry.spacing - geometry.anchor) / geometry.spacing).astype(np.int64)
        index = np.clip(geometry.first - k_min + 1, 0, len(cumulative) - 1)  # planes first .. k_min drawn
        none = k_min > geometry.first
        uv = geometry.light_uv(points)
        tau = bilinear(cumulative, index, uv)
        return np.where(none, 0.0, tau)

    def _accumulated(self, geometry) -> np.ndarray:
        """``(K + 1, ny, nx)``: the light buffer after 0, 1, ... K slices in drawing order."""
        from ..sandbox import check_bytes

        nx, ny = geometry.size
        ks = geometry.order()
        check_bytes((len(ks) + 1) * nx * ny * 8.0 * 3, "half-angle slicing's light buffers in the reference",
                    "lower renderer.scattering.light_buffer_size or the image's size")
        i, j = np.meshgrid((np.arange(nx) + 0.5) / nx, (np.arange(ny) + 0.5) / ny)
        pixels = (geometry.origin + (i.ravel() * geometry.extent[0])[:, None] * geometry.axis_u
                  + (j.ravel() * geometry.extent[1])[:, None] * geometry.axis_v)
        along = float(geometry.toward_light @ geometry.normal)
        out = np.zeros((len(ks) + 1, ny * nx))
        for n, k in enumerate(ks):
            s = (geometry.offsets(k) - (pixels - geometry.eye) @ geometry.normal) / along
            y = pixels + s[:, None] * geometry.toward_light
            inside = np.all((y >= self.lo) & (y <= self.hi), axis=1)
            slab = np.zeros(len(y))
            if inside.any():
                slab[inside] = self.extinction(y[inside], None) * geometry.light_length
            out[n + 1] = out[n] + slab
        return out.reshape(len(ks) + 1, ny, nx)

    def _light_volume_depths(self, points):
        """Each light's optical depth at points, trilinear between the light volume's nodes."""
        if self.grid is None:
            nodes, dims = light_volume_nodes(self.lo, self.hi, self.spec.light_volume_size)
            depths = []
            for light in self.spec.lights:
                toward, _, reach = self._light(light, nodes)
                depths.append(self._marched(nodes, toward, reach).reshape(dims[::-1]))
            self.grid = (dims, depths)
        dims, depths = self.grid
        return [trilinear(d, self.lo, self.hi, points) for d in depths]

    def _tolerances(self, weights, albedo):
        """Per light and point, the optical depth's error allowed: half the pixel's budget, shared by the
        lights, over what a unit of transmittance there is worth (``a 4 pi p E``; its error changes the
        pixel by at most that times the point's weight along the ray, which sums to the pixel's alpha
        <= 1)."""
        share = 0.5 * self.tolerance / max(len(weights), 1)
        a = np.reshape(albedo, -1)
        return [share / np.maximum(a * w.max(axis=1), 1e-300) for w in weights]

    # --- transmittance ----------------------------------------------------------------------

    def transmittance(self, points, toward, reach, tolerance=None) -> np.ndarray:
        """``exp(-tau)`` along ``points + t toward`` for ``t`` in ``[0, reach]``."""
        if self.pieces is None:
            return np.exp(-self._marched(points, toward, reach))
        return np.exp(-self._converged(points, toward, reach, tolerance))

    def _marched(self, points, toward, reach) -> np.ndarray:
        """Optical depth by segments of ``step`` from each point, the last one shortened, each sampled at
        its midpoint (the conventions' segments, on the shadow ray)."""
        d = self.step
        count = np.ceil(reach / d).astype(np.int64)
        tau = np.zeros(len(points))
        order = np.argsort(count)  # sorted by length, so a batch's last row is its widest
        n_sorted = np.maximum(count[order], 1)
        start = 0
        while start < len(order):
            cost = (np.arange(1, len(order) - start + 1)) * n_sorted[start:]
            end = start + max(1, int(np.searchsorted(cost, SAMPLES_PER_BATCH, side="right")))
            rows = order[start:end]
            k = np.arange(int(n_sorted[end - 1]))[None, :]
            a = k * d
            b = np.minimum((k + 1) * d, reach[rows, None])
            valid = b > a
            t = 0.5 * (a + b)
            pts = points[rows, None, :] + t[..., None] * toward[rows, None, :]
            sigma = np.zeros(valid.shape)
            sigma[valid] = self.extinction(pts[valid], None)
            self.stats["shadow_evaluations"] += int(valid.sum())
            tau[rows] = np.sum(np.where(valid, sigma * (b - a), 0.0), axis=1)
            start = end
        return tau

    def _converged(self, points, toward, reach, tolerance) -> np.ndarray:
        """Optical depth between the field's knots by Gauss-Legendre, pieces bisected until the estimate
        changes by at most ``tolerance`` (per point) in proportion to each piece's share of the reach."""
        ray, a, b, cell = self.pieces(points, toward, np.zeros(len(points)), reach)
        tau = np.zeros(len(points))
        share = tolerance[ray] / np.maximum(reach[ray], self.min_distance)  # a piece lies within its reach
        coarse = self._gauss(points, toward, ray, a, b, cell)
        for round_ in range(MAX_ROUNDS + 1):
            if not len(ray):
                break
            m = 0.5 * (a + b)
            left = self._gauss(points, toward, ray, a, m, cell)
            right = self._gauss(points, toward, ray, m, b, cell)
            fine = left + right
            done = (np.abs(fine - coarse) <= share * (b - a)) | (round_ == MAX_ROUNDS)
            np.add.at(tau, ray[done], fine[done])
            keep = ~done
            ray, a, b, m, cell, share = ray[keep], a[keep], b[keep], m[keep], cell[keep], share[keep]
            ray, cell, share = (np.concatenate([x, x]) for x in (ray, cell, share))
            a, b = np.concatenate([a, m]), np.concatenate([m, b])
            coarse = np.concatenate([left[keep], right[keep]])
        return tau

    def _gauss(self, points, toward, ray, a, b, cell) -> np.ndarray:
        half = 0.5 * (b - a)
        t = a[:, None] + half[:, None] * (self.x[None, :] + 1.0)
        pts = points[ray, None, :] + t[..., None] * toward[ray, None, :]
        cells = np.repeat(cell, len(self.x))
        sigma = self.extinction(pts.reshape(-1, 3), cells).reshape(len(ray), len(self.x))
        self.stats["shadow_evaluations"] += sigma.size
        return half * (sigma @ self.w)


def light_volume_dims(lo, hi, size: int) -> tuple[int, int, int]:
    """Nodes per axis ``(nx, ny, nz)`` of a light volume over the box ``[lo, hi]``: ``size`` along its
    longest axis, the others in proportion (at least 2 each)."""
    extent = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
    longest = max(float(extent.max()), 1e-300)
    return tuple(int(max(2, round(1 + (size - 1) * e / longest))) for e in extent)


def light_volume_nodes(lo, hi, size: int):
    """The light volume's nodes ``(nz * ny * nx, 3)`` (x fastest) spanning the box, and its dims (x, y, z)."""
    dims = light_volume_dims(lo, hi, size)
    axes = [np.linspace(a, b, n) for a, b, n in zip(lo, hi, dims)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1), dims


def trilinear(grid: np.ndarray, lo, hi, points: np.ndarray) -> np.ndarray:
    """``grid[z, y, x]`` (nodes spanning ``[lo, hi]``) interpolated trilinearly at points, clamped to the box."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    n = np.array(grid.shape[::-1])
    u = np.clip((points - lo) / np.where(hi > lo, hi - lo, 1.0) * (n - 1), 0.0, n - 1)
    i0 = np.minimum(np.floor(u).astype(np.int64), np.maximum(n - 2, 0))
    f = u - i0
    out = np.zeros(len(points))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = (np.where(dx, f[:, 0], 1 - f[:, 0]) * np.where(dy, f[:, 1], 1 - f[:, 1])
                     * np.where(dz, f[:, 2], 1 - f[:, 2]))
                idx = np.minimum(i0 + [dx, dy, dz], n - 1)
                out += w * grid[idx[:, 2], idx[:, 1], idx[:, 0]]
    return out


def bilinear(buffers: np.ndarray, index: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``buffers[index]`` (each ``(ny, nx)``) at ``uv`` in [0, 1]^2, bilinear between pixel centres,
    clamped to the edge pixels (as a GL texture with clamp-to-edge)."""
    ny, nx = buffers.shape[1:]
    x = np.clip(uv[:, 0] * nx - 0.5, 0.0, nx - 1)
    y = np.clip(uv[:, 1] * ny - 0.5, 0.0, ny - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), nx - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), ny - 2)
    fx, fy = x - x0, y - y0
    b = buffers
    return ((1 - fy) * ((1 - fx) * b[index, y0, x0] + fx * b[index, y0, x0 + 1])
            + fy * ((1 - fx) * b[index, y0 + 1, x0] + fx * b[index, y0 + 1, x0 + 1]))
