"""Which bricks a bricked frame draws, and from which level: empty bricks left out, coarser levels by
screen-space error.

* **Empty bricks.** A volume read out of core (:mod:`dvr_gl.out_of_core`) knows the value range of
  each block of its voxels without reading them; a brick whose texture's values (ghosts included)
  all classify to zero extinction composites nothing in emission-absorption and the X-ray, so it is
  neither read nor uploaded nor drawn.  "All": the exact transfer function over the range widened to
  the table nodes the GPU interpolates (the lookup table's and the pre-integration table's), so the
  image is the one drawing the brick would give, bit for bit.
* **Levels.** A volume with coarser levels (an OME-Zarr multiscale, ``dvr pyramid``) draws each brick
  from the coarsest level whose voxel projects to at most ``renderer.screen_space_error`` pixels at
  the brick's point nearest the eye (:func:`dvr_gl.multires.lod.choose_levels`); the samples, their
  step and their owner (level 0's brick cores) stay the same, only the voxels sampled change.
"""

from __future__ import annotations

import numpy as np

from ...renderers.raycast.acceleration import snapped

__all__ = ["frame_views", "transparent"]


def transparent(tf, vmin: float, vmax: float, grids) -> bool:
    """Does every value in ``[vmin, vmax]``, widened to each ``(domain, nodes)`` of ``grids`` (the
    tables the GPU interpolates), classify to zero extinction?  The transfer function is piecewise
    linear between its points: its largest extinction over an interval is at the ends or a point."""
    lo, hi = float(vmin), float(vmax)
    for domain, nodes in grids:
        a, b = snapped(np.array([vmin]), np.array([vmax]), domain, nodes)
        lo, hi = min(lo, float(a[0])), max(hi, float(b[0]))
    xs = tf.points[:, 0]
    values = np.concatenate([[lo, hi], xs[(xs > lo) & (xs < hi)]])
    return float(np.max(tf.extinction(values))) == 0.0


def frame_views(renderer, scene, defines: dict, views: list) -> tuple[list, dict]:
    """The frame's brick views: empty ones left out (volumes read out of core, emission-absorption and
    X-ray), each of the others from its level (volumes with levels); and the frame's stats of both."""
    volume, r, tf = scene.volume, scene.renderer, scene.transfer_function
    stats = {}
    ranges = getattr(volume, "ranges", None)
    if ranges is not None and "COMPOSITE_EMISSION" in defines:
        domain = tf.tabulate(2).domain  # the tables' (a one-point function's widened)
        grids = [(domain, r.lut_size)] + ([(domain, r.preintegration_size)]
                                          if "CLASSIFY_PREINTEGRATED" in defines else [])
        kept = [v for v in views if not transparent(tf, *ranges.range_of(v.brick.tex_lo, v.brick.tex_dims), grids)]
        stats["bricks_empty"] = len(views) - len(kept)
        views = kept
    if volume.levels and views:
        from ...multires.lod import choose_levels

        chosen = [0] * len(views)  # screen_space_error 0: always the finest
        if r.screen_space_error > 0:
            chosen = choose_levels([v.brick for v in views], [volume, *volume.levels], scene.camera,
                                   scene.image.width, scene.image.height, r.screen_space_error)
        views = [renderer.level_view(scene, v, k) for v, k in zip(views, chosen)]
        stats["brick_levels"] = np.bincount(np.asarray(chosen, dtype=int), minlength=len(volume.levels) + 1).tolist()
    return views, stats
