"""Which splats go into which sheet buffer, in what order: image-aligned slabs (Mueller and
Crawfis) and voxel planes (Westover), shared by the renderer and its oracle.

A schedule is the splats' order (a permutation, uploaded in that order) and one ``(uniforms,
first, last)`` per sheet, front to back: the sheet's shader uniforms and its contiguous range of
splats.
"""

from __future__ import annotations

import math

import numpy as np

from ...fields.ragged import ranges
from ...gl.geometry import box_corners
from ...reference.plans import stack_axis
from ...scene.model import CLASSIFIED_ALONG_RAY
from . import low_pass
from .splats import slabs, support_depth

#: The cubic B-spline's support is a cube of four voxels: its bounding sphere's radius, voxels.
BSPLINE_RADIUS = 2.0 * math.sqrt(3.0)


def kernel_radius(scene) -> float:
    """The grid kernel's support (its bounding sphere), voxels: the Gaussian's truncation radius, the cubic
    B-spline's cube's corner."""
    if scene.renderer.filter == "cubic_bspline":
        return BSPLINE_RADIUS
    return scene.renderer.kernel_radius * scene.renderer.kernel_width


def kernel_reach(scene) -> float:
    """How far a grid kernel reaches, voxels: its support, widened by the screen low-pass
    (:func:`.low_pass.reach_voxels`): the ghost layers, the culling's bounds and the splats' bounding spheres."""
    if scene.renderer.filter == "gaussian" and low_pass.enabled(scene):
        return low_pass.reach_voxels(scene)
    return kernel_radius(scene)


def kernel_depth_reach(scene, forward) -> float:
    """How far a grid kernel reaches along the view axis ``forward`` (world units): the Gaussian's ellipsoid's
    half-extent, the B-spline's cube's (``2 sum |spacing_i forward_i|``)."""
    spacing = np.asarray(scene.volume.spacing, float)
    if scene.renderer.filter == "cubic_bspline":
        return float(2.0 * np.abs(spacing * np.asarray(forward)).sum())
    return support_depth(kernel_radius(scene), spacing, forward)


def kernel_sigma(scene) -> float | None:
    """The Gaussian's standard deviation, voxels; None for the cubic B-spline."""
    return scene.renderer.kernel_width if scene.renderer.filter == "gaussian" else None


def pre_classified(scene) -> bool:
    r = scene.renderer
    return r.compositing in CLASSIFIED_ALONG_RAY and r.classification == "pre"


def culled_post(scene) -> bool:
    """Post-classified emission-absorption or X-ray in image-aligned sheets: culled by regions
    (:func:`.splats.post_visibility`, whose bound holds for a slab's part of a ray; an axis-aligned
    sheet's kernels reach the whole ray)."""
    r = scene.renderer
    return (r.compositing in CLASSIFIED_ALONG_RAY and r.classification == "post" and r.sheet_buffer == "image_aligned"
            and is_grid(scene) and not shaded_sheets(scene))


def shaded_sheets(scene) -> bool:
    """Whether the sheets are shaded (post-classified image-aligned emission-absorption with shading on):
    then nothing is culled and nothing terminated early, since a pixel's gradient reads its neighbours'
    and the next sheet's values, which must not be left out."""
    r = scene.renderer
    return bool(r.shading.enabled and r.shading.lights and r.sheet_buffer == "image_aligned"
                and r.classification == "post" and r.compositing == "emission_absorption")


def is_grid(scene) -> bool:
    """Whether the scene's splats are a grid's samples (else SPH particles)."""
    return scene.field.kind == "grid"


def part_voxels(scene) -> float:
    """The longest part of a ray in one slab, voxels of the smallest spacing: the slab's width over the
    cosine of the widest ray's angle to the view axis (the image's corner in perspective)."""
    cam, img = scene.camera, scene.image
    if cam.projection == "orthographic":
        return scene.renderer.slab_width
    hx, hy = cam.half_extent(img.width / img.height)
    return scene.renderer.slab_width * math.sqrt(1.0 + hx * hx + hy * hy)


