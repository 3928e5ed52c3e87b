"""Numerical extremes across every registered renderer that has an oracle (its plugin's
same-discretization reference; the CPU references are the judges and are tested against closed
forms in test_reference_closed_forms.py): closed forms or the oracle, and never a NaN or an infinity.

The renderers come from the registry: a new renderer is tested here the day it registers.
Tolerances: against the oracles, the float32 assertion of the other renderer tests
(conftest.assert_close); against closed forms, as stated per test from the measured error.
"""

import math

import numpy as np
import pytest

from conftest import array_scene, assert_close
from dvr_gl.errors import SceneError
from dvr_gl.gl.context import make_current
from dvr_gl.rays import intersect_box
from dvr_gl.renderers import create_renderer, registry
from judges import renderers

WITH_ORACLE = [name for name, p in registry.plugins().items() if p.oracle is not None]


@pytest.fixture(autouse=True)
def current_context(gl_context):
    """The session's context current for every test (a renderer released elsewhere leaves none)."""
    return gl_context


def own_filter(name, scene):
    """The scene with the renderer's own filter where it does not take the default (splatting takes its
    kernels only; closed_forms.own_filter), and its own compositing, classification and projection
    where it takes none of the scene's (Fourier rendering: line integrals of pre-classified voxels in
    parallel projections)."""
    import dataclasses

    p = registry.plugin(name)
    choices = p.choices("filter")
    if scene.renderer.filter not in choices:
        scene = scene.with_renderer(filter=choices[0])
    modes = p.choices("compositing")
    if scene.renderer.compositing not in modes:
        scene = scene.with_renderer(compositing=modes[0])
    classifications = p.choices("classification")
    if classifications and scene.renderer.classification not in classifications:
        scene = scene.with_renderer(classification=classifications[0])
    if scene.camera.projection not in p.projections:
        scene = dataclasses.replace(scene, camera=scene.camera.with_(projection=p.projections[0]))
    return scene


def oracle(name, scene):
    return registry.plugin(name).oracle_image(own_filter(name, scene))


NO_ERT = {"renderer.ert_threshold": 1.0}


class OwnFilter:
    """A renderer that renders the tests' scenes with its own filter (:func:`own_filter`)."""

    def __init__(self, renderer):
        self.renderer, self.name = renderer, renderer.name

    def render(self, scene):
        return self.renderer.render(own_filter(self.name, scene))


@pytest.fixture(scope="module", params=WITH_ORACLE)
def renderer(request, shared_gl_context):
    """Each renderer with an oracle once per module, on the session's context."""
    r = create_renderer(request.param, ctx=make_current(shared_gl_context))
    yield OwnFilter(r)
    r.close()


def check_against_reference(renderer, scene):
    image = renderer.render(scene)
    assert np.all(np.isfinite(image)) and image.min() >= 0.0 and image[..., 3].max() <= 1.0
    reference = oracle(renderer.name, scene)
    assert np.all(np.isfinite(reference))
    assert_close(image, reference)
    return image, reference


@pytest.mark.parametrize("dtype, lo, hi", [(np.uint16, 0, 65535), (np.int16, -32768, 32767),
                                           (np.float32, 1e-30, 1e30), (np.float32, -1e30, 1e30)])
def test_extreme_data_values(tmp_path, renderer, dtype, lo, hi):
    """16-bit data at both ends of its range, float data spanning 1e-30 to 1e30."""
    rng = np.random.default_rng(0)
    data = rng.choice(np.array([lo, hi], dtype=dtype), size=(6, 6, 6))
    scene = array_scene(tmp_path, data, {"transfer_function.points": [[float(lo), 0, 0, 1, 0.0],
                                                                      [float(hi), 1, 0.5, 0, 0.5]],
                                         "image.width": 12, "image.height": 12, **NO_ERT})
    _, reference = check_against_reference(renderer, scene)
    assert reference[..., 3].max() > 0.3


