"""Behaviour of the same-discretization and converged references beyond closed forms."""

import math

import numpy as np
import pytest

from conftest import array_scene, small_scene
from dvr_gl.image import compare_images
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from judges import renderers

NO_ERT = {"renderer.ert_threshold": 1.0}


@pytest.mark.parametrize("extra", [{}, {"renderer.shading.enabled": True},
                                   {"renderer.classification": "pre"}, {"renderer.jitter": True}])
def test_back_to_front_equals_front_to_back(extra):
    front = DiscreteReference(small_scene({**NO_ERT, **extra})).render_float64()
    back = DiscreteReference(small_scene({**NO_ERT, **extra, "renderer.order": "back_to_front"})).render_float64()
    assert front[..., 3].max() > 0.5
    np.testing.assert_allclose(back, front, rtol=0, atol=1e-12)  # float64 rounding only


@pytest.mark.parametrize("threshold", [0.5, 0.9, 0.99])
def test_early_ray_termination_error_is_bounded_by_one_minus_threshold(threshold):
    overrides = {"transfer_function.points": [[0, 1, 1, 1, 0], [0.15, 0.2, 0.5, 1, 0.6], [1, 1, 0.8, 0.5, 0.6]],
                 "volume.size": 24}
    full_ref = DiscreteReference(small_scene({**overrides, **NO_ERT}))
    full = full_ref.render_float64()
    ert_ref = DiscreteReference(small_scene({**overrides, "renderer.ert_threshold": threshold}))
    ert = ert_ref.render_float64()
    # what is skipped lies behind accumulated opacity >= threshold: at most 1 - threshold
    assert np.abs(ert - full).max() <= 1 - threshold + 1e-12
    assert ert_ref.samples < full_ref.samples
    stopped = ert[..., 3] < full[..., 3] - 1e-12
    assert stopped.any() and np.all(ert[..., 3][stopped] >= threshold)


def test_same_discretization_converges_to_the_converged_reference():
    """Linear filter: the midpoint rule's error falls like d^2 (measured RMS ratios 16.6 and 15.0
    per 4x smaller step; asserted > 8)."""
    base = {**NO_ERT, "renderer.lut_size": 1 << 16, "renderer.converged_tolerance": 1e-7}
    converged = ConvergedReference(small_scene(base)).render_float64()
    errors = []
    for d in (0.4, 0.1, 0.025):
        img = DiscreteReference(small_scene({**base, "renderer.sample_distance_voxels": d})).render_float64()
        errors.append(np.sqrt(np.mean((img - converged) ** 2)))
    assert errors[0] > 8 * errors[1] > 64 * errors[2]


@pytest.mark.parametrize("mode", ["average", "mip", "minip"])
@pytest.mark.parametrize("filter_kind", ["nearest", "linear", "catmull_rom"])
def test_projections_approach_the_converged_reference(mode, filter_kind):
    base = {"renderer.compositing": mode, "renderer.filter": filter_kind, "renderer.lut_size": 1 << 16,
            "transfer_function.preset": "grayscale"}
    converged = ConvergedReference(small_scene(base)).render_float64()
    coarse = DiscreteReference(small_scene({**base, "renderer.sample_distance_voxels": 0.5})).render_float64()
    fine = DiscreteReference(small_scene({**base, "renderer.sample_distance_voxels": 0.02})).render_float64()
    err_fine = np.abs(fine - converged).mean()
    assert err_fine <= np.abs(coarse - converged).mean()
    # grazing rays can still miss a thin extremum between samples; on average the fine step is close
    assert err_fine < 2e-4


def test_isosurface_refinement_approaches_the_exact_hit():
    """Bisection halves the bracket per step: the shaded colour at the hit converges to the exact
    (converged) one.  Measured median errors: 4e-4 (0 steps), 2e-7 (5), 2e-10 (10), 2e-16 (20).
    A few pixels (4 of 251) hit a different surface: their first crossing is thinner than a
    sample step; those are excluded by taking the 95th percentile."""
    base = {"renderer.compositing": "isosurface", "renderer.iso_value": 0.3, "renderer.shading.enabled": True,
            "image.width": 48, "image.height": 48}
    exact = ConvergedReference(small_scene(base)).render_float64()
    errors = {}
    for steps in (0, 10, 20):
        img = DiscreteReference(small_scene({**base, "renderer.iso_refinement": steps})).render_float64()
        both = (img[..., 3] == 1) & (exact[..., 3] == 1)
        assert np.mean(img[..., 3] != exact[..., 3]) < 0.01  # the same pixels hit, but for grazing ones
        errors[steps] = np.percentile(np.abs(img[both] - exact[both]).max(axis=1), 95)
    assert errors[0] > 1e-3
    assert errors[10] < errors[0] * 1e-4
    assert errors[20] < 1e-12


