"""Shear-warp: run-length encoded slices composited on the host, the intermediate image warped in GL.

Lacroute and Levoy's object-order renderer (:mod:`.factorization` for the
factorization, :mod:`.run_length` for the encoding):

1. the view is factored into a permutation (the principal axis), a shear (and,
   under perspective, a per-slice scale) and a 2D warp;
2. the slices across the principal axis are composited front to back into the
   *intermediate image*, whose pixels are the rays through the front slice's
   voxel grid: slice ``k``'s voxel ``(i, j)`` lands at ``(s i + a_k, s j + b_k)``,
   so every voxel of a slice shares the same bilinear weights (point sampling the
   slice where each ray crosses it; under perspective far slices are minified,
   ``s < 1``).  Transparent runs are never read; runs and voxels that land only on
   pixels already opaque (accumulated opacity at ``ert_threshold``) are skipped;
   opacity is corrected for the ray length between slices, ``spacing / |cos|``
   along each pixel's ray;
3. the intermediate image, as a float RGBA texture, is drawn on a quad transformed
   by ``M_warp`` into the float output, bilinear.

The work vectorized per slice is proportional to the stored (non-transparent)
voxels and their runs, not to the volume's size.  Emission-absorption with post-
or pre-classification, linear filtering; shading and gradient-magnitude opacity
by lookup tables over quantized normals (:mod:`.shading`); pre-integration and
jitter are refused with the reason.  Its oracle, the same-discretization reference of the
intermediate image warped on the host, is :mod:`.oracle`.
"""

from __future__ import annotations

import math
from time import perf_counter as now

import moderngl
import numpy as np

from ... import limits
from ...clipping import ClipRegion
from ...geometry import over_surface, surface_rgba
from ...gl.geometry import depth_range
from ...gl.shaders import create_program, shader_root
from ...rays import RayBatch, intersect_box
from ...sandbox import check_bytes
from ..base import GLRenderer
from .factorization import factorize_view, pixel_directions
from .run_length import RunLengthVolume, SliceClassifier, expand_runs
from .shading import VoxelNormals, frame_table

#: Its own GLSL (before the common library).
SHADERS = (shader_root(__file__),)

OPEN_REFRESH = 4  # slices between refreshes of the per-row count of open pixels (stale counts are safe)
PIECE = 8         # voxels: runs are cut into pieces this long for skipping occluded ones


def shades(scene) -> bool:
    """Whether the scene shades or scales opacity by the gradient (then the voxels carry normals)."""
    r = scene.renderer
    return (r.shading.enabled and bool(r.shading.lights)) or r.gradient_opacity


def slab_lengths(fact, rays: RayBatch, scene) -> np.ndarray:
    """World length of each intermediate pixel's ray between two slices, ``spacing / |cos|``,
    ``(Hi * Wi,)``: one value for parallel rays, varying across the image under perspective."""
    return scene.volume.spacing[fact.axis] / np.abs(rays.directions[:, fact.axis])


class _Depth:
    """Near-plane clipping of samples by their depth along the view axis; ``needed`` is False when the
    whole box lies beyond the near plane."""

    def __init__(self, fact, scene):
        f, _, _ = scene.camera.basis()
        self.f, self.eye = f, np.asarray(scene.camera.eye)
        self.near = scene.camera.near
        self.needed = depth_range(scene.camera, *scene.volume.box)[0] < self.near
        # the reference counts a plane crossed up to 1e-9 plane spacings before the ray's start
        self.slack = 1e-9 * scene.volume.spacing[fact.axis] / max(abs(f[fact.axis]), 1e-12)

    def keep(self, points: np.ndarray) -> np.ndarray:
        """Whether samples at world ``points`` (:func:`slice_points`) lie at or past the near plane."""
        return (points - self.eye) @ self.f >= self.near - self.slack


