"""The GPU ray caster against the same-discretization reference, and its behaviour.

Tolerances come from measurements on llvmpipe (Mesa 22.3, the CI machine), all of
40x40 images of the 32^3 Shepp-Logan phantom with shading on where it applies:

* exact filtering (every texture: uint8 is uploaded as R16F, uint16 and int16 as R16, float32 as R32F,
  which llvmpipe all filter in float; and any texture with ``filtering = "shader"``): the GPU differs from
  the float64 reference only by float32 arithmetic.  Measured mean absolute error <= 2.4e-7 and 99th
  percentile <= 4.2e-6 over all modes, filters and classifications; a nearest-filter isosurface flips one
  pixel of 1600 where a sample sits on a voxel boundary (a discontinuity: float32 and float64 positions
  fall on either side).  Asserted: at most 0.5 % of values off by more than 1e-4, and a mean <= 2e-6 over
  the others.  (uint8 as R8, before 2026-11-29: llvmpipe returned the filtered value rounded to 8 bits, up
  to one data unit; measured mean 8.5e-4, 99th percentile 2.0e-2, max 7e-2.)
"""

import itertools
import math

import numpy as np
import pytest

from conftest import array_scene, assert_close, small_scene
from dvr_gl.errors import DvrError
from dvr_gl.gl.context import make_current
from dvr_gl.phantoms import shepp_logan
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers.raycast.renderer import RayCastRenderer, shader_features
from dvr_gl.scene.resolve import load_scene

PHANTOM = shepp_logan(32)
POINTS = [[0.0, 0, 0, 0, 0], [0.12, 0.1, 0.2, 0.6, 0], [0.2, 0.2, 0.4, 0.9, 0.05],
          [0.3, 1, 0.4, 0.1, 0.3], [0.5, 1, 1, 1, 0.6]]
NO_ERT = {"renderer.ert_threshold": 1.0}


@pytest.fixture(scope="module")
def gpu(shared_gl_context):
    """A counting ray caster on the session's context (borrowed: its programs stay compiled for the other
    modules of the run, which compile many of the same)."""
    renderer = RayCastRenderer(count_samples=True, ctx=make_current(shared_gl_context))
    yield renderer
    renderer.close()


def phantom_scene(tmp_path, data, mode, overrides=None):
    lo, hi = float(data.min()), float(data.max())
    scaled = [[lo + p[0] * (hi - lo), *p[1:]] for p in POINTS]
    base = {"image.width": 40, "image.height": 40, "renderer.compositing": mode, **NO_ERT,
            "transfer_function.points": scaled, "renderer.iso_value": lo + 0.25 * (hi - lo),
            "renderer.shading.enabled": mode in ("emission_absorption", "isosurface")}
    base.update(overrides or {})
    return array_scene(tmp_path, data, base)


MODES = [("emission_absorption", {}), ("emission_absorption", {"renderer.order": "back_to_front"}),
         ("emission_absorption", {"renderer.classification": "pre"}),
         ("emission_absorption", {"renderer.classification": "pre", "renderer.associated_colors": False}),
         ("emission_absorption", {"renderer.classification": "preintegrated"}),
         ("emission_absorption", {"renderer.classification": "preintegrated", "renderer.order": "back_to_front",
                                  "renderer.preintegration": "fast"}),
         ("isosurface", {}), ("average", {}), ("mip", {}), ("minip", {}),
         ("xray", {}), ("xray", {"renderer.classification": "pre"})]
FILTERS = ["nearest", "linear", "cubic_bspline", "catmull_rom"]


def _data_for(mode, dtype):
    data = 1.0 - PHANTOM if mode == "minip" else PHANTOM  # MinIP needs low values inside
    if dtype == np.float32:
        return data
    if dtype == np.uint8:
        return np.round(data * 255).astype(np.uint8)
    if dtype == np.uint16:
        return np.round(data * 65535).astype(np.uint16)
    return np.round(data * 60000 - 30000).astype(np.int16)


@pytest.mark.parametrize("mode, extra", MODES, ids=[f"{m}{'-' + '-'.join(map(str, e.values())) if e else ''}"
                                                    for m, e in MODES])