def test_camera_inside_a_homogeneous_volume(tmp_path):
    data = np.ones((9, 9, 9), np.float32)
    sigma = 0.2
    overrides = {"transfer_function.points": [[0, 1, 1, 1, sigma], [2, 1, 1, 1, sigma]],
                 "transfer_function.opacity_model": "extinction", "camera.eye": [4.0, 3.0, 5.0],
                 "camera.target": [4.0, 9.0, 5.0], "camera.fov": 60.0, "image.width": 9, "image.height": 7,
                 **NO_ERT, "renderer.sample_distance": 0.3}
    scene = array_scene(tmp_path, data, overrides)
    o, d = scene.camera.pixel_rays(9, 7)
    # from the eye to the far face (y = 8) or a side face, whichever comes first
    with np.errstate(divide="ignore"):
        exits = np.min(np.where(d > 0, (8.0 - o) / d, np.where(d < 0, -o / d, np.inf)), axis=1)
    expected = -np.expm1(-sigma * exits).reshape(7, 9)
    for img in (DiscreteReference(scene).render_float64(), ConvergedReference(scene).render_float64()):
        np.testing.assert_allclose(img[..., 3], expected, rtol=1e-12)


def test_one_voxel_thick_and_single_voxel_volumes(tmp_path):
    sigma = 0.7
    tf = {"transfer_function.points": [[0, 1, 1, 1, sigma], [9, 1, 1, 1, sigma]],
          "transfer_function.opacity_model": "extinction", **NO_ERT,
          "camera.projection": "orthographic", "camera.azimuth": 0.0, "camera.elevation": 90.0,
          "image.width": 4, "image.height": 4}
    slab = array_scene(tmp_path, np.full((1, 4, 4), 5.0, np.float32), {**tf, "camera.view_height": 2.0},
                       spacing=(1.0, 1.0, 0.25))
    for img in (DiscreteReference(slab).render_float64(), ConvergedReference(slab).render_float64()):
        np.testing.assert_allclose(img[..., 3], -math.expm1(-sigma * 0.25), rtol=1e-12)  # thickness: one spacing
    voxel = array_scene(tmp_path, np.full((1, 1, 1), 5.0, np.float32), {**tf, "camera.view_height": 0.5},
                        spacing=(1.0, 1.0, 2.0))
    img = DiscreteReference(voxel).render_float64()
    np.testing.assert_allclose(img[..., 3], -math.expm1(-sigma * 2.0), rtol=1e-12)


def test_rays_grazing_a_face_see_the_closed_box(tmp_path):
    """Orthographic rays along x whose centres lie exactly on the faces y = 0 and y = 2."""
    sigma = 0.5
    overrides = {"transfer_function.points": [[0, 1, 1, 1, sigma], [1, 1, 1, 1, sigma]],
                 "transfer_function.opacity_model": "extinction", **NO_ERT,
                 "camera.projection": "orthographic", "camera.eye": [-5.0, 1.0, 1.0], "camera.target": [0.0, 1.0, 1.0],
                 "camera.view_height": 2.0, "image.width": 3, "image.height": 3}
    scene = array_scene(tmp_path, np.ones((3, 3, 5), np.float32), overrides)  # box x in [0, 4]
    for img in (DiscreteReference(scene).render_float64(), ConvergedReference(scene).render_float64()):
        assert np.all(np.isfinite(img))
        np.testing.assert_allclose(img[..., 3], -math.expm1(-sigma * 4.0), rtol=1e-12)


@pytest.mark.parametrize("dtype, lo, hi", [(np.uint16, 0, 65535), (np.int16, -32768, 32767),
                                           (np.float32, 1e-30, 1e30), (np.float32, -1e30, 1e30)])
