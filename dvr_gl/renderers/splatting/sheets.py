"""Which splats go into which sheet buffer, in what order: image-aligned slabs (Mueller and
Crawfis) and voxel planes (Westover), shared by the renderer and its oracle.

A schedule is the splats' order (a permutation, uploaded in that order) and one ``(uniforms,
first, last)`` per sheet, front to back: the sheet's shader uniforms and its contiguous range of
splats.
"""

from __future__ import annotations

import math

import numpy as np

from ...gl.geometry import box_corners
from ...model import CLASSIFIED_ALONG_RAY, GAUSSIAN_RADIUS
from ...reference.plans import stack_axis
from .splats import slabs, support_depth


def kernel_radius(scene) -> float:
    """The kernel's support, voxels."""
    return GAUSSIAN_RADIUS * scene.renderer.kernel_width


def pre_classified(scene) -> bool:
    r = scene.renderer
    return r.compositing in CLASSIFIED_ALONG_RAY and r.classification == "pre"


def culled_post(scene) -> bool:
    """Post-classified emission-absorption or X-ray in image-aligned sheets: culled by regions
    (:func:`.splats.post_visibility`, whose bound holds for a slab's part of a ray; an axis-aligned
    sheet's kernels reach the whole ray)."""
    r = scene.renderer
    return (r.compositing in CLASSIFIED_ALONG_RAY and r.classification == "post" and r.sheet_buffer == "image_aligned"
            and is_grid(scene))


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
    lo, hi = scene.field.bounds
    depths = (box_corners(lo, hi) - eye) @ forward
    width = scene.renderer.slab_width * scene.field.sample_spacing
    return slabs(max(float(depths.min()), scene.camera.near), float(depths.max()), width)


def slab_schedule(scene, depth: np.ndarray, reach: float | None = None):
    """Image-aligned slabs: the splats by view depth of their centres (``depth``), each slab with the
    range whose kernels reach into it (``reach``: the farthest a kernel reaches along the view, world
    units; by default the grid kernel's)."""
    cam = scene.camera
    forward = cam.basis()[0]
    order = np.argsort(depth, kind="stable")
    bounds = slab_bounds(scene, np.asarray(cam.eye, float), forward)  # depths: the same from any origin
    if reach is None:
        reach = support_depth(kernel_radius(scene), scene.volume.spacing, forward)
    sorted_depth = depth[order]
    first = np.searchsorted(sorted_depth, bounds[:-1] - reach, side="left")
    last = np.searchsorted(sorted_depth, bounds[1:] + reach, side="right")
    return order, [({"u_slab": (float(bounds[k]), float(bounds[k + 1]))}, int(first[k]), int(last[k]))
                   for k in range(len(bounds) - 1)]