def test_transfer_function_narrower_than_one_data_step(tmp_path, renderer):
    """uint8 data of 100 and 101 and a spike between 100.2 and 100.6: only interpolated values
    reach it (post-classification), and every renderer finds it where its reference does.  The
    spike's opacity changes by 4 per data unit, so the float32 rounding of values near 100 (7.6e-6)
    moves a sample's opacity by up to 3e-5: measured max 4.8e-5 and mean 2.6e-6 for the GPU
    renderers (shear-warp interpolates in float64: 7.7e-7), asserted max 1e-4, mean 5e-6.  A renderer
    that splats kernels' footprints (it declares ``footprint``) sums where the others interpolate: a
    sheet adds some 50 kernels' shares of the value in float32
    blending, whose rounding (4e-7 of the value 100 in a random walk, 4e-5 data units) the spike's
    slope turns into up to 1.6e-4 of opacity a slab: measured max 2.9e-4 and mean 2.5e-5, asserted
    5e-4 and 5e-5 (by design: splatting's precision scales with the value, not its gradient)."""
    rng = np.random.default_rng(1)
    data = rng.choice(np.array([100, 101], dtype=np.uint8), size=(6, 6, 6))
    tf = [[0, 1, 1, 1, 0], [100.2, 1, 0.5, 0.2, 0], [100.4, 1, 0.5, 0.2, 0.8], [100.6, 1, 0.5, 0.2, 0],
          [255, 1, 1, 1, 0]]
    # shader filtering: hardware filtering of 8-bit textures keeps 8 bits of the weights (see
    # test_raycast.py), too coarse for a feature inside one data step
    scene = array_scene(tmp_path, data, {"transfer_function.points": tf, "image.width": 12, "image.height": 12,
                                         "renderer.filtering": "shader", **NO_ERT})
    image = renderer.render(scene)
    reference = oracle(renderer.name, scene)
    assert reference[..., 3].max() > 0.3 and np.all(np.isfinite(image))
    error = np.abs(image - reference)
    sums = registry.plugin(renderer.name).declared("footprint") is not None  # it splats kernels' footprints
    bound, mean = (5e-4, 5e-5) if sums else (1e-4, 5e-6)
    assert error.max() <= bound and error.mean() <= mean


def test_total_opacity(tmp_path, renderer):
    """Opacity 1 (the clamped maximum extinction): every ray through a voxel's depth of material is
    opaque, with no NaN from log(1 - 1)."""
    scene = array_scene(tmp_path, np.ones((6, 6, 6), np.float32),
                        {"transfer_function.points": [[0, 1, 0.5, 0.2, 1.0], [1, 1, 0.5, 0.2, 1.0]],
                         "image.width": 12, "image.height": 12, **NO_ERT,
                         "camera.azimuth": 0.0, "camera.elevation": 0.0})
    image, _ = check_against_reference(renderer, scene)
    centre = image[4:8, 4:8]
    assert np.all(centre[..., 3] == pytest.approx(1.0, abs=1e-6))
    np.testing.assert_allclose(centre[..., :3], np.broadcast_to([1.0, 0.5, 0.2], centre[..., :3].shape), atol=1e-6)


@pytest.mark.parametrize("name", renderers("sample_distance", gl=True))
def test_tiny_opacity_over_a_hundred_thousand_samples(tmp_path, gl_context, name):
    """Opacity 1e-7 per unit distance, 1e5 samples along the central rays: the transmittance is
    exp(-sigma L) within 1e-4 relative (measured 1.7e-8), and the opacity itself, about 4e-7, keeps
    its relative precision because optical depth is accumulated (not a product of factors
    1 - 4e-12): measured 2.7e-4 relative (float32 sums of 1e5 terms), asserted 1e-3.  The ray
    caster takes three passes here: llvmpipe caps a shader invocation's loops at 65535
    iterations, which before the passes truncated these rays to 65 % of their opacity."""
    alpha = 1e-7
    scene = array_scene(tmp_path, np.ones((5, 5, 5), np.float32),
                        {"transfer_function.points": [[0, 1, 1, 1, alpha], [1, 1, 1, 1, alpha]],
                         "image.width": 4, "image.height": 4, **NO_ERT, "renderer.acceleration": False,
                         "renderer.sample_distance": 4e-5, "camera.projection": "orthographic",
                         "camera.azimuth": 0.0, "camera.elevation": 0.0, "camera.view_height": 2.0})
    with create_renderer(name, ctx=gl_context) as r:
        image = r.render(scene)
    o, d = scene.camera.pixel_rays(4, 4)
    t0, t1 = intersect_box(o, d, *scene.volume.box)
    sigma = -math.log1p(-alpha)
    expected = -np.expm1(-sigma * (t1 - t0)).reshape(4, 4)  # 4 world units: 1e5 samples
    assert np.all(np.isfinite(image))
    np.testing.assert_allclose(1.0 - image[..., 3], 1.0 - expected, rtol=1e-4)
    np.testing.assert_allclose(image[..., 3], expected, rtol=1e-3)


CAMERAS = {
    "along an axis": {"camera.azimuth": 0.0, "camera.elevation": 0.0},
    "at 45 degrees": {"camera.azimuth": 45.0, "camera.elevation": 0.0},
    "along a diagonal": {"camera.azimuth": 45.0, "camera.elevation": 35.26},
    "orthographic eye on a face": {"camera.projection": "orthographic", "camera.eye": [0.0, -2.5, 0.3],
                                   "camera.target": [0.0, 10.0, 0.3], "camera.view_height": 6.0},
    "grazing the top face": {"camera.projection": "orthographic", "camera.eye": [0.0, -20.0, 2.5],
                             "camera.target": [0.0, 0.0, 2.5], "camera.view_height": 2.0,
                             "image.height": 11},  # the middle row's rays run in the face
}


