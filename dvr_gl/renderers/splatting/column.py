"""The X-ray of SPH particles on the host: the column of every particle's kernel, deposited pixel by pixel.

The pre-classified X-ray of particles is a sum (order-independent, no sheets): each pixel's optical depth
is ``sum_p (m_p / rho_p) sigma_p F_p`` with ``F_p`` the integral of the particle's cubic spline along the
pixel's ray (orthographic: the footprint at the pixel's centre; perspective: the same table at the ray's
own distance from the particle, exact as in GL), or (a particle whose support's radius is under
:data:`.particles.SUBPIXEL_RADIUS` pixels) its footprint averaged over the pixel's square, and its emission
the same with ``sigma c``.  Where GL is software (llvmpipe) the rasterizer is the bottleneck: on two cores
it shades about 20 million fragments a second with the simplest footprint shader, and the splat shader's
whole ray (box, chord, slabs) about 2 million; the host loop here evaluates only the pixels whose centres
lie inside each support, from the same tables (:class:`.footprint.M4Footprint`, read alike), in float64.
The column density of a million particles at 512x512 is about 2.2e8 such pixels
(``dvr_gl/renderers/splatting/README.md``, the particles' section).

Compiled with numba where it is installed (:mod:`.column_compiled`); :func:`deposit_numpy` is the same
sums in numpy (per particle: for tests, and where numba is missing the renderer keeps the GL path).
"""

from __future__ import annotations

import numpy as np

from .particles import SUBPIXEL_RADIUS

#: Emission is ``c`` times the optical depth when every particle's colour is this close to one colour
#: (relative to its sigma): one channel deposited instead of four.
SAME_COLOUR = 1e-7
#: Below this many pixel evaluations (the supports' areas) one thread deposits: waking the others costs more
#: than it saves on a busy machine (10^4 particles at 128x128, 3e6 pixels: 0.1 s on one, 0.2 s on two).
SERIAL_WORK = 2e7


def compiled():
    """:mod:`.column_compiled` (numba) when numba is installed, else ``None``."""
    try:
        from . import column_compiled
    except ImportError:
        return None
    return column_compiled


def applies(scene, software_gl: bool) -> bool:
    """Whether the frame is the host's: particles, the pre-classified X-ray, GL in software and numba
    installed (clipping and meshes are refused for particles, ``check``).  Elsewhere GL draws: a hardware
    GPU shades the footprints faster than the host's cores; emission-absorption and post-classified
    frames need slabs in depth order, not a sum."""
    r = scene.renderer
    return (software_gl and scene.field.kind == "particles" and r.compositing == "xray"
            and r.classification == "pre" and compiled() is not None)


def _lerp(table: np.ndarray, x: np.ndarray) -> np.ndarray:
    n = len(table)
    f = np.clip(x, 0.0, 1.0) * (n - 1)
    i = np.minimum(f.astype(np.int64), n - 2)
    return table[i] + (f - i) * (table[i + 1] - table[i])


