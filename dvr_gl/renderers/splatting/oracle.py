"""The same-slabs reference of ``splatting``: float64 on the CPU, sharing no shader code.

What the renderer computes, from the model's side:

* image-aligned sheets: along each pixel's ray, the slabs' parts inside the box (from the near
  plane); on each part the integral of the field (:class:`~dvr_gl.fields.reconstruction.SampledField`,
  the Gaussian: post-classified the scalar, pre-classified the voxels' ``(sigma c, sigma)``) by
  Gauss-Legendre quadrature on pieces of at most half a voxel; post-classified, the mean over
  the part is classified through the transfer-function table and the part is one segment of that
  length; pre-classified, the part's optical depth and colour are its integrals; composited
  front to back.
* axis-aligned sheets (Westover): per voxel plane across the stack axis (border copies merged into
  the border planes), the sum of its kernels' closed-form integrals along the ray in the box;
  post-classified, that sum over the ray's length per plane is the value classified, and the
  segment is the ray's part within half a spacing of the plane in the box; pre-classified, the
  sums are the plane's optical depth and emission; planes in order of their distance from the eye.
* ``sheet_buffer = none``: every splat alone, back to front in the renderer's order (view depth
  of the centre), its integral along the ray in the box from the kernel's closed-form footprint
  (:class:`~dvr_gl.fields.reconstruction.GaussianKernel`: a 2D Gaussian times the share of the
  chord, by ``erf``).
* the average: the field's integral over the chord, divided by the chord, classified exactly.

* kernels widened by the screen low-pass (``renderer.screen_low_pass``, :mod:`.low_pass`): no field of
  one kernel, since each kernel's width follows its depth, so every integral above is the sum of the
  widened kernels' closed forms (:func:`pair_integrals` with their metric) over the same parts.

Its difference from the renderer is float32 and the footprint tables' interpolation, bounded in
``tests/test_splatting.py``.  It always takes each pixel's own ray (``renderer.footprint =
"exact"``): EWA's affine footprints differ from it by design, by the amounts measured there.
"""

from __future__ import annotations

import math

import numpy as np

from ...clipping import ClipRegion
from ...fields import filter_parameters, gradient_epsilon, reconstruct, sph
from ...fields.particles import ParticleSet, SPHInterpolant
from ...fields.ragged import ranks
from ...fields.reconstruction import GaussianKernel, _erf
from ...geometry import over_surface, surface_rgba
from ...rays import RayBatch
from ...shading import blinn_phong, normals_from_gradient
from ...transfer_function import projected_rgba, segment_opacity, xray_rgba
from . import low_pass
from .particles import SUBPIXEL_RADIUS, ParticleSplats
from .sheets import kernel_reach, pixel_rectangles, pre_classified, shaded_sheets, slab_bounds
from .splats import Splats

NODES = 8            # Gauss-Legendre nodes per piece
PIECE_VOXELS = 0.5   # the longest piece, voxels of the smallest spacing
CHUNK = 20000        # (ray, part) pairs or splats per batch


def oracle(scene) -> np.ndarray:
    """The image ``(H, W, 4)`` float64 that ``splatting`` must match (see the module doc)."""
    r, img = scene.renderer, scene.image
    rays = RayBatch.for_camera(scene.camera, img.width, img.height, scene.field.bounds,
                               clip=ClipRegion.of(r))  # the parts kept by clipping
    surface = surface_rgba(scene, rays)  # meshes end the parts, and show behind
    sub = SubPixel(scene, rays) if scene.field.kind == "particles" else None
    if r.compositing == "average":
        out = _average(scene, rays, sub)
    elif r.compositing == "xray" and pre_classified(scene):
        out = _xray_pre(scene, rays, sub)
    elif r.sheet_buffer == "none":
        out = _splats_alone(scene, rays)
    elif r.sheet_buffer == "axis_aligned":
        out = _axis_sheets(scene, rays)
    else:
        out = _sheets(scene, rays, sub)
    return over_surface(out, surface).reshape(img.height, img.width, 4)