@pytest.mark.parametrize("filter_kind", FILTERS)
def test_every_mode_and_filter_matches_the_reference(tmp_path, gpu, mode, extra, filter_kind):
    scene = phantom_scene(tmp_path, _data_for(mode, np.float32), mode, {**extra, "renderer.filter": filter_kind})
    reference = DiscreteReference(scene).render_float64()
    assert reference[..., 3].max() > 0.1  # the view shows something
    assert_close(gpu.render(scene), reference)


@pytest.mark.parametrize("extra", [{"renderer.acceleration": "on"}, {"renderer.texture_budget_mb": 0.01},
                                   {"renderer.order": "back_to_front", "camera.projection": "orthographic"}],
                         ids=["accelerated", "bricked", "orthographic"])
def test_xray_accelerated_bricked_and_in_any_order(tmp_path, gpu, extra):
    """The X-ray's sums through empty-space skipping (constant blocks jumped in closed form), in bricks
    (the sums carried between passes) and in any order (sums commute): the reference's image."""
    scene = phantom_scene(tmp_path, PHANTOM, "xray", extra)
    reference = DiscreteReference(scene).render_float64()
    assert reference[..., 3].max() > 0.1
    assert_close(gpu.render(scene), reference)
    if "renderer.texture_budget_mb" in extra:
        assert gpu.stats["bricks"] > 1


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16])
@pytest.mark.parametrize("mode", ["emission_absorption", "isosurface", "mip", "minip"])
@pytest.mark.parametrize("filtering", ["hardware", "shader"])
def test_integer_textures(tmp_path, gpu, dtype, mode, filtering):
    scene = phantom_scene(tmp_path, _data_for(mode, dtype), mode, {"renderer.filtering": filtering,
                                                                    "renderer.filter": "cubic_bspline"})
    reference = DiscreteReference(scene).render_float64()
    assert_close(gpu.render(scene), reference)  # uint8 too: R16F, filtered in float


REAL = [  # one real dataset per compositing mode
    ("regular/bucky.nhdr", "emission_absorption", [[0, 0, 0, 0, 0], [60, 0.2, 0.4, 1, 0.05], [200, 1, 0.8, 0.3, 0.5]]),
    ("regular/nucleon.nhdr", "isosurface", [[0, 0.9, 0.6, 0.3, 1], [255, 0.9, 0.6, 0.3, 1]]),
    ("regular/headsq_quarter.nhdr", "average", [[0, 0, 0, 0, 0], [1000, 1, 1, 1, 0.9]]),
    ("regular/hydrogen_atom.nhdr", "mip", [[0, 0, 0, 0, 0], [100, 1, 0.9, 0.6, 1]]),
    ("regular/bucky.nhdr", "minip", [[0, 1, 1, 1, 1], [60, 0, 0, 0, 0]]),
]


@pytest.mark.parametrize("name, mode, points", REAL, ids=[f"{m}-{n.split('/')[1]}" for n, m, _ in REAL])
def test_real_datasets(shared_data, gpu, name, mode, points):
    scene = load_scene(None, {"volume.path": str(shared_data / name), "image.width": 32, "image.height": 32,
                              "renderer.compositing": mode, "renderer.iso_value": 100.0, **NO_ERT,
                              "transfer_function.points": points, "renderer.filtering": "shader",
                              "renderer.shading.enabled": mode in ("emission_absorption", "isosurface")})
    reference = DiscreteReference(scene).render_float64()
    assert reference[..., 3].max() > 0.1 and reference[..., 3].std() > 0.01  # an image with structure
    assert_close(gpu.render(scene), reference)


def test_default_scene_features_and_program_cache(gpu):
    """An emission-only scene compiles no shading, gradients, jitter or termination code."""
    plain = small_scene({**NO_ERT, "renderer.acceleration": False})
    assert shader_features(plain) == {"COMPOSITE_EMISSION": True, "FILTER_LINEAR": True}
    assert shader_features(small_scene({**NO_ERT})) == {"COMPOSITE_EMISSION": True, "FILTER_LINEAR": True,
                                                        "ACCELERATE": True, "NUM_LEVELS": 3, "RUNS_IN_CLASSES": True}
    rich = small_scene({"renderer.shading.enabled": True, "renderer.jitter": True,
                        "renderer.gradient": "texture", "renderer.filter": "catmull_rom",
                        "renderer.filtering": "shader", "camera.projection": "orthographic"})
    assert shader_features(rich) == {
        "COMPOSITE_EMISSION": True, "FILTER_CATMULL_ROM": True, "FILTER_IN_SHADER": True,
        "CAMERA_ORTHOGRAPHIC": True, "EARLY_TERMINATION": True, "SHADING": True, "NUM_LIGHTS": 1,
        "TWO_SIDED": True, "GRADIENT_TEXTURE": True, "JITTER": True, "ACCELERATE": True, "NUM_LEVELS": 3,
        "RUNS_IN_CLASSES": True}
    from dvr_gl.gl.shaders import create_program
    from dvr_gl.renderers.raycast.renderer import SHADERS
    a = create_program(gpu.ctx, "fullscreen.vert", "raycast.frag", shader_features(plain), roots=SHADERS)
    b = create_program(gpu.ctx, "fullscreen.vert", "raycast.frag",
                       shader_features(small_scene({**NO_ERT, "renderer.acceleration": False})), roots=SHADERS)
    assert a is b
    assert "u_light_dir" not in a and "u_gradient" not in a and "u_jitter_seed" not in a and "u_blocks0" not in a


