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

Its difference from the renderer is float32 and the footprint tables' interpolation, bounded in
``tests/test_splatting.py``.
"""

from __future__ import annotations

import math

import numpy as np

from ...fields import reconstruct
from ...fields.reconstruction import GaussianKernel, _erf
from ...rays import RayBatch
from ...transfer_function import segment_opacity
from .renderer import kernel_radius, pre_classified, slab_bounds
from .splats import Splats

NODES = 8            # Gauss-Legendre nodes per piece
PIECE_VOXELS = 0.5   # the longest piece, voxels of the smallest spacing
CHUNK = 20000        # (ray, part) pairs or splats per batch


def reference(scene) -> np.ndarray:
    """The image ``(H, W, 4)`` float64 that ``splatting`` must match (see the module doc)."""
    r, img = scene.renderer, scene.image
    rays = RayBatch.for_camera(scene.camera, img.width, img.height, scene.volume.box)
    if r.compositing == "average":
        out = _average(scene, rays)
    elif r.sheet_buffer == "none":
        out = _splats_alone(scene, rays)
    elif r.sheet_buffer == "axis_aligned":
        out = _axis_sheets(scene, rays)
    else:
        out = _sheets(scene, rays)
    return out.reshape(img.height, img.width, 4)


def _integrals(field, rays, ray, a, b, spacing) -> np.ndarray:
    """Integrals of ``field`` along rays ``ray`` over ``[a, b]`` ``(N,)`` or ``(N, C)``."""
    x, w = np.polynomial.legendre.leggauss(NODES)
    pieces = np.maximum(np.ceil((b - a) / (PIECE_VOXELS * spacing)), 1).astype(np.int64)
    owner = np.repeat(np.arange(len(a)), pieces)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    step = ((b - a) / pieces)[owner]
    lo = a[owner] + k * step
    t = lo[:, None] + 0.5 * step[:, None] * (x[None, :] + 1.0)
    points = rays.origins[ray[owner], None, :] + t[..., None] * rays.directions[ray[owner], None, :]
    values = field.sample(points.reshape(-1, 3))
    values = values.reshape(len(owner), NODES, -1)
    per_piece = 0.5 * step[:, None] * np.einsum("n,pnc->pc", w, values)
    total = np.zeros((len(a), per_piece.shape[1]))
    np.add.at(total, owner, per_piece)
    return total


def _sheets(scene, rays) -> np.ndarray:
    r, tf, vol, cam = scene.renderer, scene.transfer_function, scene.volume, scene.camera
    forward, _, _ = cam.basis()
    eye = np.asarray(cam.eye, float)
    bounds = slab_bounds(scene, eye, forward)
    pre = pre_classified(scene)
    if pre:
        field = vol.reconstruct_values(tf.classify_voxels(vol.data, True), "gaussian", kernel_width=r.kernel_width)
    else:
        field = reconstruct(vol, r)
        table = tf.tabulate(r.lut_size)
    along = rays.directions @ forward  # ray length per unit of depth: 1 / along
    out = np.zeros((len(rays), 4))
    transmittance = np.ones(len(rays))
    for k in range(len(bounds) - 1):  # front to back
        a = np.maximum(rays.t0, bounds[k] / along)
        b = np.minimum(rays.t1, bounds[k + 1] / along)
        ray = np.nonzero(b > a)[0]
        for i in range(0, len(ray), CHUNK):
            rows = ray[i:i + CHUNK]
            integral = _integrals(field, rays, rows, a[rows], b[rows], vol.sample_spacing)
            if pre:
                tau = integral[:, 3]
                alpha = -np.expm1(-tau)
                with np.errstate(invalid="ignore", divide="ignore"):
                    colour = np.where(tau[:, None] > 0, integral[:, :3] / tau[:, None], 0.0)
            else:
                extent = b[rows] - a[rows]
                colour, sigma = table.lookup(integral[:, 0] / extent)
                alpha = segment_opacity(sigma, extent)
            out[rows, :3] += transmittance[rows, None] * colour * alpha[:, None]
            out[rows, 3] += transmittance[rows] * alpha
            transmittance[rows] *= 1.0 - alpha
    return out


def _average(scene, rays) -> np.ndarray:
    r, tf, vol = scene.renderer, scene.transfer_function, scene.volume
    field = reconstruct(vol, r)
    out = np.zeros((len(rays), 4))
    hit = np.nonzero(rays.t1 > rays.t0)[0]
    integral = _integrals(field, rays, hit, rays.t0[hit], rays.t1[hit], vol.sample_spacing)[:, 0]
    colour, sigma = tf.evaluate(integral / (rays.t1[hit] - rays.t0[hit]))
    alpha = segment_opacity(sigma, tf.unit_distance)
    out[hit, :3] = colour * alpha[:, None]
    out[hit, 3] = alpha
    return out


def kernel_integrals(kernel: GaussianKernel, spacing, centres, rays, rows) -> np.ndarray:
    """Each kernel's integral ``(splats, rays)`` along rays ``rows`` over their part in the box (world
    units), in closed form: the footprint at the ray's nearest approach times the share of the chord."""
    inv = 1.0 / np.asarray(spacing, float)
    ud = rays.directions[rows] * inv                        # (R, 3) voxels per world unit
    a = (ud * ud).sum(axis=1)
    uo = (rays.origins[rows][None, :, :] - centres[:, None, :]) * inv  # (S, R, 3)
    tc = -(uo * ud[None]).sum(axis=2) / a[None]
    nearest = uo + tc[..., None] * ud[None]
    rho2 = (nearest * nearest).sum(axis=2)
    r2 = kernel.radius ** 2
    inside = rho2 < r2
    half = np.sqrt(np.maximum(r2 - rho2, 0.0)) / np.sqrt(a)[None]   # the chord's half-length, world units
    lo = np.maximum(tc - half, rays.t0[rows][None])
    hi = np.minimum(tc + half, rays.t1[rows][None])
    # the share of the Gaussian between lo and hi along the chord, by erf (sigma in world units along it)
    scale = np.sqrt(a)[None] / (kernel.sigma * math.sqrt(2.0))
    with np.errstate(invalid="ignore"):
        share = 0.5 * (_erf((hi - tc) * scale) - _erf((lo - tc) * scale))
        whole = _erf(half * scale)
    full = kernel.footprint(np.where(inside, rho2, r2)) / np.sqrt(a)[None]
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.where(whole > 0, full * share / whole, 0.0)
    return np.where(inside & (hi > lo), value, 0.0)


