"""Image-aligned post-classified sheets of a grid's Gaussian splats rasterized on the host (numba), for the
frames where software GL spends its time on the splats' instances rather than their pixels.

On llvmpipe each kernel drawn into each slab costs about a microsecond and a half whatever its footprint
(vertex shading, triangle setup and binning of an instanced quad), and an image-aligned frame draws every
kernel into each of the 7-8 slabs it reaches: CThead's 3.0 million kept splats are 19 million instances.
Here each splat is taken once per group of slabs (:func:`group_size`): per pixel of its screen rectangle the
footprint is found once (the nearest approach, ``F(q)``) and split among the group's slabs by the Gaussian's
cumulative along the ray; each group's sheets are then composited front to back, and the pixels that are
opaque by then take no more splats (early termination per pixel, as ``splat.frag``'s).  The loops
(:mod:`.host_compiled`) compute what the shaders compute, in float64 from the same tables, so the image is the
same-slabs oracle's to float64 rounding and the tables' interpolation.

Used where numba is installed and the frame is what it serves (:func:`serves`): the Gaussian, image-aligned
sheets, post-classified emission-absorption, no shading, clipping, meshes or screen low-pass, exact
footprints; every other frame, and every frame without numba, is drawn in GL.
"""

from __future__ import annotations

import functools

import numpy as np

from ...clipping import clipping_in_use
from ...rays import RayBatch
from . import low_pass
from .footprint import GaussianFootprint
from .sheets import kernel_depth_reach, kernel_radius, shaded_sheets, slab_bounds

#: Slabs filled per pass over the splats, at most: a splat is visited once per group it reaches (a kernel
#: reaches 7-8 slabs of one voxel), and early termination waits for the group's compositing.  CThead at
#: 128x128 (process CPU seconds a frame, a busy machine): groups of 4 slabs 9.1, 8 7.0, 16 6.7, 32 5.8.
GROUP = 32
#: The group's sheets' size, at most (float64 entries, two arrays): fewer slabs a group in large images.
GROUP_ENTRIES = 1 << 22
#: Bands of image rows per thread in :func:`.host_compiled.fill_sheets` (several: a band's splats vary).
BANDS_PER_THREAD = 4