def test_back_to_front_equals_front_to_back(gpu):
    front = gpu.render(small_scene({**NO_ERT, "renderer.shading.enabled": True}))
    back = gpu.render(small_scene({**NO_ERT, "renderer.shading.enabled": True, "renderer.order": "back_to_front"}))
    assert np.abs(front - back).max() <= 1e-5  # float32 rounding of two summation orders (measured 1e-6)


@pytest.mark.parametrize("threshold", [0.5, 0.9, 0.99])
def test_early_termination_bound_and_savings(gpu, threshold):
    overrides = {"transfer_function.points": [[0, 1, 1, 1, 0], [0.15, 0.2, 0.5, 1, 0.6], [1, 1, 0.8, 0.5, 0.6]]}
    full = gpu.render(small_scene({**overrides, **NO_ERT}))
    full_samples = gpu.stats["samples"]
    cut = gpu.render(small_scene({**overrides, "renderer.ert_threshold": threshold}))
    assert np.abs(cut - full).max() <= 1 - threshold + 1e-6
    assert gpu.stats["samples"] < full_samples
    reference = DiscreteReference(small_scene({**overrides, "renderer.ert_threshold": threshold})).render_float64()
    assert_close(cut, reference)


def test_jitter_matches_the_reference_hash(gpu):
    scene = small_scene({**NO_ERT, "renderer.jitter": True, "renderer.jitter_seed": 7,
                         "renderer.sample_distance_voxels": 1.0})
    image = gpu.render(scene)
    assert_close(image, DiscreteReference(scene).render_float64())
    plain = gpu.render(small_scene({**NO_ERT, "renderer.sample_distance_voxels": 1.0}))
    assert np.abs(image - plain).max() > 1e-3


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_camera_inside_the_volume(tmp_path, gpu, projection):
    sigma = 0.2
    data = np.ones((9, 9, 9), np.float32)
    scene = array_scene(tmp_path, data, {
        "transfer_function.points": [[0, 1, 1, 1, sigma], [2, 1, 1, 1, sigma]],
        "transfer_function.opacity_model": "extinction", "camera.eye": [4.0, 3.0, 5.0],
        "camera.target": [4.0, 9.0, 5.0], "camera.fov": 60.0, "camera.projection": projection,
        "camera.view_height": 4.0, "image.width": 9, "image.height": 7, **NO_ERT, "renderer.sample_distance": 0.3})
    o, d = scene.camera.pixel_rays(9, 7)
    with np.errstate(divide="ignore"):
        exits = np.min(np.where(d > 0, (8.0 - o) / d, np.where(d < 0, -o / d, np.inf)), axis=1)
    expected = -np.expm1(-sigma * exits).reshape(7, 9)
    image = gpu.render(scene)
    np.testing.assert_allclose(image[..., 3], expected, rtol=2e-6)  # float32


def test_rays_grazing_faces_and_edges(tmp_path, gpu):
    sigma = 0.5
    scene = array_scene(tmp_path, np.ones((3, 3, 5), np.float32), {
        "transfer_function.points": [[0, 1, 1, 1, sigma], [1, 1, 1, 1, sigma]],
        "transfer_function.opacity_model": "extinction", **NO_ERT, "camera.projection": "orthographic",
        "camera.eye": [-5.0, 1.0, 1.0], "camera.target": [0.0, 1.0, 1.0], "camera.view_height": 2.0,
        "image.width": 3, "image.height": 3})
    image = gpu.render(scene)  # pixel centres on the faces y = 0, 2 and z = 0, 2 (and their edges)
    np.testing.assert_allclose(image[..., 3], -math.expm1(-sigma * 4.0), rtol=2e-6)


