"""The ray caster's depth image (shaders/depth.glsl) against the float64 judge's (dvr_gl.reference.depth), which
samples the same segments: what differs is float32 arithmetic, and where a ray's optical depth reaches ln 2 within
rounding of a segment's end, or two samples tie for the maximum, the two may choose neighbouring segments (a
sample distance apart at most: the discretisation bounds every difference).

Measured on the 32^3 phantom (llvmpipe), relative to the depth: at most 5.5e-6 (orthographic, the eye 83 away:
4.6e-4 world units), 1.8e-6 in perspective (depths about 4), 2.6e-7 for MIP, MinIP and the isosurface; no pixel
in another segment, and the pixels with no depth the same.  The crossing's error is the float32 optical depth's
(summed over about a hundred segments) over the extinction there.  Held to 1e-5 of the depth, with one pixel
or 0.5 % of them (whichever is more) allowed anywhere within one sample distance, and as many with a depth on
one side only."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import small_scene
from dvr_gl.errors import SceneError
from dvr_gl.reference.depth import depth_image
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry

CASES = [
    {}, {"renderer.acceleration": "on"}, {"renderer.acceleration": "off"}, {"renderer.jitter": True},
    {"renderer.classification": "preintegrated", "renderer.preintegration_size": 64},
    {"renderer.shading.enabled": True, "renderer.gradient_opacity": True},
    {"renderer.compositing": "xray"}, {"renderer.compositing": "mip"}, {"renderer.compositing": "minip"},
    {"renderer.compositing": "isosurface", "renderer.iso_value": 0.25}, {"camera.projection": "orthographic"},
    {"renderer.clipping": {"planes": [[0.0, 0.0, 1.0, 0.2]]}},
    {"camera.eye": [0.0, -0.3, 0.1], "camera.target": [0.0, 8.0, 0.1]},  # inside the volume
]


def scene_of(extra):
    return small_scene({"renderer.name": "raycast", "renderer.ert_threshold": 1.0, "transfer_function.points": [
        [0.0, 0.1, 0.2, 0.9, 0.0], [0.15, 0.9, 0.6, 0.2, 0.0], [1.0, 1.0, 0.9, 0.8, 0.9]], **extra})


def reference_depth(scene) -> np.ndarray:
    ref = DiscreteReference(scene)
    ref.render()
    return depth_image(ref)


@pytest.mark.parametrize("extra", CASES, ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(
    v, (list, dict)) else k.split(".")[-1] for k, v in e.items()) or "default")
def test_depth_image_matches_the_judge(gl_context, extra):
    scene = scene_of(extra)
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        renderer.want_depth = True
        renderer.render(scene)
        assert "DEPTH" in renderer.stats["defines"]
        gpu = renderer.depth
    judge = reference_depth(scene)
    assert gpu.shape == judge.shape == (32, 32) and np.isfinite(judge).sum() > 50
    both = np.isfinite(gpu) & np.isfinite(judge)
    allowed = max(1, int(0.005 * gpu.size))
    assert np.sum(np.isfinite(gpu) != np.isfinite(judge)) <= allowed
    err = np.abs(gpu[both].astype(np.float64) - judge[both])
    off = err > 1e-5 * np.abs(judge[both])
    assert np.sum(off) <= allowed, f"{np.sum(off)} pixels off by more than 1e-5 of the depth (max {err.max():.3g})"
    assert err.max() <= scene.renderer.sample_distance * 1.001


def test_no_depth_unless_asked(gl_context):
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        renderer.render(scene_of({}))
        assert "DEPTH" not in renderer.stats["defines"] and renderer.depth is None


@pytest.mark.parametrize("extra, words", [({"renderer.order": "back_to_front"}, "front_to_back"),
                                          ({"renderer.texture_budget_mb": 0.004}, "one pass")])
def test_refusals_in_one_line(gl_context, extra, words):
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        renderer.want_depth = True
        with pytest.raises(SceneError, match=words):
            renderer.render(scene_of(extra))


@pytest.mark.parametrize("height, depth", [(1.5, 8.5), (0.8, 9.2)])
def test_an_opaque_mesh_gives_its_depth_where_the_volume_does_not(tmp_path, gl_context, height, depth):
    """The slab (z in [0, 1], extinction 1.3, seen from z = 10) with a square at ``height``: in front of the slab
    the rays end at the square; inside it (0.2 deep, opacity 0.23 < 1/2) the volume never reaches one half. Both
    ways the pixels over the square have the square's depth (float64, rounded to float32), the others the
    slab's ln 2 / 1.3 past its face."""
    from slab_scenes import meshed_slab_scene, square

    scene = meshed_slab_scene(tmp_path, "raycast", [{"path": square(tmp_path / "square.obj", height)}])
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        renderer.want_depth = True
        renderer.render(scene)
        gpu = renderer.depth
    judge = reference_depth(scene)
    origins, _ = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    over = ((np.abs(origins[:, 0] - 2.0) < 0.75) & (np.abs(origins[:, 1] - 2.0) < 0.75)).reshape(gpu.shape)
    np.testing.assert_allclose(judge[over], depth, rtol=0, atol=1e-6)  # float32 rounding of the image
    np.testing.assert_allclose(judge[~over], 9.0 + np.log(2.0) / 1.3, rtol=0, atol=1e-6)
    np.testing.assert_allclose(gpu, judge, rtol=1e-5)