def _pieces(field, rays, ray, a, b, spacing):
    """``(owner, lo, step)``: ``[a, b]`` of each ray cut into pieces of at most ``PIECE_VOXELS`` voxels,
    and for particles also at the knots of their kernels (where the kernels' pieces meet)."""
    pieces = np.maximum(np.ceil((b - a) / (PIECE_VOXELS * spacing)), 1).astype(np.int64)
    owner = np.repeat(np.arange(len(a)), pieces)
    k = ranks(pieces)
    step = ((b - a) / pieces)[owner]
    lo = a[owner] + k * step
    if not isinstance(field, SPHInterpolant) and getattr(field, "kind", None) != "cubic_bspline":
        return owner, lo, step
    # particles: the supports' ends; the cubic B-spline: the voxel planes, between which it is a polynomial
    k_ray, k_t = field.knots(rays.origins[ray], rays.directions[ray], a, b)
    owner = np.concatenate([owner, k_ray, np.arange(len(a))])
    cut = np.concatenate([lo, k_t, b])
    order = np.lexsort((cut, owner))
    owner, cut = owner[order], cut[order]
    same = owner[1:] == owner[:-1]
    return owner[:-1][same], cut[:-1][same], (cut[1:] - cut[:-1])[same]


def _integrals(field, rays, ray, a, b, spacing) -> np.ndarray:
    """Integrals of ``field`` along rays ``ray`` over ``[a, b]`` ``(N,)`` or ``(N, C)``."""
    x, w = np.polynomial.legendre.leggauss(NODES)
    owner, lo, step = _pieces(field, rays, ray, a, b, spacing)
    t = lo[:, None] + 0.5 * step[:, None] * (x[None, :] + 1.0)
    points = rays.origins[ray[owner], None, :] + t[..., None] * rays.directions[ray[owner], None, :]
    values = field.sample(points.reshape(-1, 3))
    values = values.reshape(len(owner), NODES, -1)
    per_piece = 0.5 * step[:, None] * np.einsum("n,pnc->pc", w, values)
    total = np.zeros((len(a), per_piece.shape[1]))
    np.add.at(total, owner, per_piece)
    return total


def _sheets(scene, rays, sub=None) -> np.ndarray:
    r, tf, cam = scene.renderer, scene.transfer_function, scene.camera
    forward, _, _ = cam.basis()
    eye = np.asarray(cam.eye, float)
    bounds = slab_bounds(scene, eye, forward)
    pre = pre_classified(scene)
    if pre:
        field = _classified_field(scene, sub)
    else:
        field = _field(scene, sub)
        table = tf.tabulate(r.lut_size)
    carried = None if sub is None else sub.carried(scene, pre)
    along = rays.directions @ forward  # ray length per unit of depth: 1 / along
    if shaded_sheets(scene):
        return _shaded_sheets(scene, rays, field, table, bounds, along, sub)
    xray = r.compositing == "xray"
    sums = np.zeros((len(rays), 4))
    out = np.zeros((len(rays), 4))
    transmittance = np.ones(len(rays))
    for k, rows, extent, integral in _slab_parts(scene, rays, field, bounds, along, sub, carried):  # front to back
        if pre:  # the part's optical depth and emission: its colour and opacity as the X-ray's
            premult = xray_rgba(integral[:, :3], integral[:, 3])
        else:
            colour, sigma = table.lookup(integral[:, 0] / extent)
            if xray:  # sums of the parts' optical depth and emission
                sums[rows, :3] += colour * (sigma * extent)[:, None]
                sums[rows, 3] += sigma * extent
                continue
            alpha = segment_opacity(sigma, extent)
            premult = np.concatenate([colour * alpha[:, None], alpha[:, None]], axis=1)
        out[rows] += transmittance[rows, None] * premult
        transmittance[rows] *= 1.0 - premult[:, 3]
    return xray_rgba(sums[:, :3], sums[:, 3]) if xray else out


def _slab_parts(scene, rays, field, bounds, along, sub, carried):
    """``(slab, rays, extents, integrals (N, C))`` for each slab front to back, in chunks of rays whose part
    of the slab is not empty: the field's integral over each part, and particles smaller than a pixel
    (``sub``, carrying ``carried``); kernels widened by the screen low-pass: :func:`_widened_slab_parts`."""
    if scene.field.kind == "grid" and low_pass.enabled(scene):
        yield from _widened_slab_parts(scene, rays, bounds, along)
        return
    for k in range(len(bounds) - 1):
        a = np.maximum(rays.t0, bounds[k] / along)
        b = np.minimum(rays.t1, bounds[k + 1] / along)
        ray = np.nonzero(b > a)[0]
        extra = None if sub is None else sub.sums(carried, len(rays), (bounds[k], bounds[k + 1]))
        for i in range(0, len(ray), CHUNK):
            rows = ray[i:i + CHUNK]
            integral = _integrals(field, rays, rows, a[rows], b[rows],
                                  scene.field.sample_spacing).reshape(len(rows), -1)
            if extra is not None:
                integral = integral + extra[rows]
            yield k, rows, b[rows] - a[rows], integral