def slice_points(fact, k: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """World points ``(N, 3)`` where intermediate pixels ``(u, v)``' rays cross slice ``k``."""
    scale, ou, ov = fact.slice_transform(k)
    q = np.stack([(u - ou) / scale, (v - ov) / scale, np.full(u.shape, float(k)), np.ones(u.shape)], axis=-1)
    return (q @ fact.to_world.T)[:, :3]


def composite(fact, rle: RunLengthVolume, scene, table=None) -> tuple[np.ndarray, dict]:
    """The intermediate image ``(Hi, Wi, 4)`` float64 (premultiplied colour, opacity) and counts;
    ``table``: the frame's shading table ``(D, S)`` (:mod:`.shading`), if the scene shades."""
    width, height = fact.size
    r = scene.renderer
    pixels = width * height
    colour = np.zeros((pixels, 3))
    tau = np.zeros(pixels)
    rays = intermediate_rays(fact, scene)
    surface = surface_rgba(scene, rays)  # opaque meshes: each ray ends at its surface (t1 narrowed)
    if surface is not None:
        v_all, u_all = (a.ravel() for a in np.mgrid[0:height, 0:width])
        surface[on_border(fact, u_all, v_all)] = 0.0
    # where a surface ends a ray: a sample past it is dropped (with the reference's slack for a slice on it)
    ends = None
    if surface is not None:
        slack = 1e-9 * scene.volume.spacing[fact.axis] / np.maximum(np.abs(rays.directions[:, fact.axis]), 1e-12)
        ends = np.where(surface[:, 3] > 0, rays.t1 + slack, np.inf)
    open_ = rays.t1 > rays.t0  # rays that only touch the box (at an edge) miss it, as in the reference
    open_rows = np.full((height, width + 1), 0, dtype=np.int64)
    tau_stop = -math.log1p(-r.ert_threshold) if r.ert_threshold < 1.0 else np.inf
    slab = slab_lengths(fact, rays, scene)
    lut = rle.lut
    depth = _Depth(fact, scene)
    clip = ClipRegion.of(r)
    slot = np.zeros(pixels, dtype=np.int64)  # compacting scratch: pixel -> one of its entries
    counts = {"voxels_read": 0, "samples": 0}
    for n, k in enumerate(fact.slices):
        if n % OPEN_REFRESH == 0:
            open_rows[:, 1:] = np.cumsum(open_.reshape(height, width), axis=1)
        if fact.gather:  # a pyramid of an eye inside: each open pixel samples the slice
            p, w, rows, read = _gathered(fact, rle, int(k), open_)
        else:
            p, w, rows, read = _scattered(fact, rle, int(k), open_, open_rows)
        counts["voxels_read"] += read
        if not len(p):
            continue
        if depth.needed or clip is not None or ends is not None:  # per-sample tests at the samples' points
            points = slice_points(fact, int(k), (p % width).astype(np.float64), (p // width).astype(np.float64))
            keep = np.ones(len(p), dtype=bool)
            if depth.needed:
                keep &= depth.keep(points)
            if clip is not None:  # as the slicers' fragments
                keep &= clip.inside(points)
            if ends is not None:  # behind a surface: dropped
                keep &= np.sum((points - rays.origins[p]) * rays.directions[p], axis=1) <= ends[p]
            p, w, rows = p[keep], w[keep], rows[keep]
        if not len(p):
            continue
        pix, weight, values = _accumulate(p, w, _shaded_payload(rle, rows, table), slot)
        c, sigma, pix = _classify(pix, weight, values, lut)
        seg_tau = sigma * slab[pix]
        colour[pix] += np.exp(-tau[pix])[:, None] * c * (-np.expm1(-seg_tau))[:, None]
        tau[pix] += seg_tau
        open_[pix] = tau[pix] < tau_stop
        counts["samples"] += len(pix)
    rgba = over_surface(np.concatenate([colour, -np.expm1(-tau)[:, None]], axis=1), surface)
    return rgba.reshape(height, width, 4), counts


def _scattered(fact, rle, k: int, open_, open_rows):
    """Slice ``k``'s stored voxels scattered to their (up to four) open pixels: pixel indices, bilinear
    weights and the voxels' rows, only pixels whose ray crosses the slice within its voxels; and the
    number of voxels read."""
    width, _ = fact.size
    ni, nj, _ = fact.dims
    empty = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), 0)
    first, length, first_row = rle.runs(k)
    if not len(first):
        return empty
    scale, ou, ov = (float(x) for x in fact.slice_transform(k))
    first, length, first_row = _runs_in_view(first, length, first_row, ni, scale, ou, ov, open_rows)
    if not len(first):
        return empty
    offset, run = expand_runs(first, length)
    flat = first[run] + offset
    rows = first_row[run] + offset
    p, w, rows = _footprints(flat % ni, flat // ni, rows, scale, ou, ov, fact.dims, width, open_)
    keep = _inside(p % width, ou, scale, ni) & _inside(p // width, ov, scale, nj)
    return p[keep], w[keep], rows[keep], len(flat)


def _gathered(fact, rle, k: int, open_):
    """Slice ``k`` sampled by each open pixel whose ray crosses it within its voxels: the pixel, its
    (up to four) stored voxels' bilinear weights and rows, as :func:`_scattered` gives them (the tent
    ``max(0, 1 - |x - i|)`` is the same either way); also where the slice is magnified (scale above
    1), which scattering to four pixels cannot do.  Voxels not stored (transparent) are left out; the
    last value counts the taps read."""
    width, height = fact.size
    ni, nj, _ = fact.dims
    scale, ou, ov = (float(x) for x in fact.slice_transform(k))
    pad_i, pad_j = (0.5 if ni == 1 else 0.0), (0.5 if nj == 1 else 0.0)
    u0, u1 = max(0, math.floor(ou - scale * pad_i)), min(width - 1, math.ceil(ou + scale * (ni - 1 + pad_i)))
    v0, v1 = max(0, math.floor(ov - scale * pad_j)), min(height - 1, math.ceil(ov + scale * (nj - 1 + pad_j)))
    if u1 < u0 or v1 < v0:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), 0
    v, u = (a.ravel() for a in np.mgrid[v0:v1 + 1, u0:u1 + 1])
    p = v * width + u
    keep = open_[p] & _inside(u, ou, scale, ni) & _inside(v, ov, scale, nj)
    p, u, v = p[keep], u[keep], v[keep]
    first, length, first_row = rle.runs(k)
    index = np.full(ni * nj, -1, dtype=np.int64)  # the slice's voxel -> its row (-1: not stored)
    if len(first):
        offset, run = expand_runs(first, length)
        index[first[run] + offset] = first_row[run] + offset
    (i, wi), (j, wj) = _taps((u - ou) / scale, ni), _taps((v - ov) / scale, nj)
    pix = np.tile(p, 4)
    w = np.concatenate([wi[0] * wj[0], wi[1] * wj[0], wi[0] * wj[1], wi[1] * wj[1]])
    rows = index[np.concatenate([j[0] * ni + i[0], j[0] * ni + i[1], j[1] * ni + i[0], j[1] * ni + i[1]])]
    keep = (w > 0) & (rows >= 0)
    return pix[keep], w[keep], rows[keep], int(keep.sum())


def _taps(x, n: int):
    """The two voxels along an axis of ``n`` around positions ``x`` and their linear weights; a single
    sample: itself, weight 1 (its half-voxel extent is checked by :func:`_inside`)."""
    if n == 1:
        zero = np.zeros(len(x), dtype=np.int64)
        return (zero, zero), (np.ones(len(x)), np.zeros(len(x)))
    lo = np.clip(np.floor(x), 0, n - 2).astype(np.int64)
    frac = x - lo
    return (lo, lo + 1), (1.0 - frac, frac)


def _runs_in_view(first, length, first_row, ni, scale, ou, ov, open_rows):
    """Cut the runs into pieces of at most :data:`PIECE` voxels and drop the pieces whose pixels (two
    intermediate rows, the piece's span of columns) are all opaque: early termination at the
    granularity of pieces, as Lacroute's offsets to the next open pixel do per pixel.  ``open_rows``
    counts open pixels per row cumulatively, refreshed every few slices: pixels only ever close, so a
    stale count can keep a piece needlessly but never drop one that is needed."""
    pieces = -(-length // PIECE)
    run = np.repeat(np.arange(len(length)), pieces)
    skip = PIECE * (np.arange(len(run)) - np.repeat(np.cumsum(pieces) - pieces, pieces))
    first, first_row = first[run] + skip, first_row[run] + skip
    length = np.minimum(length[run] - skip, PIECE)
    i0, j = first % ni, first // ni
    height, width1 = open_rows.shape
    y = scale * j + ov
    v0 = np.floor(y).astype(np.int64)
    c0 = np.clip(np.floor(scale * i0 + ou).astype(np.int64), 0, width1 - 1)
    c1 = np.clip(np.floor(scale * (i0 + length - 1) + ou).astype(np.int64) + 2, 0, width1 - 1)
    rows0, rows1 = np.clip(v0, 0, height - 1), np.clip(v0 + 1, 0, height - 1)
    open_count = (open_rows[rows0, c1] - open_rows[rows0, c0]) + (open_rows[rows1, c1] - open_rows[rows1, c0])
    keep = open_count > 0
    return first[keep], length[keep], first_row[keep]


def _footprints(i, j, rows, scale, ou, ov, dims, width, open_):
    """Each voxel's (up to four) pixels and bilinear weights: pixel ``u`` samples the slice at
    ``x = (u - ou) / scale`` and weighs voxel ``i`` by ``max(0, 1 - |x - i|)``; only open pixels."""
    x, y = scale * i + ou, scale * j + ov
    u0, v0 = np.floor(x), np.floor(y)
    wx = _axis_weights(x - u0, scale, dims[0] == 1)
    wy = _axis_weights(y - v0, scale, dims[1] == 1)
    base = v0.astype(np.int64) * width + u0.astype(np.int64)
    p = np.concatenate([base, base + 1, base + width, base + width + 1])
    w = np.concatenate([wx[0] * wy[0], wx[1] * wy[0], wx[0] * wy[1], wx[1] * wy[1]])
    rows = np.tile(rows, 4)
    keep = (w > 0) & open_[p]
    return p[keep], w[keep], rows[keep]


def _axis_weights(frac, scale, single: bool):
    """Weights of a voxel for the pixels ``floor(x)`` and ``floor(x) + 1``, ``frac = x - floor(x)``:
    the tent of bilinear interpolation, or, across a single sample, its value within half a voxel
    (the conventions' one-spacing slab)."""
    if single:
        return (frac <= 0.5 * scale).astype(np.float64), (1.0 - frac <= 0.5 * scale).astype(np.float64)
    return np.maximum(0.0, 1.0 - frac / scale), np.maximum(0.0, 1.0 - (1.0 - frac) / scale)


def _inside(u, offset, scale, n) -> np.ndarray:
    """Pixels whose ray crosses the slice within its ``n`` voxels (``x = (u - offset) / scale``); a
    single sample's extent is half a voxel either side."""
    x = (u - offset) / scale
    lo, hi = (-0.5, 0.5) if n == 1 else (0.0, n - 1.0)
    return (x >= lo - 1e-9) & (x <= hi + 1e-9)


def _accumulate(p, w, payload, slot):
    """Sum weights and weighted payload per distinct pixel, in O(entries): every entry finds its
    pixel's representative through ``slot`` (no sort)."""
    m = len(p)
    idx = np.arange(m)
    slot[p] = idx
    rep = slot[p]
    first = rep == idx
    compact = np.cumsum(first) - 1
    ids = compact[rep]
    n = int(compact[-1]) + 1
    weight = np.bincount(ids, w, n)
    values = np.stack([np.bincount(ids, w * payload[:, c], n) for c in range(payload.shape[1])], axis=1)
    return p[first], weight, values


def _shaded_payload(rle: RunLengthVolume, rows, table) -> np.ndarray:
    """What the voxels of ``rows`` contribute (:mod:`.shading`): the payload, pre-classified voxels
    shaded and scaled by their gradient-opacity factor (``(sigma f (c D + S), sigma f)``); after a
    post-classified value, its voxel's ``D``, ``S`` and ``f`` (interpolated alike)."""
    payload = rle.payload[rows].astype(np.float64)
    if rle.codes is None:
        return payload
    codes = rle.codes[rows]
    f = np.ones((len(rows), 1)) if rle.factor is None else rle.factor[rows].astype(np.float64)[:, None]
    d, s = (np.ones((len(rows), 3)), np.zeros((len(rows), 3))) if table is None else \
        (table[0][codes], table[1][codes])
    if rle.lut is None:
        sigma = payload[:, 3:4] * f
        return np.concatenate([(payload[:, :3] * d + payload[:, 3:4] * s) * f, sigma], axis=1)
    return np.concatenate([payload, d, s, f], axis=1)


def _classify(pix, weight, values, lut):
    """Colour and extinction of the accumulated samples.  Post-classification keeps only samples whose
    four voxels were all stored (weights adding to 1); the others are transparent by construction.
    Post-classified samples with shading carry their interpolated ``D``, ``S`` and ``f`` after the
    value (:func:`_shaded_payload`)."""
    if lut is None:
        sigma = np.maximum(values[:, 3], 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            colour = np.where(sigma[:, None] > 0, np.maximum(values[:, :3], 0.0) / sigma[:, None], 0.0)
        return colour, sigma, pix
    complete = weight >= 1.0 - 1e-9
    w = weight[complete, None]
    colour, sigma = lut.lookup(values[complete, 0] / w[:, 0])
    if values.shape[1] > 1:
        shades = values[complete, 1:] / w
        colour, sigma = colour * shades[:, :3] + shades[:, 3:6], sigma * shades[:, 6]
    return colour, sigma, pix[complete]


def intermediate_rays(fact, scene, u=None, v=None) -> RayBatch:
    """The rays of intermediate pixels ``(u, v)`` (default: all, row-major), clipped like the camera's."""
    if u is None:
        width, height = fact.size
        v, u = (a.ravel() for a in np.mgrid[0:height, 0:width])
    points = fact.front_points(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64))
    cam = scene.camera
    f, _, _ = cam.basis()
    eye = np.asarray(cam.eye)
    if fact.perspective:
        d = points - eye
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        o = np.broadcast_to(eye, d.shape).copy()
    else:
        d = np.broadcast_to(f, points.shape).copy()
        o = points - ((points - eye) @ f)[:, None] * f
    t_enter, t_exit = intersect_box(o, d, *scene.volume.box)
    clip = ClipRegion.of(scene.renderer)
    if clip is not None:  # the slices crossed inside the region: the samples composite keeps
        t_enter, t_exit = clip.interval(o, d, t_enter, t_exit)
    t0 = np.maximum(t_enter, cam.near_distance(d))
    hit = (t_exit > t0) & (d @ f > 0)  # a ray leaving the eye backwards is no camera's (a pyramid's margin)
    return RayBatch(o, d, np.where(hit, t0, 0.0), np.where(hit, t_exit, 0.0), np.full(len(o), 0.5))


def on_border(fact, u, v) -> np.ndarray:
    """Whether intermediate pixels ``(u, v)`` lie on the image's one-pixel border, which stays transparent
    (meshes included) so that the warp fades to nothing at its edges as the reference's taps outside do.
    A pyramid's image has none: it covers its pixels' taps with a margin, every pixel a ray's."""
    width, height = fact.size
    if fact.gather:
        return np.zeros(np.shape(u), dtype=bool)
    return (u <= 0) | (v <= 0) | (u >= width - 1) | (v >= height - 1)


#: Shear-warp's own unit of work: each slice composited touches the whole intermediate image (its open pixels'
#: counts, refreshed every few slices, and the scratch of its pieces), so beside the voxels a frame costs about
#: slices x intermediate pixels, which the shear widens: a 1 x 2000 x 2 volume composites 2000 slices into 650 x 890
#: pixels in 1.45 s (8e8 a second, on two shared cores, 2026-11-29), and a 1 x 20000 x 2 one (58 million pixels)
#: ran past 400 s unrefused.  Bound: about 20 minutes at that rate.
PIXEL_SLICES = limits.work_unit("intermediate pixel-slices", 1e12, 8e8)
#: Host bytes an intermediate pixel takes while its slices composite: its ray (origin, direction, ends), colour,
#: optical depth, slab length, counts and scratch in float64, and the image handed to the warp.
BYTES_PER_INTERMEDIATE_PIXEL = 256
WORK_FIX = "downsample the volume along its longest axis, lower --size, or use raycast (whose rays do not widen)"


class ShearWarpRenderer(GLRenderer):
    name = "shearwarp"
    description = "shear-warp: run-length encoded slices composited on the host, warped in GL"

    def work(self, scene) -> limits.Work:
        """Slices x intermediate pixels over the view's factorizations (:data:`PIXEL_SLICES`)."""
        facts = factorize_view(scene.camera, scene.volume, scene.image.width, scene.image.height)
        count = sum(float(len(f.slices)) * f.size[0] * f.size[1] for f in facts)
        big = max(facts, key=lambda f: f.size[0] * f.size[1])
        return limits.Work(count, PIXEL_SLICES, f"{len(big.slices)} slices x {big.size[0]}x{big.size[1]} intermediate "
                           f"pixels{f' in each of {len(facts)} factorizations' if len(facts) > 1 else ''}", WORK_FIX)

    def encoding(self, scene, axis: int) -> RunLengthVolume:
        """The run-length encoding across ``axis``, rebuilt only when the volume, transfer function,
        classification, threshold, table size or (shading) the voxels' normals change."""
        r = scene.renderer
        normals = self.voxel_normals(scene)
        key = (scene.volume, scene.transfer_function, r.classification, r.opacity_threshold, r.lut_size, normals)
        return self._cached(f"rle {axis}", key, lambda: RunLengthVolume(
            scene.volume.data, axis, SliceClassifier(scene.transfer_function, r.classification, r.lut_size,
                                                     r.opacity_threshold), normals))

    def voxel_normals(self, scene) -> "VoxelNormals | None":
        """The volume's encoded normals (:mod:`.shading`), made once per volume and gradient-opacity
        reference; None where the scene neither shades nor scales opacity by the gradient."""
        if not shades(scene):
            return None
        r = scene.renderer
        reference = r.gradient_opacity_reference if r.gradient_opacity else None
        return self._cached("voxel normals", (scene.volume, reference),
                            lambda: VoxelNormals(scene.volume, reference))

    def check_textures(self, scene, gl):
        """Classification runs on the host: the table is no texture, only its memory counts; the
        intermediate image is one (one pixel per voxel of the front slice, plus the shear)."""
        limits.check_lut_memory(scene.renderer.lut_size)
        for fact in factorize_view(scene.camera, scene.volume, scene.image.width, scene.image.height):
            limits.check_texture("shear-warp's intermediate image", fact.size, gl,
                                 "downsample the volume or use another renderer (raycast bricks large volumes)")
            check_bytes(fact.size[0] * fact.size[1] * BYTES_PER_INTERMEDIATE_PIXEL,
                        f"shear-warp's {fact.size[0]}x{fact.size[1]} intermediate image", WORK_FIX)

    def draw(self, scene) -> np.ndarray:
        self.activate()
        start = now()
        width, height = scene.image.width, scene.image.height
        image = np.zeros((height, width, 4), dtype=np.float32)
        counts = {"voxels_read": 0, "samples": 0}
        composited, stored = 0.0, 0
        facts = factorize_view(scene.camera, scene.volume, width, height)
        for fact in facts:  # one, or one per pyramid of an eye inside (each pixel warped from one)
            begun = now()
            rle = self.encoding(scene, fact.axis)
            table = frame_table(scene) if rle.codes is not None else None
            intermediate, done = composite(fact, rle, scene, table)
            composited += now() - begun
            stored = max(stored, rle.stored_voxels)
            counts = {key: counts[key] + done[key] for key in counts}
            image += self.warp(fact, intermediate, width, height, scene)
        total = int(np.prod(scene.volume.dims))
        self.stats = {"seconds": now() - start, "composite_seconds": composited, "axis": facts[0].axis,
                      "intermediate": facts[0].size, "factorizations": len(facts), "voxels": total,
                      "stored_voxels": stored, "skipped_fraction": 1.0 - counts["voxels_read"] / total, **counts}
        return image

    def warp(self, fact, intermediate: np.ndarray, width: int, height: int, scene=None) -> np.ndarray:
        """Draw the intermediate image on a quad transformed by ``M_warp`` (homogeneous, so that GL
        interpolates texture coordinates perspective-correctly), bilinear; a pyramid's only on the
        pixels whose rays are its own (PYRAMID in warp.frag, :func:`.oracle.pixel_owners`' rule)."""
        wi, hi = fact.size
        to_ndc = np.array([[2.0 / width, 0.0, -1.0], [0.0, -2.0 / height, 1.0], [0.0, 0.0, 1.0]])
        program = create_program(self.ctx, "warp.vert", "warp.frag", {"PYRAMID": fact.pyramid is not None},
                                 roots=SHADERS)
        if fact.pyramid is not None:
            directions = pixel_directions(scene.camera, scene.volume, width, height)
            program["u_pixel_dirs"].write(directions.T.astype("f4").tobytes())  # GL: column-major
            program["u_pyramid_axis"].value = fact.pyramid[0]
            program["u_pyramid_sign"].value = float(fact.pyramid[1])
            program["u_image_height"].value = float(height)
        texture = self.ctx.texture((wi, hi), 4, np.ascontiguousarray(intermediate, dtype=np.float32).tobytes(),
                                   dtype="f4")
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        texture.repeat_x = texture.repeat_y = False
        corners = np.array([[-0.5, -0.5], [wi - 0.5, -0.5], [wi - 0.5, hi - 0.5],
                            [-0.5, -0.5], [wi - 0.5, hi - 0.5], [-0.5, hi - 0.5]], dtype=np.float32)
        vbo = self.ctx.buffer(corners.tobytes())
        vao = self.ctx.vertex_array(program, [(vbo, "2f", "position")])
        (_,), fbo = self.target("main", width, height)
        try:
            fbo.use()
            self.ctx.viewport = (0, 0, width, height)
            self.ctx.clear(0.0, 0.0, 0.0, 0.0)
            self.ctx.disable(self.ctx.BLEND | self.ctx.DEPTH_TEST | self.ctx.CULL_FACE)
            program["u_warp"].write((to_ndc @ fact.warp).T.astype("f4").tobytes())  # GL: column-major
            program["u_size"].value = (float(wi), float(hi))
            texture.use(0)
            program["u_intermediate"].value = 0
            vao.render(moderngl.TRIANGLES)
            return self.read(fbo, width, height)
        finally:
            vao.release()
            vbo.release()
            texture.release()