def _splats_alone(scene, rays) -> np.ndarray:
    """Back to front, each splat over what lies behind it: front to back here, the same sum."""
    vol, cam, r = scene.volume, scene.camera, scene.renderer
    lo, hi = (np.asarray(b, float) for b in vol.box)
    splats = Splats(vol, kernel_radius(scene), np.zeros(3), scene.transfer_function.classify_voxels(vol.data, True))
    forward, _, _ = cam.basis()
    depth = splats.depths(np.asarray(cam.eye, float), forward)
    front_to_back = np.argsort(-depth, kind="stable")[::-1]
    kernel = GaussianKernel(r.kernel_width)
    rows = np.nonzero(rays.t1 > rays.t0)[0]
    out = np.zeros((len(rays), 4))
    transmittance = np.ones(len(rows))
    colour_sum = np.zeros((len(rows), 3))
    step = max(1, CHUNK * 50 // max(len(rows), 1))
    for i in range(0, len(front_to_back), step):
        idx = front_to_back[i:i + step]
        integral = kernel_integrals(kernel, vol.spacing, splats.positions[idx], rays, rows)   # (S, R)
        optics = splats.optics[idx].astype(np.float64)
        sigma = optics[:, 3]
        tau = sigma[:, None] * integral
        alpha = -np.expm1(-tau)
        colour = optics[:, :3] / sigma[:, None]
        before = np.exp(-(np.cumsum(tau, axis=0) - tau))     # transmittance in front of each splat
        colour_sum += transmittance[:, None] * np.einsum("sr,sr,sc->rc", before, alpha, colour)
        transmittance *= np.exp(-tau.sum(axis=0))
    out[rows, :3] = colour_sum
    out[rows, 3] = 1.0 - transmittance
    return out


def _axis_sheets(scene, rays) -> np.ndarray:
    from .renderer import axis_order, sheet_axis_planes
    from ...reference.plans import stack_axis

    vol, cam, r, tf = scene.volume, scene.camera, scene.renderer, scene.transfer_function
    pre = pre_classified(scene)
    splats = Splats(vol, kernel_radius(scene), np.zeros(3), tf.classify_voxels(vol.data, True) if pre else None)
    axis = stack_axis(cam)
    planes = sheet_axis_planes(scene, splats.index[:, axis])
    kernel = GaussianKernel(r.kernel_width)
    rows = np.nonzero(rays.t1 > rays.t0)[0]
    h = vol.spacing[axis]
    o, d = rays.origins[rows, axis], rays.directions[rows, axis]
    per_plane = h / np.maximum(np.abs(d), 1e-6)
    table = None if pre else tf.tabulate(r.lut_size)
    out = np.zeros((len(rays), 4))
    transmittance = np.ones(len(rows))
    unique = np.unique(planes)
    for k in unique[np.lexsort((unique, axis_order(scene, unique)))]:
        idx = np.nonzero(planes == k)[0]
        position = vol.origin[axis] + k * h
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (position - 0.5 * h - o) / d, (position + 0.5 * h - o) / d
        lo = np.maximum(rays.t0[rows], np.minimum(ta, tb))
        hi = np.minimum(rays.t1[rows], np.maximum(ta, tb))
        extent = np.where(hi > lo, hi - lo, 0.0)
        sheet = np.zeros((len(rows), 4))
        for i in range(0, len(idx), max(1, CHUNK * 50 // max(len(rows), 1))):
            part = idx[i:i + max(1, CHUNK * 50 // max(len(rows), 1))]
            integral = kernel_integrals(kernel, vol.spacing, splats.positions[part], rays, rows)   # (S, R)
            if pre:
                sheet += integral.T @ splats.optics[part].astype(np.float64)
            else:
                sheet[:, 0] += integral.T @ splats.values[part]
        hit = extent > 0
        if pre:
            tau = sheet[:, 3]
            alpha = -np.expm1(-tau)
            with np.errstate(invalid="ignore", divide="ignore"):
                colour = np.where(tau[:, None] > 0, sheet[:, :3] / tau[:, None], 0.0)
        else:
            colour, sigma = table.lookup(sheet[:, 0] / per_plane)
            alpha = segment_opacity(sigma, extent)
        alpha = np.where(hit, alpha, 0.0)
        out[rows, :3] += transmittance[:, None] * colour * alpha[:, None]
        out[rows, 3] += transmittance * alpha
        transmittance *= 1.0 - alpha
    return out