def test_thin_and_single_voxel_volumes(tmp_path, gpu):
    sigma = 0.7
    tf = {"transfer_function.points": [[0, 1, 1, 1, sigma], [9, 1, 1, 1, sigma]],
          "transfer_function.opacity_model": "extinction", **NO_ERT, "camera.projection": "orthographic",
          "camera.azimuth": 0.0, "camera.elevation": 90.0, "image.width": 4, "image.height": 4}
    slab = array_scene(tmp_path, np.full((1, 4, 4), 5.0, np.float32), {**tf, "camera.view_height": 2.0},
                       spacing=(1.0, 1.0, 0.25))
    np.testing.assert_allclose(gpu.render(slab)[..., 3], -math.expm1(-sigma * 0.25), rtol=2e-6)
    voxel = array_scene(tmp_path, np.full((1, 1, 1), 5.0, np.float32), {**tf, "camera.view_height": 0.5},
                        spacing=(1.0, 1.0, 2.0))
    for filter_kind in FILTERS:
        image = gpu.render(voxel.with_renderer(filter=filter_kind))
        np.testing.assert_allclose(image[..., 3], -math.expm1(-sigma * 2.0), rtol=2e-6)


@pytest.mark.parametrize("dtype, lo, hi", [(np.uint16, 0, 65535), (np.int16, -32768, 32767),
                                           (np.float32, 1e-30, 1e30), (np.float32, -1e30, 1e30)])
def test_extreme_values_map_back_to_data_units(tmp_path, gpu, dtype, lo, hi):
    rng = np.random.default_rng(0)
    data = rng.choice(np.array([lo, hi], dtype=dtype), size=(6, 6, 6))
    for mode, filter_kind in itertools.product(("emission_absorption", "mip", "average"), ("nearest", "linear")):
        scene = array_scene(tmp_path, data, {
            "transfer_function.points": [[float(lo), 0, 0, 1, 0.0], [float(hi), 1, 0.5, 0, 0.5]],
            "image.width": 12, "image.height": 12, "renderer.compositing": mode, "renderer.filter": filter_kind})
        image = gpu.render(scene)
        assert np.all(np.isfinite(image))
        reference = DiscreteReference(scene).render_float64()
        assert np.abs(image - reference).max() < 1e-4


def test_very_long_rays_are_not_truncated(tmp_path, gpu):
    """Thousands of steps per ray: the loop count comes from the ray length; float32 accumulation
    of optical depth over 7900 segments stays within 2e-5 of the closed form (measured 5.4e-6)."""
    scene = array_scene(tmp_path, np.full((4, 4, 80), 1.0, np.float32), {
        "transfer_function.points": [[0, 1, 1, 1, 0.03], [2, 1, 1, 1, 0.03]],
        "transfer_function.opacity_model": "extinction", **NO_ERT, "renderer.sample_distance": 0.01,
        "camera.projection": "orthographic", "camera.eye": [-10.0, 1.5, 1.5], "camera.target": [0.0, 1.5, 1.5],
        "camera.view_height": 2.0, "image.width": 4, "image.height": 4, "renderer.acceleration": False})
    image = gpu.render(scene)
    assert gpu.stats["samples_per_ray"] == pytest.approx(7900, abs=1)  # 79 units / 0.01
    np.testing.assert_allclose(image[..., 3], -math.expm1(-0.03 * 79.0), atol=2e-5)
    # accelerated, the homogeneous volume is one closed-form jump per block: the same result
    jumped = gpu.render(scene.with_renderer(acceleration=True))
    assert gpu.stats["samples_per_ray"] == 1.0
    np.testing.assert_allclose(jumped[..., 3], -math.expm1(-0.03 * 79.0), atol=2e-5)