class _WidenedKernels:
    """The grid's splats with kernels widened by the screen low-pass (:mod:`.low_pass`): no field of one
    kernel, since each kernel's width follows its depth, so its integrals are sums over the kernels of
    their closed forms (:func:`pair_integrals`) along each ray."""

    def __init__(self, scene):
        vol, tf = scene.volume, scene.transfer_function
        self.scene = scene
        pre = pre_classified(scene)
        self.splats = Splats(vol, kernel_reach(scene), np.zeros(3), tf.classify_voxels(vol.data, True) if pre else None)
        self.values = self.splats.optics.astype(np.float64) if pre else self.splats.values[:, None]
        self.kernel = GaussianKernel(scene.renderer.kernel_width, scene.renderer.kernel_radius)
        self.metric = low_pass.metric(scene, self.splats.positions)

    def integrals(self, rays, t0, t1, idx=None) -> np.ndarray:
        """``(rays, C)``: the kernels' (``idx``, default all) integrals along each ray over ``[t0, t1]``."""
        idx = np.arange(len(self.splats)) if idx is None else idx
        splat, pixel, integral = _all_pair_integrals(self.scene, rays, self.splats, idx, self.kernel, t0, t1,
                                                     self.metric)
        return np.stack([np.bincount(pixel, integral * self.values[splat, c], minlength=len(rays))
                         for c in range(self.values.shape[1])], axis=1)


def _widened_slab_parts(scene, rays, bounds, along):
    """As :func:`_slab_parts`, of kernels widened by the screen low-pass: per slab, the kernels that reach
    into it (their depth reach is the kernel's, :mod:`.low_pass`)."""
    from .sheets import kernel_depth_reach

    kernels = _WidenedKernels(scene)
    forward = scene.camera.basis()[0]
    depth = kernels.splats.depths(np.asarray(scene.camera.eye, float), forward)
    reach = kernel_depth_reach(scene, forward)
    for k in range(len(bounds) - 1):
        a = np.maximum(rays.t0, bounds[k] / along)
        b = np.minimum(rays.t1, bounds[k + 1] / along)
        rows = np.nonzero(b > a)[0]
        idx = np.nonzero((depth + reach >= bounds[k]) & (depth - reach <= bounds[k + 1]))[0]
        if len(rows) and len(idx):
            yield k, rows, (b - a)[rows], kernels.integrals(rays, a, b, idx)[rows]


def _shaded_sheets(scene, rays, field, table, bounds, along, sub) -> np.ndarray:
    """Post-classified slabs shaded by the gradient of the slab means in screen space: across, from the
    neighbouring pixels' means (the edge repeated beyond the image) at the pixel's size at the slab's
    middle depth; along the view, from the slabs in front and behind (zero beyond the first and the
    last); a mean is zero where a part is empty."""
    r, cam, img = scene.renderer, scene.camera, scene.image
    w, h = img.width, img.height
    forward, right, up = cam.basis()
    count = len(bounds) - 1
    means = np.zeros((count + 2, len(rays)))  # with an empty slab before the first and after the last
    extents = np.zeros((count, len(rays)))
    carried = None if sub is None else sub.carried(scene, False)
    for k, rows, extent, integral in _slab_parts(scene, rays, field, bounds, along, sub, carried):
        extents[k, rows] = extent
        means[k + 1, rows] = integral[:, 0] / extent
    hx, _ = cam.half_extent(w / h)
    width = bounds[1] - bounds[0]
    col = np.arange(len(rays)) % w
    row = np.arange(len(rays)) // w
    def at(k, dr, dc):  # the means of slab k at the pixels dr rows down and dc columns right, clamped
        return means[k + 1][np.clip(row + dr, 0, h - 1) * w + np.clip(col + dc, 0, w - 1)]
    epsilon = gradient_epsilon(scene.field)
    out = np.zeros((len(rays), 4))
    transmittance = np.ones(len(rays))
    for k in range(count):
        pixel = 2.0 * hx / w * (1.0 if cam.projection == "orthographic" else 0.5 * (bounds[k] + bounds[k + 1]))
        gx = (at(k, 0, 1) - at(k, 0, -1)) / (2.0 * pixel)
        gy = (at(k, -1, 0) - at(k, 1, 0)) / (2.0 * pixel)  # rows run down, up runs up
        gz = (means[k + 2] - means[k]) / (2.0 * width)
        gradient = gx[:, None] * right + gy[:, None] * up + gz[:, None] * forward
        colour, sigma = table.lookup(means[k + 1])
        colour = blinn_phong(colour, normals_from_gradient(gradient, epsilon), rays.directions, r.shading)
        alpha = np.where(extents[k] > 0, segment_opacity(sigma, extents[k]), 0.0)
        out[:, :3] += (transmittance * alpha)[:, None] * colour
        out[:, 3] += transmittance * alpha
        transmittance *= 1.0 - alpha
    return out


