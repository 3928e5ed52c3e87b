"""The X-ray of SPH particles on the host: the column of every particle's kernel, deposited pixel by pixel.

The pre-classified X-ray of particles in an orthographic view is a sum (order-independent, no sheets):
each pixel's optical depth is ``sum_p (m_p / rho_p) sigma_p F_p`` with ``F_p`` the footprint of the
particle's cubic spline at the pixel's centre, or (a particle whose support's radius is under
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
    """Whether the frame is the host's: particles, the pre-classified X-ray, orthographic, GL in software and
    numba installed (clipping and meshes are refused for particles, ``check``)."""
    r = scene.renderer
    return (software_gl and scene.field.kind == "particles" and r.compositing == "xray"
            and r.classification == "pre" and scene.camera.projection == "orthographic" and compiled() is not None)


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


def deposit_numpy(cx, cy, radius, weights, subpixel, table, box, height: int, width: int) -> np.ndarray:
    """The sum over particles ``p`` of ``weights[p]`` (``(N, channels)``) times the footprint at each pixel,
    ``(channels, height, width)`` float64.  Pixel coordinates: the centre of pixel ``i`` at ``i + 0.5``, rows
    from the bottom; ``radius`` the support ``R`` in pixels.  A pixel whose centre lies inside a support gets
    ``table`` (``h^2 F`` over ``q = rho^2 / R^2`` in [0, 1], read linearly) there; a ``subpixel`` particle
    gives every pixel its footprint's share over the pixel's square, ``G(x1, y1) - G(x0, y1) - G(x1, y0) +
    G(x0, y0)`` from ``box`` (``G`` over [-1, 1]^2 in units of ``R``, read bilinearly), so its pixels share
    its weight exactly."""
    out = np.zeros((weights.shape[1], height, width))
    for p in range(len(cx)):
        x, y, r = cx[p], cy[p], radius[p]
        if subpixel[p]:
            i, j = _span(x - r, x + r, width), _span(y - r, y + r, height)
            x0, x1 = (i - x) / r, (i + 1 - x) / r
            y0, y1 = ((j - y) / r)[:, None], ((j + 1 - y) / r)[:, None]
            value = _box(box, x1, y1) - _box(box, x0, y1) - _box(box, x1, y0) + _box(box, x0, y0)
        else:
            i, j = _span(x - r - 0.5, x + r - 0.5, width), _span(y - r - 0.5, y + r - 0.5, height)
            q = (((i + 0.5 - x) ** 2)[None, :] + ((j + 0.5 - y) ** 2)[:, None]) / (r * r)
            value = np.where(q < 1.0, _lerp(table, q), 0.0)
        if len(i) and len(j):
            out[:, j[0]:j[-1] + 1, i[0]:i[-1] + 1] += weights[p][:, None, None] * value
    return out


def deposit(args: tuple, work: float, use_numpy: bool = False) -> np.ndarray:
    """:func:`deposit_numpy`'s sums of ``args``, compiled where numba is installed (on one thread below
    :data:`SERIAL_WORK` pixel evaluations)."""
    module = None if use_numpy else compiled()
    if module is None:
        return deposit_numpy(*args)
    if work < SERIAL_WORK:
        return module.deposit_serial(*args)
    return module.deposit(*args, module.numba.get_num_threads())


def host_xray(scene, splats, eye: np.ndarray, basis, tables, use_numpy: bool = False) -> np.ndarray | None:
    """The X-ray's image (:func:`radiograph`: premultiplied RGBA ``(height, width, 4)`` float32, rows from the
    top, as the GL path reads its target) from the sums ``(sigma c, sigma)`` per pixel; None where a support
    reaches the near plane (the GL path clips it there).
    ``splats``: :class:`.particles.ParticleSplats` (pre-classified, relative to the box's centre as
    ``eye``); ``tables``: :class:`.footprint.M4Footprint`."""
    cam, img = scene.camera, scene.image
    if not len(splats):
        return np.zeros((img.height, img.width, 4), np.float32)
    forward, right, up = basis
    offset = splats.positions - eye
    support = 2.0 * splats.h
    if len(offset) and not ((offset @ forward) - support > cam.near).all():
        return None
    hx, hy = cam.half_extent(img.width / img.height)
    per_world = img.height / (2.0 * hy)  # pixels per world unit (square pixels)
    cx = (offset @ right / hx + 1.0) * (0.5 * img.width)
    cy = (offset @ up / hy + 1.0) * (0.5 * img.height)
    radius = support * per_world
    subpixel = radius < SUBPIXEL_RADIUS
    optics = splats.optics.astype(np.float64) * splats.weights[:, None]  # (m / rho) (sigma c, sigma)
    sigma = optics[:, 3:]
    colour = optics[:1, :3] / sigma[:1]
    one = bool(np.all(np.abs(optics[:, :3] - sigma * colour) <= SAME_COLOUR * sigma))
    weights = sigma if one else optics
    # per world unit of the ray: F = table / h^2 at a centre, the share over a pixel's area otherwise
    scale = np.where(subpixel, per_world * per_world, 1.0 / (splats.h * splats.h))
    weights = np.ascontiguousarray(weights * scale[:, None])
    table, box = tables.footprint_table, tables.box_table
    args = (cx, cy, radius, weights, subpixel, table, box, img.height, img.width)
    sums = deposit(args, float(np.sum(np.minimum(radius, img.width + img.height) ** 2)) * np.pi, use_numpy)
    return radiograph(sums, colour[0] if one else None)


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