@pytest.mark.parametrize("renderer", ["gpu", "judge"])
def test_associated_colours_do_not_bleed(tmp_path, gpu, renderer):
    """Pre-classification of an opaque red region beside empty space whose transfer-function colour
    is green: interpolating non-associated colours mixes the invisible green into the edge;
    associated colours (sigma c, sigma) do not."""
    data = np.zeros((6, 6, 6), np.float32)
    data[:, :, 3:] = 1.0
    overrides = {"transfer_function.points": [[0.0, 0, 1, 0, 0.0], [1.0, 1, 0, 0, 0.9]],
                 "renderer.classification": "pre", "image.width": 16, "image.height": 16,
                 "camera.azimuth": 0.0, "camera.elevation": 0.0}
    share = {}
    for associated in (True, False):
        scene = array_scene(tmp_path, data, {**overrides, "renderer.associated_colors": associated})
        image = gpu.render(scene) if renderer == "gpu" else DiscreteReference(scene).render_float64()
        seen = image[..., 3] > 1e-3
        share[associated] = (image[..., 1][seen] / image[..., 0][seen]).max()
    assert share[True] < 1e-6 and share[False] > 0.2


@pytest.mark.parametrize("filter_kind", ["linear", "cubic_bspline"])
def test_gradient_texture_equals_central_differences(gpu, filter_kind):
    base = {**NO_ERT, "renderer.shading.enabled": True, "renderer.filter": filter_kind,
            "renderer.filtering": "shader"}
    on_the_fly = gpu.render(small_scene(base))
    textured = gpu.render(small_scene({**base, "renderer.gradient": "texture"}))
    assert_close(textured, on_the_fly.astype(np.float64))


def test_gradient_magnitude_opacity(gpu):
    scene = small_scene({**NO_ERT, "renderer.gradient_opacity": True, "renderer.shading.enabled": True})
    image = gpu.render(scene)
    assert_close(image, DiscreteReference(scene).render_float64())
    plain = gpu.render(small_scene({**NO_ERT, "renderer.shading.enabled": True}))
    assert image[..., 3].sum() < plain[..., 3].sum()  # homogeneous regions lose opacity


def test_budget_too_small_even_for_bricks(gpu):
    # pre-classified, gradient texture, linear filter: 32 bytes per voxel, one ghost voxel a side
    with pytest.raises(DvrError, match="cannot hold even a 4\\^3 brick of .* \\(1 ghost voxel a side\\)"):
        gpu.render(small_scene({"renderer.texture_budget_mb": 1, "volume.size": 48,
                                "renderer.classification": "pre", "renderer.gradient": "texture",
                                "renderer.shading.enabled": True}).with_renderer(texture_budget_mb=1e-6))


def test_int16_upload_in_slabs_keeps_every_value(gl_context, monkeypatch):
    """int16 volumes reach the GPU a slab of slices at a time (flipped sign bit, one small buffer):
    with a slab of 2 slices and 7 slices (a short last slab), every voxel's texel is x + 32768."""
    from types import SimpleNamespace

    from dvr_gl.renderers.grid import textures

    monkeypatch.setattr(textures, "SLAB_BYTES", 2 * 2 * 5 * 3)  # 2 slices of 5 x 3
    data = np.random.default_rng(1).integers(-32768, 32768, (7, 3, 5)).astype(np.int16)
    data[0, 0, 0], data[-1, -1, -1] = -32768, 32767
    tex = textures.upload_volume(gl_context, SimpleNamespace(data=data))
    texels = np.frombuffer(tex.texture.read(), np.uint16).reshape(data.shape)
    np.testing.assert_array_equal(texels.astype(np.int64) - 32768, data)
    assert tex.value_scale * texels[0, 0, 0] / 65535 + tex.value_offset == -32768
    tex.texture.release()


def test_uint8_upload_in_slabs_keeps_every_value(gl_context, monkeypatch):
    """uint8 volumes reach the GPU as R16F a slab of slices at a time: with a slab of 2 slices and 7 slices,
    every voxel's texel is its value exactly (every one of the 256 values present)."""
    from types import SimpleNamespace

    from dvr_gl.renderers.grid import textures

    monkeypatch.setattr(textures, "SLAB_BYTES", 2 * 2 * 8 * 16)  # 2 slices of 16 x 8
    data = np.arange(7 * 8 * 16, dtype=np.int64).reshape(7, 8, 16).astype(np.uint8)  # 0..255 each at least once
    tex = textures.upload_volume(gl_context, SimpleNamespace(data=data))
    texels = np.frombuffer(tex.texture.read(), np.float16).reshape(data.shape)
    np.testing.assert_array_equal(texels.astype(np.float64) * tex.value_scale + tex.value_offset, data)
    assert tex.nbytes == 2 * data.size
    tex.texture.release()