def _box(box: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    n = box.shape[0]
    fx = (np.clip(x, -1.0, 1.0) * 0.5 + 0.5) * (n - 1)
    fy = (np.clip(y, -1.0, 1.0) * 0.5 + 0.5) * (n - 1)
    i, j = np.minimum(fx.astype(np.int64), n - 2), np.minimum(fy.astype(np.int64), n - 2)
    wx, wy = fx - i, fy - j
    a = box[i, j] + wx * (box[i + 1, j] - box[i, j])
    b = box[i, j + 1] + wx * (box[i + 1, j + 1] - box[i, j + 1])
    return a + wy * (b - a)


def _span(lo: float, hi: float, n: int) -> np.ndarray:
    """Pixel indices from ``floor(lo)`` to ``floor(hi)`` within ``[0, n)``, clamped before conversion."""
    a = int(np.floor(min(max(lo, -1.0), n)))
    b = int(np.floor(min(max(hi, -1.0), n)))
    return np.arange(max(a, 0), min(b, n - 1) + 1)


def deposit_numpy(cx, cy, radius, weights, subpixel, rays, half, table, box, height: int, width: int) -> np.ndarray:
    """The sum over particles ``p`` of ``weights[p]`` (``(N, channels)``) times the footprint at each pixel,
    ``(channels, height, width)`` float64.  Pixel coordinates: the centre of pixel ``i`` at ``i + 0.5``, rows
    from the bottom; ``radius`` the support ``R`` in pixels (at the particle's depth).  Orthographic
    (``rays`` of shape ``(N, 0)``): a pixel whose centre lies inside a support gets ``table`` (``h^2 F`` over
    ``q = rho^2 / R^2`` in [0, 1], read linearly) there.  Perspective (``rays[p]``: the centre in the view's
    axes right, up, forward from the eye, and the support, world units; ``half``: the view's half extents in
    ``tan``): ``q`` is each pixel's own ray's squared distance from the centre over ``R^2``
    (:func:`ray_q`).  A ``subpixel`` particle gives every pixel its footprint's share over the pixel's
    square, ``G(x1, y1) - G(x0, y1) - G(x1, y0) + G(x0, y0)`` from ``box`` (``G`` over [-1, 1]^2 in units of
    ``R``, read bilinearly), so its pixels share its weight exactly."""
    out = np.zeros((weights.shape[1], height, width))
    for p in range(len(cx)):
        x, y, r = cx[p], cy[p], radius[p]
        if subpixel[p]:
            i, j = _span(x - r, x + r, width), _span(y - r, y + r, height)
            x0, x1 = (i - x) / r, (i + 1 - x) / r
            y0, y1 = ((j - y) / r)[:, None], ((j + 1 - y) / r)[:, None]
            value = _box(box, x1, y1) - _box(box, x0, y1) - _box(box, x1, y0) + _box(box, x0, y0)
        elif rays.shape[1]:
            du, dv = 2.0 * half[0] / width, 2.0 * half[1] / height
            (u0, u1), (v0, v1) = (_tangents(rays[p, a], rays[p, 2], rays[p, 3]) for a in (0, 1))
            i = _span((u0 + half[0]) / du - 0.5, (u1 + half[0]) / du + 0.5, width)
            j = _span((v0 + half[1]) / dv - 0.5, (v1 + half[1]) / dv + 0.5, height)
            u, v = (i + 0.5) * du - half[0], (j + 0.5) * dv - half[1]
            q = ray_q(rays[p], u[None, :], v[:, None])
            value = np.where(q < 1.0, _lerp(table, q), 0.0)
        else:
            i, j = _span(x - r - 0.5, x + r - 0.5, width), _span(y - r - 0.5, y + r - 0.5, height)
            q = (((i + 0.5 - x) ** 2)[None, :] + ((j + 0.5 - y) ** 2)[:, None]) / (r * r)
            value = np.where(q < 1.0, _lerp(table, q), 0.0)
        if len(i) and len(j):
            out[:, j[0]:j[-1] + 1, i[0]:i[-1] + 1] += weights[p][:, None, None] * value
    return out


def _tangents(x: float, z: float, support: float) -> tuple[float, float]:
    """The extremes of ``x / z`` over a sphere in front of the eye (its tangents through the eye)."""
    w = np.sqrt(max(x * x + z * z - support * support, 0.0))
    den = z * z - support * support
    return (x * z - support * w) / den, (x * z + support * w) / den


def ray_q(ray: np.ndarray, u, v):
    """The squared distance of the ray ``(u, v, 1)`` (view axes, from the eye) from the centre ``ray[:3]``,
    over the support's ``ray[3]^2``: ``|c x d|^2 / (|d|^2 R^2)`` (the cross product's terms cancel less than
    ``|c|^2 - (c . d)^2 / |d|^2`` for a far particle)."""
    x, y, z, support = ray
    across, bx, ey = y - z * v, z * u - x, x * v - y * u
    return (across * across + bx * bx + ey * ey) / ((u * u + v * v + 1.0) * support * support)


def deposit(args: tuple, work: float, use_numpy: bool = False) -> np.ndarray:
    """:func:`deposit_numpy`'s sums of ``args``, compiled where numba is installed (on one thread below
    :data:`SERIAL_WORK` pixel evaluations)."""
    module = None if use_numpy else compiled()
    if module is None:
        return deposit_numpy(*args)
    if work < SERIAL_WORK:
        return module.deposit_serial(*args)
    return module.deposit(*args, module.numba.get_num_threads())


class View:
    """The particles as one view sees them (world units, pixels): ``cx``, ``cy`` the centres' images and
    ``radius`` the supports' radii in pixels at their depths, ``per_world`` pixels per world unit there,
    ``rays`` (perspective) each centre in the view's axes from the eye and its support (``(N, 4)``; ``(N,
    0)`` orthographic), ``half`` the view's half extents (``tan`` of the half angles in perspective).
    ``None`` from :meth:`of` where a support reaches the near plane (the GL path clips the rays there)."""

    def __init__(self, cx, cy, radius, per_world, rays, half, slant):
        self.cx, self.cy, self.radius, self.per_world = cx, cy, radius, per_world
        self.rays, self.half, self.slant = rays, half, slant
        self.subpixel = radius < SUBPIXEL_RADIUS

    @classmethod
    def of(cls, scene, splats, eye: np.ndarray, basis) -> "View | None":
        cam, img = scene.camera, scene.image
        forward, right, up = basis
        offset = splats.positions - eye
        depth = offset @ forward
        support = 2.0 * splats.h
        if not (depth - support > cam.near).all():
            return None
        hx, hy = cam.half_extent(img.width / img.height)
        x, y = offset @ right, offset @ up
        if cam.projection == "orthographic":
            at, rays, slant = 1.0, np.empty((len(depth), 0)), 1.0
        else:  # the view's extents at each particle's depth; the ray through the centre's cosine
            at, rays = depth, np.ascontiguousarray(np.stack([x, y, depth, support], axis=1))
            slant = np.sqrt(np.einsum("ij,ij->i", offset, offset)) / depth
        per_world = img.height / (2.0 * hy * at)  # pixels per world unit (square pixels)
        cx = (x / (hx * at) + 1.0) * (0.5 * img.width)
        cy = (y / (hy * at) + 1.0) * (0.5 * img.height)
        return cls(cx, cy, support * per_world, per_world, rays, np.array([hx, hy], float), slant)


def host_xray(scene, splats, eye: np.ndarray, basis, tables, use_numpy: bool = False) -> np.ndarray | None:
    """The X-ray's image (:func:`radiograph`: premultiplied RGBA ``(height, width, 4)`` float32, rows from the
    top, as the GL path reads its target) from the sums ``(sigma c, sigma)`` per pixel; None where a support
    reaches the near plane (the GL path clips it there).  Orthographic: each particle's footprint at the
    pixel centres; perspective: the kernel's exact integral along each pixel's own ray (a sphere's column
    depends only on the ray's distance from its centre), as the GL path's ``m4_integral``; particles under
    :data:`.particles.SUBPIXEL_RADIUS` pixels at their depth averaged over the pixel's square there, over the
    cosine of the ray through them, as GL's ``m4_pixel_average``.
    ``splats``: :class:`.particles.ParticleSplats` (pre-classified, relative to the box's centre as
    ``eye``); ``tables``: :class:`.footprint.M4Footprint`.  What depends only on the particles (their
    weights, one colour) is kept on ``splats``, what depends on the view too with the last view's key."""
    img = scene.image
    if not len(splats):
        return np.zeros((img.height, img.width, 4), np.float32)
    cam = scene.camera
    key = (cam.projection, cam.half_extent(img.width / img.height), cam.near, img.width, img.height,
           tuple(np.ravel(eye)), tuple(np.ravel(basis)))
    view = splats.cached_view(key, lambda: View.of(scene, splats, eye, basis))
    if view is None:
        return None
    weights, colour = splats.column_weights(SAME_COLOUR)
    subpixel = view.subpixel
    # per world unit of the ray: F = table / h^2 at a centre; the share over a pixel's area at the particle's
    # depth otherwise, over the cosine of the ray through it (perspective)
    scale = np.where(subpixel, view.per_world * view.per_world * view.slant, 1.0 / (splats.h * splats.h))
    weights = np.ascontiguousarray(weights * scale[:, None])
    box = tables.box_table if subpixel.any() else NO_BOX
    args = (view.cx, view.cy, view.radius, weights, subpixel, view.rays, view.half, tables.footprint_table, box,
            img.height, img.width)
    work = float(np.sum(np.minimum(view.radius, img.width + img.height) ** 2)) * np.pi
    return radiograph(deposit(args, work, use_numpy), colour)


#: The quadrant table's stand-in where no particle is under a pixel (the real one takes 0.3 s to make).
NO_BOX = np.zeros((2, 2))


def radiograph(sums: np.ndarray, colour: np.ndarray | None) -> np.ndarray:
    """The X-ray's premultiplied RGBA ``(height, width, 4)`` float32, rows from the top, from the deposited
    sums ``(channels, height, width)`` (rows from the bottom): ``(sigma c, sigma)``, or ``sigma`` alone times
    the one ``colour``.  The numbers of :func:`~dvr_gl.transfer_function.xray_rgba` (alpha ``1 - exp(-tau)``,
    colour alpha times ``emitted / tau``), a channel at a time without its ``(N, 4)`` copies."""
    tau = sums[-1][::-1]
    alpha = -np.expm1(-tau)
    out = np.empty(tau.shape + (4,), np.float32)
    inside = tau > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        for c in range(3):
            emitted = tau * colour[c] if colour is not None else sums[c][::-1]
            out[..., c] = np.where(inside, emitted / tau, 0.0) * alpha
    out[..., 3] = alpha
    return out
