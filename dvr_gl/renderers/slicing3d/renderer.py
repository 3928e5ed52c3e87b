"""``slicing3d``: view-aligned planes through a 3D texture (or its bricks), blended back to front.

The planes are perpendicular to the view axis, ``sample_distance`` apart and anchored at the box
centre's depth; each plane's polygon (3 to 6 vertices) is computed per frame, clipped to the
volume box (or to each brick's core box).
"""

from __future__ import annotations

import numpy as np

from ... import limits
from ...gl.geometry import clip_planes, depth_range, slice_polygons
from ...sandbox import check_bytes
from ..grid.slicing import SlicingRenderer, core_box
from ..surfaces import with_surfaces
from . import fields

BYTES_PER_SLICE = 2048  # a slice's polygon (up to 4 triangles, float64) and its clipping's temporaries


class Slicing3DRenderer(SlicingRenderer):
    name = "slicing3d"
    description = "3D texture, view-aligned slices blended back to front (GPU)"

    def draw(self, scene) -> np.ndarray:
        """The frame; several fields through :mod:`.fields` (one pass over the union box, every field sampled
        at each slice's fragment and mixed)."""
        if fields.several(scene):
            return with_surfaces(self, scene, lambda s, surfaces: fields.draw_fields(self, s, surfaces))
        return super().draw(scene)

    def work(self, scene):
        return limits.slice_fragments(scene)

    def check_resources(self, scene):
        super().check_resources(scene)
        slices = limits.samples_per_ray(scene)
        check_bytes(slices * BYTES_PER_SLICE, f"{slices:.3g} slice polygons", limits.SAMPLE_FIX)

    def geometry(self, scene, view) -> np.ndarray:
        """Triangles of the slices within this view's box, back to front, as a flat (N * 3, 3) array."""
        cam = scene.camera
        f, right, up = cam.basis()
        lo, hi = scene.field.box
        d = scene.renderer.sample_distance
        centre = float(((lo + hi) / 2.0 - np.asarray(cam.eye)) @ f)
        near_depth, far_depth = depth_range(cam, *core_box(scene, view))
        near_clip, _ = clip_planes(cam, lo, hi)
        k_lo = int(np.ceil((max(near_depth, near_clip) - centre) / d))
        k_hi = int(np.floor((far_depth - centre) / d))
        if k_hi < k_lo:
            return np.zeros((0, 3))
        depths = centre + np.arange(k_hi, k_lo - 1, -1) * d  # back to front
        box_lo, box_hi = core_box(scene, view)
        if view.brick is not None:
            depths = self._own_planes(scene, view, depths, f)
        tris = slice_polygons(f, depths, box_lo, box_hi, cam.eye, right, up).reshape(-1, 3, 3)
        tris = tris[np.all(np.isfinite(tris), axis=(1, 2))]
        return tris.reshape(-1, 3)

    @staticmethod
    def _own_planes(scene, view, depths, f):
        """A plane lying exactly in a face shared by two bricks belongs to one of them (the lower)."""
        axis = int(np.argmax(np.abs(f)))
        if abs(abs(f[axis]) - 1.0) > 1e-12 or view.brick.last[axis]:
            return depths
        _, hi = view.brick.world_box(scene.volume)
        face = float((hi[axis] - scene.camera.eye[axis]) * f[axis])
        return depths[depths != face]