def sheet_axis_planes(scene, index_along: np.ndarray) -> np.ndarray:
    """Westover's sheets: each splat's voxel plane across the stack axis, ghosts merged into the border
    planes (their kernels reach into the box from there)."""
    return np.clip(index_along, 0, scene.volume.dims[stack_axis(scene.camera)] - 1)


def axis_order(scene, planes: np.ndarray) -> np.ndarray:
    """The planes' compositing order: by their distance from the eye along the axis (each pixel
    composites only the planes in front of it, so an eye among the planes is served too)."""
    vol, axis = scene.volume, stack_axis(scene.camera)
    position = vol.origin[axis] + planes * vol.spacing[axis]
    return np.abs(position - scene.camera.eye[axis])


def axis_schedule(scene, splats, centre):
    """Splats sorted by sheet (front first) and one ``(uniforms, first, last)`` per sheet."""
    vol, axis = scene.volume, stack_axis(scene.camera)
    planes = sheet_axis_planes(scene, splats.index[:, axis])
    key = axis_order(scene, planes)
    order = np.lexsort((planes, key))
    sorted_planes = planes[order]
    starts = np.r_[0, np.nonzero(np.diff(sorted_planes))[0] + 1, len(order)]
    schedule = []
    for a, b in zip(starts[:-1], starts[1:]):
        position = vol.origin[axis] + sorted_planes[a] * vol.spacing[axis] - centre[axis]
        schedule.append(({"u_axis": axis, "u_plane": float(position)}, int(a), int(b)))
    return order, schedule


def slab_bounds(scene, eye, forward) -> np.ndarray:
    """The image-aligned slabs' view depths over the box (from the near plane); ``eye`` in world
    coordinates."""
    return slabs(*_slab_span(scene, eye, forward))


def _slab_span(scene, eye, forward) -> tuple[float, float, float]:
    """``(first depth, last depth, slab width)`` of the image-aligned slabs, world units."""
    lo, hi = scene.field.bounds
    depths = (box_corners(lo, hi) - eye) @ forward
    width = scene.renderer.slab_width * scene.field.sample_spacing
    return max(float(depths.min()), scene.camera.near), float(depths.max()), width


def _slab_runs(scene, depth: np.ndarray, reach: float):
    """``(start, width, count, a, b)``: the slabs from depth ``start`` of ``width`` (``count`` of them over
    the box) and the runs ``a[i] .. b[i]`` of those a splat reaches (view depths ``depth`` of the centres,
    every kernel within ``reach`` of its own)."""
    cam = scene.camera
    start, end, width = _slab_span(scene, np.asarray(cam.eye, float), cam.basis()[0])
    count = max(math.ceil((end - start) / width - 1e-9), 1) if math.isfinite((end - start) / width) else math.inf
    depth = np.sort(np.asarray(depth, float))
    first = np.clip(np.floor((depth - reach - start) / width), 0, count - 1)
    last = np.clip(np.floor((depth + reach - start) / width), 0, count - 1)
    reached = np.maximum.accumulate(last)  # a run ends where the next splat starts past all reached so far
    new = np.r_[True, first[1:] > reached[:-1] + 1] if len(depth) else np.zeros(0, bool)
    return start, width, count, first[new], reached[np.r_[np.nonzero(new)[0][1:] - 1, len(depth) - 1]] \
        if len(depth) else np.zeros(0)


def occupied_slab_count(scene, depth: np.ndarray, reach: float) -> float:
    """How many slabs :func:`occupied_slabs` gives (without making them): those reached, and one for each
    stretch between (a float: it may be huge)."""
    _, _, count, a, b = _slab_runs(scene, depth, reach)
    if not len(a):
        return 1.0
    gaps = float(a[0] > 0) + float(b[-1] < count - 1) + float(np.count_nonzero(a[1:] > b[:-1] + 1))
    return float((b - a + 1).sum()) + gaps


