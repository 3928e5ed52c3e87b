"""Texture slicing against the reference that samples the same planes, and its behaviour.

Tolerances: the slicers differ from the float64 reference by float32 arithmetic and by the
interpolation of fragment positions across slice polygons; measured on 32x32 images of the 32^3
phantom over the views and classifications below: mean absolute error <= 3.8e-7, max <= 6e-6.
Asserted as for the ray caster: at most 0.5 % of values off by more than 1e-4 (pixels on the box's
silhouette may fall on either side of a polygon edge), mean <= 2e-6 over the others.
"""

import numpy as np
import pytest

from conftest import array_scene, assert_close, small_scene
from dvr_gl.errors import SceneError
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.grid.slicing import reference as slicer_reference

NO_ERT = {"renderer.ert_threshold": 1.0}


@pytest.fixture(scope="module", params=["slicing3d", "slicing2d"])
def slicer(request):
    renderer = create_renderer(request.param)
    yield renderer
    renderer.close()


def same_planes(scene, name):
    return slicer_reference(scene, name).render_float64()


VARIANTS = [{}, {"camera.projection": "orthographic"}, {"renderer.classification": "preintegrated"},
            {"renderer.classification": "preintegrated", "renderer.preintegration": "fast"},
            {"renderer.shading.enabled": True}, {"renderer.gradient_opacity": True},
            {"renderer.filter": "nearest"}, {"renderer.filtering": "shader"},
            {"camera.azimuth": 0.0, "camera.elevation": 0.0},     # exactly along an axis
            {"camera.azimuth": 45.0, "camera.elevation": 35.26},  # along a diagonal
            {"camera.eye": [2.0, -3.0, 1.0], "camera.target": [0.0, 10.0, 0.0]}]  # inside the volume


@pytest.mark.parametrize("extra", VARIANTS, ids=lambda e: "-".join(f"{k.split('.')[-1]}={v}" for k, v in e.items())
                         or "default")
def test_slicers_match_the_same_plane_reference(slicer, extra):
    scene = small_scene({**NO_ERT, **extra})
    reference = same_planes(scene, slicer.name)
    assert reference[..., 3].max() > 0.1
    assert_close(slicer.render(scene), reference)


@pytest.mark.parametrize("extra", [{"renderer.filter": "cubic_bspline"}, {"renderer.filter": "catmull_rom"},
                                   {"renderer.classification": "pre"},
                                   {"renderer.shading.enabled": True, "renderer.gradient": "texture"}],
                         ids=["bspline", "catmull-rom", "pre", "gradient-texture"])
def test_slicing3d_with_every_filter_and_classification(extra):
    with create_renderer("slicing3d") as slicer:
        scene = small_scene({**NO_ERT, **extra})
        assert_close(slicer.render(scene), same_planes(scene, "slicing3d"))


@pytest.mark.parametrize("extra", [{"renderer.filter": "cubic_bspline"}, {"renderer.classification": "pre"},
                                   {"renderer.shading.enabled": True, "renderer.gradient": "texture"}])
def test_slicing2d_refuses_what_stacks_cannot_do(extra):
    with create_renderer("slicing2d") as slicer, pytest.raises(SceneError, match="slicing2d"):
        slicer.render(small_scene(extra))


@pytest.mark.parametrize("extra, message", [
    ({"renderer.compositing": "mip"}, "does not support renderer.compositing = 'mip' .it takes emission_absorption"),
    ({"renderer.jitter": True}, "does not support renderer.jitter; turn it off or use raycast, reference or "
                                "reference-converged"),
])
def test_slicers_refuse_other_compositing_and_jitter(slicer, extra, message):
    with pytest.raises(SceneError, match=message):
        slicer.render(small_scene(extra))


@pytest.mark.parametrize("extra", [{}, {"renderer.classification": "preintegrated"},
                                   {"renderer.shading.enabled": True},
                                   {"camera.azimuth": 0.0, "camera.elevation": 0.0,
                                    "camera.projection": "orthographic"},
                                   # slabs 5 voxels long: the next slice lies beyond the default ghost
                                   # (3 voxels); the bricks get more (it once read clamped voxels: 0.3 off)
                                   {"renderer.classification": "preintegrated",
                                    "renderer.sample_distance_voxels": 5.0}],
                         ids=["default", "preintegrated", "shaded", "axis-aligned", "long-slabs"])
def test_bricked_equals_unbricked(slicer, extra):
    """Bricks drawn back to front, each with its own slices: the same image to rounding.  Splitting a
    slice's polygon among bricks changes how fragment positions are interpolated across triangles
    (float32), which shading's gradients amplify: measured max 8.5e-6 (slicing2d, shaded), asserted 2e-5."""
    scene = small_scene({**NO_ERT, **extra})
    whole = slicer.render(scene)
    bricked = slicer.render(scene.with_renderer(texture_budget_mb=1 / 16))
    assert slicer.stats["bricks"] >= 4
    assert np.abs(bricked - whole).max() <= 2e-5, np.abs(bricked - whole).max()


def test_slice_spacing_converges_to_the_converged_reference():
    """More slices, smaller error: 3D slicing approaches the converged integral (second order)."""
    converged = ConvergedReference(small_scene({**NO_ERT, "renderer.converged_tolerance": 1e-6})).render_float64()
    errors = []
    with create_renderer("slicing3d") as slicer:
        for d in (1.0, 0.5, 0.25):
            image = slicer.render(small_scene({**NO_ERT, "renderer.sample_distance_voxels": d}))
            errors.append(np.sqrt(np.mean((image - converged) ** 2)))
    assert errors[0] > 2.5 * errors[1] > 6 * errors[2]


def test_stack_switch_changes_the_picture_at_45_degrees():
    """2D stacks switch axis where the view crosses 45 degrees: just before and after, the slices
    differ though the views barely do.  3D slicing changes smoothly there."""
    images = {}
    for name in ("slicing2d", "slicing3d"):
        with create_renderer(name) as slicer:
            images[name] = [slicer.render(small_scene({**NO_ERT, "camera.azimuth": az, "camera.elevation": 0.0}))
                            for az in (44.9, 45.1)]
    jump = {name: np.abs(a - b).mean() for name, (a, b) in images.items()}
    assert jump["slicing2d"] > 5 * jump["slicing3d"]


def test_one_voxel_thick_volume(tmp_path, slicer):
    scene = array_scene(tmp_path, np.full((1, 6, 6), 0.5, np.float32), {
        "transfer_function.points": [[0, 1, 1, 1, 0.7], [1, 1, 1, 1, 0.7]],
        "transfer_function.opacity_model": "extinction",
        **NO_ERT, "camera.elevation": 60.0, "image.width": 12, "image.height": 12})
    image = slicer.render(scene)
    assert np.all(np.isfinite(image)) and image[..., 3].max() > 0.05
    assert_close(image, same_planes(scene, slicer.name))