def test_extreme_data_ranges_stay_finite(tmp_path, dtype, lo, hi):
    rng = np.random.default_rng(0)
    data = rng.choice(np.array([lo, hi], dtype=dtype), size=(6, 6, 6))
    overrides = {"transfer_function.points": [[float(lo), 0, 0, 1, 0.0], [float(hi), 1, 0.5, 0, 0.5]],
                 "image.width": 12, "image.height": 12}
    for mode in ("emission_absorption", "mip", "average"):
        scene = array_scene(tmp_path, data, {**overrides, "renderer.compositing": mode})
        for img in (DiscreteReference(scene).render_float64(), ConvergedReference(scene).render_float64()):
            assert np.all(np.isfinite(img)) and img[..., 3].max() > 0.1


def test_jitter_is_deterministic_per_seed_and_unbiased():
    base = {"renderer.jitter": True, "renderer.sample_distance_voxels": 1.0, **NO_ERT}
    a = DiscreteReference(small_scene(base)).render_float64()
    np.testing.assert_array_equal(a, DiscreteReference(small_scene(base)).render_float64())
    b = DiscreteReference(small_scene({**base, "renderer.jitter_seed": 1})).render_float64()
    assert not np.array_equal(a, b)
    # averaged over many seeds, jittered sampling of 1 voxel approaches a fine midpoint sampling
    fine = DiscreteReference(small_scene({**NO_ERT, "renderer.sample_distance_voxels": 0.05})).render_float64()
    mean = np.mean([DiscreteReference(small_scene({**base, "renderer.jitter_seed": s})).render_float64()
                    for s in range(16)], axis=0)
    mid = DiscreteReference(small_scene({**NO_ERT, "renderer.sample_distance_voxels": 1.0})).render_float64()
    assert compare_images(mean, fine)["rms"] < compare_images(mid, fine)["rms"]


@pytest.mark.parametrize("classification", ["post", "pre"])
def test_xray_mixes_colours_by_extinction(tmp_path, classification):
    """The X-ray (absorption only): alpha ``1 - exp(-tau)``, colour alpha times the extinction-weighted
    mean colour.  Data ``= x``, a colour linear in the value and constant extinction: along each chord
    the mean colour is the colour of the mean value.  Both references, post- and pre-classified
    (linear transfer function and linear data: the same field), to 1e-9 (measured 5.6e-16)."""
    sigma = 0.4
    x = np.arange(9, dtype=np.float32)
    data = np.broadcast_to(x, (6, 7, 9)).copy()
    colour = lambda v: np.stack([v / 8.0, 1.0 - v / 8.0, np.full_like(v, 0.5)], axis=-1)  # noqa: E731
    overrides = {"transfer_function.points": [[0, 0, 1, 0.5, sigma], [8, 1, 0, 0.5, sigma]],
                 "transfer_function.opacity_model": "extinction", "renderer.compositing": "xray",
                 "renderer.classification": classification, "renderer.lut_size": 1 << 16,
                 "renderer.sample_distance_voxels": 0.01, "renderer.converged_tolerance": 1e-10,
                 "camera.azimuth": 30.0, "camera.elevation": 20.0, "image.width": 12, "image.height": 10}
    scene = array_scene(tmp_path, data, overrides)
    o, d = scene.camera.pixel_rays(12, 10)
    from dvr_gl.rays import intersect_box
    t0, t1 = intersect_box(o, d, *scene.field.bounds)
    hit = t1 > t0
    mean = (o[:, 0] + 0.5 * (t0 + t1) * d[:, 0])[hit]
    alpha = -np.expm1(-sigma * (t1 - t0)[hit])
    expected = np.zeros((120, 4))
    expected[hit, :3] = colour(mean) * alpha[:, None]
    expected[hit, 3] = alpha
    assert hit.mean() > 0.3
    converged = ConvergedReference(scene).render_float64().reshape(-1, 4)
    np.testing.assert_allclose(converged, expected, atol=1e-9)
    # the same samples' sums: the midpoint rule is exact for the linear field, the table's interpolation
    # of the linear function too, up to float64 sums over 1e3 samples
    discrete = DiscreteReference(scene).render_float64().reshape(-1, 4)
    np.testing.assert_allclose(discrete, expected, atol=1e-9)


