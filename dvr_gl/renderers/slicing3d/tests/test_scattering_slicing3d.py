"""3D texture slicing's single scattering: half-angle slicing and the ray caster's methods on view-aligned
slices against the reference of the same planes, and half-angle slicing's convergence.
"""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.errors import SceneError
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from scattering_scenes import ALBEDO_BY_DEFAULT, LIT, with_column

HALF = {**LIT, "renderer.name": "slicing3d", "renderer.scattering.method": "half_angle",
        "renderer.scattering.light_buffer_size": 32, "image.width": 28, "image.height": 24}  # a pixel: 0.15 %


@pytest.mark.parametrize("extra", [
    {}, {"renderer.scattering.lights": [{"direction": [-0.5, 0.9, 0.3], "intensity": 2.0}]},  # behind: over
    {"camera.projection": "orthographic"}, {"renderer.classification": "pre"},
    {"renderer.classification": "preintegrated"}, {"renderer.gradient_opacity": True},
    {"renderer.scattering.light_buffer_size": 100}, {"renderer.scattering.shadows": False},
    {"renderer.scattering.method": "shadow_rays"}, {"renderer.scattering.method": "light_volume"},
], ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(v, list) else k.split('.')[-1]
                          for k, v in e.items()) or "default")
def test_slicing3d_scattering_matches_its_planes(gl_context, extra):
    """Half-angle slicing against the reference of the same planes and the same light buffer (its
    slices accumulated per pixel, looked up bilinearly): float32 against float64 on all but a
    silhouette pixel or so, where the rasterizer and the reference's clipping decide a slice's edge
    apart (measured at most 2 pixels, 0.3 % of values off by more than 1e-4; conftest's bound 0.5 %);
    the ray caster's methods on view-aligned slices to 3e-6."""
    from conftest import assert_close
    from dvr_gl.renderers.slicing3d.oracle import oracle

    scene = load_scene(None, {**HALF, **extra})
    with registry.plugin("slicing3d").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert image[..., :3].max() > 0.1
    assert_close(image, oracle(scene))


def test_half_angle_converges_to_the_converged_reference(gl_context):
    """Half-angle slicing's error against reference-converged falls at first order as the slices get
    finer and the light buffer larger (a slice's light is what the slices before it left: measured
    5.4e-2, 2.8e-2, 1.4e-2 at 1, 0.5, 0.25 voxel with 16, 32, 64 pixels)."""
    truth = ConvergedReference(load_scene(None, {**HALF, "renderer.converged_tolerance": 1e-5})).render_float64()
    errors = []
    with registry.plugin("slicing3d").create(ctx=gl_context) as renderer:
        for voxels, pixels in ((1.0, 16), (0.5, 32), (0.25, 64)):
            scene = load_scene(None, {**HALF, "renderer.sample_distance_voxels": voxels,
                                      "renderer.scattering.light_buffer_size": pixels})
            errors.append(float(np.sqrt(np.mean((renderer.render(scene) - truth) ** 2))))
    assert errors[0] > 1.6 * errors[1] > 1.6 ** 2 * errors[2]


@pytest.mark.parametrize("lights", [[{"type": "point", "position": [0.0, 0.0, 30.0]}],
                                    [{"direction": [1.0, 0.0, 0.0]}, {"direction": [0.0, 1.0, 0.0]}]])
def test_half_angle_takes_one_directional_light(lights):
    with pytest.raises(SceneError, match="one directional light"):
        load_scene(None, {**HALF, "renderer.scattering.lights": lights})


@pytest.mark.parametrize("method", ["half_angle", "light_volume"])
def test_slicing3d_albedo_column_matches_its_planes(gl_context, method):
    from conftest import assert_close
    from dvr_gl.renderers.slicing3d.oracle import oracle

    scene = load_scene(None, {**with_column(HALF, [0.1, 1.0, 0.4]), **ALBEDO_BY_DEFAULT,
                              "renderer.name": "slicing3d", "renderer.scattering.method": method,
                              "renderer.scattering.light_buffer_size": 32})
    with registry.plugin("slicing3d").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["ALBEDO_TABLE"]
    assert_close(image, oracle(scene))