@pytest.mark.parametrize("camera", list(CAMERAS))
def test_special_views(tmp_path, renderer, camera):
    """Views exactly along an axis, at 45 degrees (2D stacks and shear-warp switch axes there),
    along a diagonal, an eye on a face and rays grazing a face: each renderer against its own
    reference (6^3 random data, 12x12)."""
    rng = np.random.default_rng(2)
    scene = array_scene(tmp_path, rng.random((6, 6, 6)).astype(np.float32),
                        {"transfer_function.points": [[0, 1, 0.5, 0.2, 0.0], [1, 0.2, 0.5, 1, 0.4]],
                         "image.width": 12, "image.height": 12, **NO_ERT, **CAMERAS[camera]},
                        origin=(-2.5, -2.5, -2.5))
    if camera == "grazing the top face" and renderer.name.startswith("slicing"):
        # GL's fill rule leaves out fragments centred exactly on a polygon's top edge, so the slicers
        # draw nothing for the rays that run in the face, which the reference (a closed box) samples:
        # by design, and confined to that row
        image = renderer.render(scene)
        reference = oracle(renderer.name, scene)
        assert np.all(image[5] == 0.0) and reference[5, :, 3].max() > 0.5
        assert_close(np.delete(image, 5, axis=0), np.delete(reference, 5, axis=0))
        return
    reason = registry.refusal(own_filter(renderer.name, scene), renderer.name)
    if reason is not None:  # Fourier rendering integrates whole chords: an eye on the box is refused
        assert "inside" in reason and camera == "orthographic eye on a face", reason
        return
    _, reference = check_against_reference(renderer, scene)
    assert reference[..., 3].max() > 0.05


@pytest.mark.parametrize("shape", [(1, 6, 6), (6, 6, 1), (6, 1, 6), (1, 1, 1)])
def test_one_voxel_thick_and_single_voxel_volumes(tmp_path, renderer, shape):
    """A 1-voxel-thick slab along each axis and a 1x1x1 volume (a single-sample axis gets a
    one-spacing slab, conventions): each renderer against its own reference, from a diagonal view
    and from along the thin axis (x, y or z: the data are [z, y, x])."""
    rng = np.random.default_rng(3)
    data = (0.3 + 0.7 * rng.random(shape)).astype(np.float32)
    thin = np.eye(3)[2 - int(np.argmin(shape))] * 12.0
    up = [0.0, 0.0, 1.0] if thin[2] == 0 else [0.0, 1.0, 0.0]
    along = {"camera.eye": list(thin + 0.01), "camera.target": [0.01, 0.01, 0.01], "camera.up": up}
    # azimuth 31, not 30: at 30 one pixel centre of the 12x12 image lies exactly on the edge of a
    # 2D-stack slice (the fill rule's case, as in test_special_views), and the eyes are off-centre
    # by 0.01 so that no slice plane lies exactly in a face (a sample there is either side's)
    for view in ({"camera.azimuth": 31.0, "camera.elevation": 25.0}, along):
        scene = array_scene(tmp_path, data, {"transfer_function.points": [[0, 1, 0.5, 0.2, 0.0], [1, 0.2, 0.5, 1, 0.9]],
                                             "image.width": 12, "image.height": 12, **NO_ERT, **view},
                            origin=tuple(-(n - 1) / 2.0 for n in shape[::-1]))
        _, reference = check_against_reference(renderer, scene)
        assert reference[..., 3].max() > 0.1


def test_camera_inside_the_volume(tmp_path, renderer):
    """A perspective eye at the centre of the volume: rays start at the eye (near plane 0), for each
    renderer against its reference (shear-warp factors the view by pyramids of rays, Lacroute 1995; a
    renderer that refuses the eye inside does so in one line)."""
    rng = np.random.default_rng(4)
    scene = array_scene(tmp_path, rng.random((8, 8, 8)).astype(np.float32),
                        {"transfer_function.points": [[0, 1, 0.5, 0.2, 0.0], [1, 0.2, 0.5, 1, 0.3]],
                         "image.width": 12, "image.height": 12, "camera.eye": [0.2, 0.1, 0.3],
                         "camera.target": [5.0, 3.0, 1.0], "camera.fov": 70.0, **NO_ERT},
                        origin=(-3.5, -3.5, -3.5))
    if registry.refusal(own_filter(renderer.name, scene), renderer.name):  # shear-warp, splatting: one line
        with pytest.raises(SceneError, match="inside"):
            renderer.render(scene)
        return
    _, reference = check_against_reference(renderer, scene)
    assert reference[..., 3].min() > 0.05   # every ray starts inside and sees material