def test_xray_refuses_preintegration_and_the_renderers_without_it():
    from dvr_gl.errors import SceneError
    from dvr_gl.renderers import registry

    with pytest.raises(SceneError, match="preintegrated does not apply to xray"):
        small_scene({"renderer.compositing": "xray", "renderer.classification": "preintegrated"})
    without = next(n for n in renderers(kind="grid", gl=True)
                   if "xray" not in registry.plugin(n).choices("compositing"))
    reason = registry.refusal(small_scene({"renderer.compositing": "xray", "renderer.shading.enabled": False}),
                              without)
    assert "xray" in reason and renderers("compositing", "xray", gl=True)[0] in reason


@pytest.mark.parametrize("compositing", ["average", "xray"])
def test_depth_cue_weights_by_depth(tmp_path, compositing):
    """renderer.depth_cue (conventions): a weight 1 at the box's nearest depth and depth_cue at its
    farthest, linear between.  A constant volume seen along an axis, orthographic: every chord spans
    the box's depth, so its mean weight is (1 + depth_cue) / 2: the average's value (X-ray: the colour)
    is scaled by it, the X-ray's opacity unchanged.  reference-converged to 1e-9 (measured 1e-15)."""
    from dvr_gl.transfer_function import projected_rgba, xray_rgba

    value, sigma, cue = 0.6, 0.4, 0.25
    data = np.full((5, 6, 7), value, np.float32)
    scene = array_scene(tmp_path, data, {"transfer_function.points": [[0, 0.9, 0.5, 0.2, 0],
                                                                      [1, 0.9, 0.5, 0.2, sigma / value]],
                                         "transfer_function.opacity_model": "extinction",
                                         "renderer.compositing": compositing,
                                         "renderer.classification": "pre", "renderer.depth_cue": cue,
                                         "camera.projection": "orthographic", "camera.azimuth": 0.0,
                                         "camera.elevation": 0.0, "camera.view_height": 3.0,
                                         "image.width": 8, "image.height": 8, "renderer.converged_tolerance": 1e-10})
    image = ConvergedReference(scene).render_float64().reshape(-1, 4)
    o, d = scene.camera.pixel_rays(8, 8)
    from dvr_gl.rays import intersect_box
    t0, t1 = intersect_box(o, d, *scene.field.bounds)
    hit = t1 > t0
    assert hit.all()
    mean_weight = (1.0 + cue) / 2.0
    if compositing == "average":
        expected = projected_rgba(scene.transfer_function, np.full(hit.sum(), value * mean_weight))
    else:
        tau = sigma * (t1 - t0)
        expected = xray_rgba(np.array([0.9, 0.5, 0.2]) * (tau * mean_weight)[:, None], tau)
    np.testing.assert_allclose(image, expected, atol=1e-9)


def test_hemispherical_shading_of_a_constant_is_its_ambient_part(tmp_path):
    """renderer.hemispherical_shading: ambient E + diffuse h (G + grad E . L) / 2; a constant volume has no
    gradient (central differences, the border repeated), so the average is ambient times the value:
    reference-converged to 1e-9.  Meshes have no samples to take gradient magnitudes of: one line."""
    from dvr_gl.transfer_function import projected_rgba

    value, ambient = 0.6, 0.35
    scene = array_scene(tmp_path, np.full((5, 6, 7), value, np.float32),
                        {"renderer.compositing": "average", "renderer.hemispherical_shading": True,
                         "renderer.shading.ambient": ambient, "renderer.shading.diffuse": 0.9,
                         "image.width": 8, "image.height": 8, "renderer.converged_tolerance": 1e-10})
    image = ConvergedReference(scene).render_float64().reshape(-1, 4)
    o, d = scene.camera.pixel_rays(8, 8)
    from dvr_gl.rays import intersect_box
    t0, t1 = intersect_box(o, d, *scene.field.bounds)
    hit = t1 > t0
    expected = np.zeros((64, 4))
    expected[hit] = projected_rgba(scene.transfer_function, np.full(hit.sum(), ambient * value))
    np.testing.assert_allclose(image, expected, atol=1e-9)