def _field(scene, sub=None):
    """The scalar field the rays integrate: the scene's, or (particles) its particles' but those smaller
    than a pixel (:class:`SubPixel`)."""
    return reconstruct(scene.field if sub is None else sub.regular, scene.renderer)


def _classified_field(scene, sub=None):
    """The voxels (or particles but those smaller than a pixel) classified (``(sigma c, sigma)``, associated)
    and reconstructed by the kernel."""
    field, tf = scene.field if sub is None else sub.regular, scene.transfer_function
    return field.reconstruct_values(tf.classify_voxels(field.samples, True), scene.renderer.filter,
                                    **filter_parameters(scene.renderer))


class SubPixel:
    """Particles whose support's radius is under ``SUBPIXEL_RADIUS`` pixels at their depth (in front of
    the near plane), as the renderer splats them: the footprint's mean over each pixel's square at the
    particle's depth (:func:`dvr_gl.fields.sph.quadrant`, float64), over the cosine of the angle of the
    ray through the particle to the view axis; in a slab, times the particle's mass between the slab's
    planes (:func:`dvr_gl.fields.sph.slab_mass`).  ``regular``: the other particles (these with no mass)."""

    def __init__(self, scene, rays):
        p = scene.field
        self.mask = subpixel_mask(scene, p.positions, p.smoothing_lengths)
        self.regular = ParticleSet(p.positions, p.smoothing_lengths, np.where(self.mask, 0.0, p.masses),
                                   p.densities, p.values, name=p.name, array=p.array)
        index = np.nonzero(self.mask)[0]
        j, self.pixel, self.base = subpixel_pairs(scene, rays, p.positions[index], p.smoothing_lengths[index],
                                                  p.weights[index])
        self.index = index[j]
        forward = scene.camera.basis()[0]
        self.depth = (p.positions[self.index] - np.asarray(scene.camera.eye, float)) @ forward
        self.h = p.smoothing_lengths[self.index]

    def carried(self, scene, pre: bool) -> np.ndarray:
        """What each particle carries ``(N, C)``: its quantity, or classified ``(sigma c, sigma)``."""
        p = scene.field
        return scene.transfer_function.classify_voxels(p.values, True) if pre else p.values[:, None]

    def sums(self, carried: np.ndarray, rays: int, slab=None) -> np.ndarray:
        """``(rays, C)``: the particles' integrals along each pixel's ray (in the slab between view depths
        ``slab``)."""
        weight = self.base
        if slab is not None:
            weight = weight * (sph.slab_mass((slab[1] - self.depth) / self.h)
                               - sph.slab_mass((slab[0] - self.depth) / self.h))
        values = carried[self.index]
        return np.stack([np.bincount(self.pixel, weight * values[:, c], minlength=rays)
                         for c in range(values.shape[1])], axis=1)


