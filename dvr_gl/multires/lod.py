"""Level of detail by screen-space error: per brick, the coarsest level whose voxel projects to at most
``pixel_error`` pixels.

The projected size of one voxel of a level (its largest spacing, world units) where the brick comes
nearest the eye: perspective, ``spacing * H / (2 tan(fov / 2) d)`` pixels for an image ``H`` pixels
high and the distance ``d`` from the eye to the brick's nearest point (exact on the view axis; off axis
the image plane magnifies a little more, by up to ``1 / cos`` of the ray's angle to the axis, within
the tolerance the ``pixel_error`` leaves); orthographic, ``spacing * H / view_height``, the same
everywhere.  A brick with the eye inside (``d = 0``) gets level 0.  The camera must be in the volume's
own frame, as the bricks are (:func:`dvr_gl.orientation.volume_frame_scene`).
"""

from __future__ import annotations

import numpy as np


def voxel_pixels(level, camera, height: int, distance: float) -> float:
    """Pixels one voxel of ``level`` (its largest spacing) spans at ``distance`` from the eye (world
    units; ignored when orthographic) in an image ``height`` pixels high; infinite at distance 0."""
    _, half_h = camera.half_extent(1.0)
    size = max(level.spacing)
    if camera.projection == "orthographic":
        return size * height / (2.0 * half_h)
    if distance <= 0:
        return float("inf")
    return size * height / (2.0 * half_h * distance)


def nearest_distance(box, eye) -> float:
    """Distance from ``eye`` to the nearest point of the box ``(lo, hi)`` (0 inside)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in box)
    eye = np.asarray(eye, dtype=np.float64)
    return float(np.linalg.norm(eye - np.clip(eye, lo, hi)))


def choose_levels(bricks, levels, camera, width: int, height: int, pixel_error: float = 1.0) -> list[int]:
    """The level of each brick: the coarsest of ``levels`` (level 0, the full resolution, first; then
    coarser, as ``[volume, *volume.levels]``) whose voxel projects to at most ``pixel_error`` pixels
    at the brick's point nearest the eye; level 0 when none does or the eye is inside the brick.
    Bricks (:class:`~dvr_gl.renderers.grid.bricking.Brick`) index level 0's voxels."""
    del width  # square pixels: the image's height and the vertical field of view set their size
    if pixel_error <= 0:
        raise ValueError(f"pixel_error must be positive, got {pixel_error}")
    full = levels[0]
    chosen = []
    for brick in bricks:
        distance = nearest_distance(brick.world_box(full), camera.eye)
        level = 0
        if distance > 0 or camera.projection == "orthographic":
            for index, candidate in enumerate(levels):
                if voxel_pixels(candidate, camera, height, distance) <= pixel_error:
                    level = index
        chosen.append(level)
    return chosen
