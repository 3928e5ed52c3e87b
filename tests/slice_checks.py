"""The checks every texture slicer passes (the grid kit's slices, :mod:`dvr_gl.renderers.grid.slicing`),
run by each slicer's own tests (``dvr_gl/renderers/NAME/tests/test_NAME.py``) on its renderer.

Tolerances: the slicers differ from the float64 reference by float32 arithmetic and by the
interpolation of fragment positions across slice polygons; measured on 32x32 images of the 32^3
phantom over the views and classifications below: mean absolute error <= 3.8e-7, max <= 6e-6.
Asserted as for the ray caster: at most 0.5 % of values off by more than 1e-4 (pixels on the box's
silhouette may fall on either side of a polygon edge), mean <= 2e-6 over the others.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import array_scene, assert_close, small_scene
from dvr_gl.errors import SceneError
from dvr_gl.gl.context import make_current
from dvr_gl.renderers import create_renderer, registry
from judges import renderers

NO_ERT = {"renderer.ert_threshold": 1.0}


def slicer_on(ctx, name):
    """The slicer ``name`` on the session's context, made current (an earlier test may have left none)."""
    return create_renderer(name, ctx=make_current(ctx))


def same_planes(scene, name):
    """The slicer's oracle: the float64 reference that samples the same planes."""
    return registry.plugin(name).oracle_image(scene)


VARIANTS = [{}, {"camera.projection": "orthographic"}, {"renderer.classification": "preintegrated"},
            {"renderer.classification": "preintegrated", "renderer.preintegration": "fast"},
            {"renderer.shading.enabled": True}, {"renderer.gradient_opacity": True},
            {"renderer.filter": "nearest"}, {"renderer.filtering": "shader"},
            {"camera.azimuth": 0.0, "camera.elevation": 0.0},     # exactly along an axis
            {"camera.azimuth": 45.0, "camera.elevation": 35.26},  # along a diagonal
            {"camera.eye": [2.0, -3.0, 1.0], "camera.target": [0.0, 10.0, 0.0]}]  # inside the volume
VARIANT_IDS = ["-".join(f"{k.split('.')[-1]}={v}" for k, v in e.items()) or "default" for e in VARIANTS]


def matches_the_same_plane_reference(slicer, extra):
    scene = small_scene({**NO_ERT, **extra})
    reference = same_planes(scene, slicer.name)
    assert reference[..., 3].max() > 0.1
    assert_close(slicer.render(scene), reference)


def _either(names):
    return ", ".join(names[:-1]) + " or " + names[-1]


REFUSALS = [
    ({"renderer.compositing": "mip"}, "does not support renderer.compositing = 'mip' .it takes emission_absorption"),
    ({"renderer.jitter": True}, f"does not support renderer.jitter; turn it off or use {_either(renderers('jitter'))}"),
]


def refuses(slicer, extra, message):
    with pytest.raises(SceneError, match=message):
        slicer.render(small_scene(extra))


BRICKED = {"default": {}, "preintegrated": {"renderer.classification": "preintegrated"},
           "shaded": {"renderer.shading.enabled": True},
           "axis-aligned": {"camera.azimuth": 0.0, "camera.elevation": 0.0, "camera.projection": "orthographic"},
           # slabs 5 voxels long: the next slice lies beyond the default ghost (3 voxels); the bricks get
           # more (it once read clamped voxels: 0.3 off)
           "long-slabs": {"renderer.classification": "preintegrated", "renderer.sample_distance_voxels": 5.0}}


def bricked_equals_unbricked(slicer, extra):
    """Bricks drawn back to front, each with its own slices: the same image to rounding.  Splitting a
    slice's polygon among bricks changes how fragment positions are interpolated across triangles
    (float32), which shading's gradients amplify: measured max 8.5e-6 (2D stacks, shaded), asserted 2e-5."""
    scene = small_scene({**NO_ERT, **extra})
    whole = slicer.render(scene)
    bricked = slicer.render(scene.with_renderer(texture_budget_mb=1 / 16))
    assert slicer.stats["bricks"] >= 4
    assert np.abs(bricked - whole).max() <= 2e-5, np.abs(bricked - whole).max()


def one_voxel_thick_volume(tmp_path, slicer):
    scene = array_scene(tmp_path, np.full((1, 6, 6), 0.5, np.float32), {
        "transfer_function.points": [[0, 1, 1, 1, 0.7], [1, 1, 1, 1, 0.7]],
        "transfer_function.opacity_model": "extinction",
        **NO_ERT, "camera.elevation": 60.0, "image.width": 12, "image.height": 12})
    image = slicer.render(scene)
    assert np.all(np.isfinite(image)) and image[..., 3].max() > 0.05
    assert_close(image, same_planes(scene, slicer.name))