def occupied_slabs(scene, depth: np.ndarray, reach: float) -> np.ndarray:
    """Particles' slab boundaries: :func:`slab_bounds`' slabs where a splat reaches, each run of slabs that
    none reaches merged into one (see :func:`_slab_runs`).  The field is zero all along such a run, so it
    composites the same cut or whole (a homogeneous stretch); a particle 1e17 away from the rest then costs
    its own slabs, not 1e17 of them.  Boundaries closer than float64 tells apart are merged too (no slab of
    zero depth)."""
    start, width, count, a, b = _slab_runs(scene, depth, reach)
    edges = ranges(a, (b - a + 2).astype(np.int64))  # each run's slabs' boundaries
    edges = np.unique(np.r_[0.0, edges, float(count)])
    return np.unique(start + width * edges)


def slab_schedule(scene, depth: np.ndarray, reach: float | None = None):
    """Image-aligned slabs: the splats by view depth of their centres (``depth``), each slab with the
    range whose kernels reach into it (``reach``: the farthest a kernel reaches along the view, world
    units; by default the grid kernel's)."""
    cam = scene.camera
    forward = cam.basis()[0]
    order = np.argsort(depth, kind="stable")
    if reach is None:  # a grid: its kernels reach every slab across it
        reach = kernel_depth_reach(scene, forward)
        bounds = slab_bounds(scene, np.asarray(cam.eye, float), forward)  # depths: the same from any origin
    else:
        bounds = occupied_slabs(scene, depth, reach)
    sorted_depth = depth[order]
    first = np.searchsorted(sorted_depth, bounds[:-1] - reach, side="left")
    last = np.searchsorted(sorted_depth, bounds[1:] + reach, side="right")
    return order, [({"u_slab": (float(bounds[k]), float(bounds[k + 1]))}, int(first[k]), int(last[k]))
                   for k in range(len(bounds) - 1)]


def pixel_rectangles(scene, positions: np.ndarray, radius_world) -> tuple[np.ndarray, ...]:
    """``(i0, i1, j0, j1)``: the columns and rows (from the top, inclusive; empty where ``i1 < i0``) of the
    pixels whose centres lie in the screen rectangle of each bounding sphere (world ``positions``,
    ``radius_world`` a number or one per sphere): its tangents through the eye in perspective, every
    pixel where the sphere reaches the eye's plane."""
    cam, img = scene.camera, scene.image
    w, h = img.width, img.height
    forward, right, up = cam.basis()
    p = positions - np.asarray(cam.eye, float)
    x, y, z = p @ right, p @ up, p @ forward
    hx, hy = cam.half_extent(w / h)
    r = radius_world
    if cam.projection == "orthographic":
        nx0, nx1, ny0, ny1 = (x - r) / hx, (x + r) / hx, (y - r) / hy, (y + r) / hy
    else:
        front = z - r > cam.near
        zz = np.where(front, z, 2.0 * r + 1.0)

        def bounds(c):
            root = np.sqrt(np.maximum(c * c + zz * zz - r * r, 0.0))
            den = zz * zz - r * r
            return (c * zz - r * root) / den, (c * zz + r * root) / den

        (bx0, bx1), (by0, by1) = bounds(x), bounds(y)
        nx0, nx1 = np.where(front, bx0 / hx, -2.0), np.where(front, bx1 / hx, 2.0)
        ny0, ny1 = np.where(front, by0 / hy, -2.0), np.where(front, by1 / hy, 2.0)
    # pixel column i has ndc x (i + 0.5) / w * 2 - 1; row j (from the top) ndc y 1 - 2 (j + 0.5) / h
    i0 = np.clip(np.ceil((nx0 + 1.0) * 0.5 * w - 0.5 - 1e-9), 0, w).astype(np.int64)
    i1 = np.clip(np.floor((nx1 + 1.0) * 0.5 * w - 0.5 + 1e-9), -1, w - 1).astype(np.int64)
    j0 = np.clip(np.ceil((1.0 - ny1) * 0.5 * h - 0.5 - 1e-9), 0, h).astype(np.int64)
    j1 = np.clip(np.floor((1.0 - ny0) * 0.5 * h - 0.5 + 1e-9), -1, h - 1).astype(np.int64)
    return i0, i1, j0, j1