def subpixel_mask(scene, positions: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The renderer's test (``splat.vert``): the support ``2h`` under ``SUBPIXEL_RADIUS`` pixels at the
    particle's depth, and in front of the near plane."""
    cam, img = scene.camera, scene.image
    hx, hy = cam.half_extent(img.width / img.height)
    r = sph.SUPPORT * h
    z = (positions - np.asarray(cam.eye, float)) @ cam.basis()[0]
    pixel = 2.0 * hy / img.height * (1.0 if cam.projection == "orthographic" else np.maximum(z, 0.0))
    return (z - r > cam.near) & (r < SUBPIXEL_RADIUS * pixel)


def subpixel_pairs(scene, rays, positions, h, weights):
    """``(particle, pixel, integral)`` for particles smaller than a pixel: each pixel whose square (at the
    particle's depth) meets the support's square, and the particle's weight times its footprint's mean
    over that square, per unit of the pixel ray's length along the ray through the particle."""
    cam, img = scene.camera, scene.image
    w, hgt = img.width, img.height
    forward, right, up = cam.basis()
    hx, hy = cam.half_extent(w / hgt)
    rel = positions - np.asarray(cam.eye, float)
    z = rel @ forward
    scale = np.ones(len(z)) if cam.projection == "orthographic" else z
    npw = np.stack([1.0 / (hx * scale), 1.0 / (hy * scale)], axis=1)        # NDC per world unit
    centre = np.stack([rel @ right, rel @ up], axis=1) * npw                  # NDC
    reach = (sph.SUPPORT * h)[:, None] * npw
    size = np.array([w, hgt])
    first = np.clip(np.floor((centre - reach + 1.0) * 0.5 * size), 0, size - 1).astype(np.int64)
    last = np.clip(np.floor((centre + reach + 1.0) * 0.5 * size), 0, size - 1).astype(np.int64)
    span = last - first + 1
    count = span[:, 0] * span[:, 1]
    j = np.repeat(np.arange(len(positions)), count)
    k = ranks(count)
    col = first[j, 0] + k % span[j, 0]
    row_up = first[j, 1] + k // span[j, 0]                                     # from the bottom
    edges = [np.stack([col + a, row_up + b], axis=1) / size * 2.0 - 1.0 for a, b in ((0, 0), (1, 1))]
    lo, hi = ((e - centre[j]) / npw[j] / h[j, None] for e in edges)          # smoothing lengths
    share = (sph.quadrant(hi[:, 0], hi[:, 1]) - sph.quadrant(lo[:, 0], hi[:, 1])
             - sph.quadrant(hi[:, 0], lo[:, 1]) + sph.quadrant(lo[:, 0], lo[:, 1]))
    area = np.prod((edges[1] - edges[0]) / npw[j], axis=1)
    secant = 1.0 if cam.projection == "orthographic" else np.linalg.norm(rel[j], axis=1) / z[j]
    pixel = (hgt - 1 - row_up) * w + col
    base = weights[j] * share / area * secant
    keep = base != 0
    return j[keep], pixel[keep], base[keep]


def _xray_pre(scene, rays, sub=None) -> np.ndarray:
    """The radiograph of the pre-classified field: its integrals of ``(sigma c, sigma)`` over the chord."""
    out = np.zeros((len(rays), 4))
    hit = np.nonzero(rays.t1 > rays.t0)[0]
    integral = _chord_integrals(scene, rays, hit, _classified_field, sub)
    if sub is not None:
        integral = integral + sub.sums(sub.carried(scene, True), len(rays))[hit]
    out[hit] = xray_rgba(integral[:, :3], integral[:, 3])
    return out


def _chord_integrals(scene, rays, hit, field_of, sub=None) -> np.ndarray:
    """The integrals over the rays ``hit``'s chords of the field ``field_of(scene, sub)`` (the scalar or
    the classified voxels), or of the kernels widened by the screen low-pass."""
    if scene.field.kind == "grid" and low_pass.enabled(scene):
        return _WidenedKernels(scene).integrals(rays, rays.t0, rays.t1)[hit]
    return _integrals(field_of(scene, sub), rays, hit, rays.t0[hit], rays.t1[hit], scene.field.sample_spacing)


def _average(scene, rays, sub=None) -> np.ndarray:
    out = np.zeros((len(rays), 4))
    hit = np.nonzero(rays.t1 > rays.t0)[0]
    integral = _chord_integrals(scene, rays, hit, _field, sub)
    if sub is not None:
        integral = integral.reshape(len(hit), -1) + sub.sums(sub.carried(scene, False), len(rays))[hit]
    out[hit] = projected_rgba(scene.transfer_function, integral[:, 0] / (rays.t1[hit] - rays.t0[hit]))
    return out


def pair_integrals(kernel: GaussianKernel, spacing, centres, origins, directions, t0, t1, metric=None) -> np.ndarray:
    """Each kernel's integral along its ray over ``[t0, t1]`` (world units), for pairs of kernels
    (``centres`` ``(N, 3)``) and rays (``origins``, ``directions`` ``(N, 3)``), in closed form: the
    footprint at the ray's nearest approach times the share of the chord, by ``erf``.  ``metric``: the
    kernels widened by the screen low-pass, ``(G (N, 3, 3), sqrt(det G) (N,))`` (:func:`.low_pass.metric`):
    distances in voxels measured by ``G``, the density times ``sqrt(det G)``."""
    inv = 1.0 / np.asarray(spacing, float)
    ud = directions * inv                                  # voxels per world unit
    uo = (origins - centres) * inv
    g = (lambda v: v) if metric is None else (lambda v: np.einsum("nij,nj->ni", metric[0], v))
    gd = g(ud)
    a = (ud * gd).sum(axis=1)
    tc = -(uo * gd).sum(axis=1) / a
    nearest = uo + tc[:, None] * ud
    rho2 = (nearest * g(nearest)).sum(axis=1)
    r2 = kernel.radius ** 2
    inside = rho2 < r2
    half = np.sqrt(np.maximum(r2 - rho2, 0.0)) / np.sqrt(a)  # the chord's half-length, world units
    lo = np.maximum(tc - half, t0)
    hi = np.minimum(tc + half, t1)
    live = inside & (hi > lo)
    out = np.zeros(len(a))
    if not live.any():
        return out
    a, tc, half, lo, hi, rho2 = (x[live] for x in (a, tc, half, lo, hi, rho2))
    scale = np.sqrt(a) / (kernel.sigma * math.sqrt(2.0))   # sigma in world units along the ray
    share = 0.5 * (_erf((hi - tc) * scale) - _erf((lo - tc) * scale))
    whole = _erf(half * scale)
    full = kernel.footprint(rho2) / np.sqrt(a)
    if metric is not None:
        full = full * metric[1][live]
    with np.errstate(invalid="ignore", divide="ignore"):
        out[live] = np.where(whole > 0, full * share / whole, 0.0)
    return out


def _pairs(scene, positions: np.ndarray, radius_world):
    """``(splat, pixel)`` pairs whose pixel centre lies in the screen rectangle of the splat's bounding
    sphere (:func:`.sheets.pixel_rectangles`)."""
    w = scene.image.width
    i0, i1, j0, j1 = pixel_rectangles(scene, positions, radius_world)
    cols, rows = np.maximum(i1 - i0 + 1, 0), np.maximum(j1 - j0 + 1, 0)
    count = cols * rows
    splat = np.repeat(np.arange(len(positions)), count)
    k = ranks(count)
    c = cols[splat]
    pixel = (j0[splat] + k // np.maximum(c, 1)) * w + i0[splat] + k % np.maximum(c, 1)
    return splat, pixel


def bspline_pair_integrals(spacing, centres, origins, directions, t0, t1) -> np.ndarray:
    """Each cubic B-spline kernel's integral along its ray over ``[t0, t1]``, for pairs as
    :func:`pair_integrals`: exact, by 5-point Gauss-Legendre on the pieces between the places where a
    coordinate crosses a whole voxel (the kernel is a polynomial of degree 9 there)."""
    inv = 1.0 / np.asarray(spacing, float)
    ud = directions * inv
    uo = (origins - centres) * inv
    moving = np.abs(ud) > 1e-12
    safe = np.where(moving, ud, 1.0)
    ta, tb = (-2.0 - uo) / safe, (2.0 - uo) / safe
    inside = np.where(moving, True, np.abs(uo) < 2.0).all(axis=1)
    enter = np.maximum(np.where(moving, np.minimum(ta, tb), -np.inf).max(axis=1), t0)
    leave = np.minimum(np.where(moving, np.maximum(ta, tb), np.inf).min(axis=1), t1)
    live = inside & (leave > enter)
    cuts = [enter, leave]
    for k in (-1.0, 0.0, 1.0):
        t = (k - uo) / safe
        for axis in range(3):
            cuts.append(np.where(moving[:, axis], np.clip(t[:, axis], enter, leave), enter))
    cuts = np.sort(np.stack(cuts, axis=1), axis=1)            # (N, 11)
    x, w = np.polynomial.legendre.leggauss(5)
    half = 0.5 * np.diff(cuts, axis=1)                        # (N, 10)
    mid = 0.5 * (cuts[:, 1:] + cuts[:, :-1])
    t = mid[..., None] + half[..., None] * x                  # (N, 10, 5)
    u = uo[:, None, None, :] + t[..., None] * ud[:, None, None, :]
    value = np.prod(_bspline(u), axis=-1)
    return np.where(live, np.einsum("npq,q,np->n", value, w, half), 0.0)


def _bspline(u: np.ndarray) -> np.ndarray:
    a = np.abs(u)
    return np.where(a < 1.0, 2.0 / 3.0 - a * a + 0.5 * a ** 3, np.where(a < 2.0, (2.0 - np.minimum(a, 2.0)) ** 3 / 6.0,
                                                                          0.0))


def _all_pair_integrals(scene, rays, splats, idx, kernel, t0=None, t1=None, metric=None):
    """``(splat, pixel, integral)`` for the splats ``idx`` and the pixels their kernels may reach
    (``kernel``: a :class:`GaussianKernel`, or None for the cubic B-spline), over each ray's part in the
    box or ``[t0, t1]`` (per pixel); Gaussians widened by the screen low-pass through ``metric`` (every
    splat's, :func:`.low_pass.metric`; found here if not given)."""
    vol = scene.volume
    t0 = rays.t0 if t0 is None else t0
    t1 = rays.t1 if t1 is None else t1
    s_local, pixel = _pairs(scene, splats.positions[idx], splats.bounding_radii())
    if metric is None and kernel is not None and low_pass.enabled(scene):
        metric = low_pass.metric(scene, splats.positions)
    integral = np.zeros(len(pixel))
    for i in range(0, len(pixel), CHUNK * 10):
        sl = slice(i, i + CHUNK * 10)
        pix, which = pixel[sl], idx[s_local[sl]]
        args = (vol.spacing, splats.positions[which], rays.origins[pix], rays.directions[pix], t0[pix], t1[pix])
        if kernel is None:
            integral[sl] = bspline_pair_integrals(*args)
        else:
            integral[sl] = pair_integrals(kernel, *args, metric=None if metric is None else
                                          (metric[0][which], metric[1][which]))
    keep = integral > 0
    return idx[s_local[keep]], pixel[keep], integral[keep]


def _particle_pairs(scene, rays, splats, which):
    """``(splat, pixel, integral)`` of the particle splats ``which`` (a mask): each particle's kernel along
    the pixel's ray over its part in the field's box (:func:`dvr_gl.fields.sph.line_integral`)."""
    chosen = np.nonzero(which)[0]
    s_local, pixel = _pairs(scene, splats.positions[chosen], sph.SUPPORT * splats.h[chosen])
    s_local = chosen[s_local]
    c, h = splats.positions[s_local], splats.h[s_local]
    o, d, t0, t1 = rays.origins[pixel], rays.directions[pixel], rays.t0[pixel], rays.t1[pixel]
    a = (d * d).sum(axis=1)
    tc = ((c - o) * d).sum(axis=1) / a
    length = np.sqrt(a)
    rho = np.linalg.norm(o + tc[:, None] * d - c, axis=1)
    z0, z1 = (t0 - tc) * length / h, (t1 - tc) * length / h  # smoothing lengths from the nearest approach
    integral = sph.line_integral(rho / h, z0, z1) / (math.pi * h * h) / length * splats.weights[s_local]
    keep = integral > 0
    return s_local[keep], pixel[keep], integral[keep]


def _splats_alone(scene, rays) -> np.ndarray:
    """Back to front, each splat over what lies behind it: front to back here, the same sum."""
    field, cam, r, tf = scene.field, scene.camera, scene.renderer, scene.transfer_function
    grid = field.kind == "grid"
    if grid:
        splats = Splats(field, kernel_reach(scene), np.zeros(3), tf.classify_voxels(field.data, True))
    else:
        splats = ParticleSplats(field, np.zeros(3), tf.classify_voxels(field.samples, True))
    forward, _, _ = cam.basis()
    depth = splats.depths(np.asarray(cam.eye, float), forward)
    rank = np.empty(len(splats), np.int64)
    rank[np.argsort(-depth, kind="stable")[::-1]] = np.arange(len(splats))  # 0: the front splat
    if grid:
        kernel = GaussianKernel(r.kernel_width, r.kernel_radius) if r.filter == "gaussian" else None
        splat, pixel, integral = _all_pair_integrals(scene, rays, splats, np.arange(len(splats)), kernel)
    else:
        small = subpixel_mask(scene, splats.positions, splats.h)
        splat, pixel, integral = _particle_pairs(scene, rays, splats, ~small)
        index = np.nonzero(small)[0]
        j, sub_pixel, base = subpixel_pairs(scene, rays, splats.positions[index], splats.h[index],
                                            splats.weights[index])
        splat, pixel, integral = (np.concatenate(x) for x in ((splat, index[j]), (pixel, sub_pixel),
                                                                (integral, base)))
    order = np.lexsort((rank[splat], pixel))
    splat, pixel, integral = splat[order], pixel[order], integral[order]
    optics = splats.optics[splat].astype(np.float64)
    tau = optics[:, 3] * integral
    alpha = -np.expm1(-tau)
    colour = optics[:, :3] / optics[:, 3:4]
    total = np.cumsum(tau)
    start = np.r_[0, np.nonzero(np.diff(pixel))[0] + 1]
    first = np.repeat(start, np.diff(np.r_[start, len(pixel)]))
    before = total - tau - (total[first] - tau[first])     # optical depth of the splats in front
    out = np.zeros((len(rays), 4))
    weight = np.exp(-before) * alpha
    for c in range(3):
        out[:, c] = np.bincount(pixel, weight * colour[:, c], minlength=len(rays))
    out[:, 3] = 1.0 - np.exp(-np.bincount(pixel, tau, minlength=len(rays)))
    return out


def _axis_sheets(scene, rays) -> np.ndarray:
    from ...reference.plans import stack_axis
    from .sheets import axis_order, sheet_axis_planes

    vol, cam, r, tf = scene.volume, scene.camera, scene.renderer, scene.transfer_function
    pre = pre_classified(scene)
    splats = Splats(vol, kernel_reach(scene), np.zeros(3), tf.classify_voxels(vol.data, True) if pre else None)
    axis = stack_axis(cam)
    planes = sheet_axis_planes(scene, splats.index[:, axis])
    unique = np.unique(planes)
    ordered = unique[np.lexsort((unique, axis_order(scene, unique)))]
    slot = np.empty(unique.max() + 1, np.int64)
    slot[ordered] = np.arange(len(ordered))                  # the planes' compositing order
    kernel = GaussianKernel(r.kernel_width, r.kernel_radius) if r.filter == "gaussian" else None
    splat, pixel, integral = _all_pair_integrals(scene, rays, splats, np.arange(len(splats)), kernel)
    key = slot[planes[splat]] * len(rays) + pixel
    size = len(ordered) * len(rays)
    values = splats.optics[splat].astype(np.float64) if pre else splats.values[splat][:, None]
    sheets = np.stack([np.bincount(key, integral * values[:, c], minlength=size) for c in range(values.shape[1])],
                      axis=1).reshape(len(ordered), len(rays), -1)
    h = vol.spacing[axis]
    o, d = rays.origins[:, axis], rays.directions[:, axis]
    per_plane = h / np.maximum(np.abs(d), 1e-6)
    table = None if pre else tf.tabulate(r.lut_size)
    xray = r.compositing == "xray"
    sums = np.zeros((len(rays), 4))
    out = np.zeros((len(rays), 4))
    transmittance = np.ones(len(rays))
    for n, k in enumerate(ordered):
        position = vol.origin[axis] + k * h
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (position - 0.5 * h - o) / d, (position + 0.5 * h - o) / d
        lo = np.maximum(rays.t0, np.minimum(ta, tb))
        hi = np.minimum(rays.t1, np.maximum(ta, tb))
        extent = np.where(hi > lo, hi - lo, 0.0)
        sheet = sheets[n]
        if pre:  # the plane's optical depth and emission
            premult = xray_rgba(sheet[:, :3], sheet[:, 3])
        else:
            colour, sigma = table.lookup(sheet[:, 0] / per_plane)
            if xray:
                tau = np.where(extent > 0, sigma * extent, 0.0)
                sums[:, :3] += colour * tau[:, None]
                sums[:, 3] += tau
                continue
            alpha = segment_opacity(sigma, extent)
            premult = np.concatenate([colour * alpha[:, None], alpha[:, None]], axis=1)
        premult = np.where(extent[:, None] > 0, premult, 0.0)
        out += transmittance[:, None] * premult
        transmittance *= 1.0 - premult[:, 3]
    return xray_rgba(sums[:, :3], sums[:, 3]) if xray else out