def group_size(pixels: int) -> int:
    """Slabs a group for an image of ``pixels``: :data:`GROUP`, fewer where the sheets would pass
    :data:`GROUP_ENTRIES` (at least 2)."""
    return int(min(GROUP, max(2, GROUP_ENTRIES // max(pixels, 1))))


def compiled():
    """:mod:`.host_compiled` (numba) when numba is installed, else ``None`` (the frame is drawn in GL)."""
    try:
        from . import host_compiled
    except ImportError:
        return None
    return host_compiled


def serves(scene) -> bool:
    """Whether the host path draws this frame (module doc)."""
    r = scene.renderer
    return (scene.field.kind == "grid" and r.filter == "gaussian" and r.sheet_buffer == "image_aligned"
            and r.classification == "post" and r.compositing == "emission_absorption" and not shaded_sheets(scene)
            and not clipping_in_use(r.clipping) and not r.geometry and not low_pass.enabled(scene)
            and r.footprint == "exact")


def render(scene, splats, centre, table, loops=None, report=None) -> tuple[np.ndarray, dict]:
    """The frame ``(H, W, 4)`` float32 and its stats, from ``splats`` (:class:`.splats.Splats`, positions
    relative to ``centre``) and the transfer function's ``table`` (:class:`~dvr_gl.transfer_function.
    TransferFunctionLUT`); ``loops``: :mod:`.host_compiled` or an object with its functions (default: the
    compiled ones); ``report(done, total)``: called with the slabs composited after each group (progress,
    where Ctrl-C and a sandbox's timer stop a frame)."""
    loops = loops or compiled()
    r, cam, img = scene.renderer, scene.camera, scene.image
    w, h = img.width, img.height
    forward, right, up = cam.basis()
    eye = np.asarray(cam.eye, float)
    rays = RayBatch.for_camera(cam, w, h, scene.field.bounds)
    origins = np.ascontiguousarray(rays.origins - centre)
    directions = np.ascontiguousarray(rays.directions, dtype=np.float64)
    along = directions @ np.asarray(forward, float)
    bounds = slab_bounds(scene, eye, forward)  # view depths from the eye; even slabs
    slabs = len(bounds) - 1
    reach = kernel_depth_reach(scene, forward)
    spacing = np.asarray(scene.volume.spacing, float)
    group = group_size(w * h)
    core = np.zeros(0) if splats.core is None else np.ascontiguousarray(splats.core, dtype=np.float64)
    positions, values, core, rect, slab_range, start = loops.splat_schedule(
        np.ascontiguousarray(splats.positions, dtype=np.float64), np.ascontiguousarray(splats.values, dtype=np.float64),
        core, eye - centre, np.ascontiguousarray([forward, right, up], dtype=np.float64),
        np.asarray(cam.half_extent(w / h), float), kernel_radius(scene) * spacing, cam.projection == "perspective",
        float(cam.near), w, h, float(bounds[0]), float(bounds[1] - bounds[0]), slabs, reach, group)
    span = int((slab_range[:, 1] - slab_range[:, 0]).max()) if len(values) else 0  # the most slabs a kernel meets
    footprint, cumulative = _tables(r.kernel_radius)
    image = np.zeros((w * h, 4))
    sheet = np.zeros((group, w * h))
    cores = np.zeros((group, w * h))
    bands = min(h, BANDS_PER_THREAD * _threads())
    threshold = r.ert_threshold if r.ert_threshold < 1.0 else np.inf  # 1: no early termination (as GL's)
    visits = skipped = rest = 0  # splats taken per group, of them skipped (opaque), and those left at the end
    for k0 in range(0, slabs, group):
        k1 = min(k0 + group, slabs)
        first = int(start[max(k0 - span, 0) // group])  # every splat whose slabs may meet k0 .. k1 - 1
        last = int(start[k0 // group + 1])
        if not (image[:, 3] < threshold).any():  # every pixel opaque: nothing behind counts
            rest = len(values) - first
            break
        sheet[:] = 0.0
        cores[:] = 0.0
        opened = np.zeros(last - first, bool)
        crossings = np.ascontiguousarray(bounds[k0:k1 + 1, None] / along[None, :])
        loops.fill_sheets(first, last, positions, values, core, rect, slab_range, origins, directions,
                          rays.t0, rays.t1, crossings, k0, 1.0 / spacing, kernel_radius(scene), r.kernel_width,
                          footprint, cumulative, image[:, 3], threshold, w, bands, sheet[:k1 - k0], cores[:k1 - k0],
                          opened)
        meets = (slab_range[first:last, 1] >= k0) & (slab_range[first:last, 0] < k1)
        visits += int(np.count_nonzero(meets))
        skipped += int(np.count_nonzero(meets & ~opened))
        loops.composite_sheets(sheet, cores, len(core) > 0, rays.t0, rays.t1, along, bounds, k0, k1, table.table,
                               float(table.domain[0]), float(table.domain[1]), image)
        if report is not None:
            report(k1, slabs)
    stats = {"sheets": slabs, "splats_drawn": visits - skipped, "skipped": skipped + rest}
    return image.reshape(h, w, 4).astype(np.float32), stats


def _threads() -> int:
    """The threads numba's parallel loops run on (1 where numba is not installed)."""
    try:
        import numba
    except ImportError:
        return 1
    return int(numba.get_num_threads())


@functools.lru_cache(maxsize=2)
def _tables(radius_in_sigmas: float) -> tuple[np.ndarray, np.ndarray]:
    """The Gaussian's footprint ``F(q)`` for ``sigma = 1`` and the standard normal's cumulative over ``+-R /
    sigma`` (float64, the GL textures'), cut at ``radius_in_sigmas`` (``renderer.kernel_radius``): once per
    process and truncation."""
    table = GaussianFootprint(radius_in_sigmas)
    return table.footprint_table, table.cumulative_table
