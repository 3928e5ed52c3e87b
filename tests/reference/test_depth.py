"""Picking and depth on the float64 model (dvr_gl.picking, dvr_gl.reference.depth) against closed forms.

* A slab of constant extinction sigma seen along its normal: the opacity reaches one half ``ln 2 / sigma``
  past its face.  Each segment has one extinction and the crossing is interpolated linearly in the optical
  depth, so the model is exact here: measured 1e-15, held to 1e-9.
* MIP of a Gaussian blob centred on a voxel, the ray through its centre: the maximum's sample lies within half
  a segment of the centre (the sample grid is the rays', not the voxels').
* The isosurface of a constant box (value above iso): the hit is the entry point (exact).
* pick and the depth image are the same code over one ray or all: equal to float32 rounding of the image.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import array_scene
from dvr_gl import SceneError, pick, render
from dvr_gl.reference.depth import depth_image
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry

SIGMA = 1.3
# the reference renderer that writes depth images, found by what it declares
JUDGE = next(n for n, p in registry.plugins().items() if p.reference and p.depth_output)


def slab(tmp_path, **extra):
    """4 x 4 x 1 (world) of constant data, extinction SIGMA, seen orthographically from +z (eye at z = 10),
    the view 6 wide: the outer pixels miss the slab."""
    data = np.full((3, 9, 9), 0.5, np.float32)
    overrides = {"transfer_function.points": [[0.0, 1.0, 1.0, 1.0, SIGMA], [1.0, 1.0, 1.0, 1.0, SIGMA]],
                 "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 10,
                 "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
                 "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 6.0, "renderer.ert_threshold": 1.0, **extra}
    return array_scene(tmp_path, data, overrides, spacing=(0.5, 0.5, 0.5))


def reference_depth(scene) -> np.ndarray:
    ref = DiscreteReference(scene)
    ref.render()
    return depth_image(ref)


def test_slab_half_opacity_depth_is_ln2_over_sigma(tmp_path):
    scene = slab(tmp_path)
    p = pick(scene, 6, 5)
    assert p.hit
    assert p.depth == pytest.approx(9.0 + math.log(2.0) / SIGMA, abs=1e-9)  # the face at z = 1, 9 from the eye
    assert p.position[2] == pytest.approx(1.0 - math.log(2.0) / SIGMA, abs=1e-9)
    assert p.value == pytest.approx(0.5)
    assert p.index == (1, 3, 5)  # (z, y, x) of the node nearest the point (2.3, 1.7, 0.47)
    z = reference_depth(scene)
    origins, _ = scene.camera.pixel_rays(12, 10)
    inside = np.all((origins[:, :2] > 0.0) & (origins[:, :2] < 4.0), axis=1).reshape(10, 12)
    np.testing.assert_allclose(z[inside], 9.0 + math.log(2.0) / SIGMA, atol=1e-5)  # float32 image
    assert np.isposinf(z[~inside]).all() and (~inside).any()  # the rays that miss: inf


def test_a_ray_that_misses_or_stays_thin_has_no_depth(tmp_path):
    missed = pick(slab(tmp_path), 0, 0)
    assert not missed.hit and missed.depth == math.inf and missed.value is None and missed.position is None
    thin = slab(tmp_path, **{"transfer_function.points": [[0.0, 1.0, 1.0, 1.0, 0.1], [1.0, 1.0, 1.0, 1.0, 0.1]]})
    assert not pick(thin, 6, 5).hit  # 1 - exp(-0.1) never reaches one half
    assert np.isposinf(reference_depth(thin)).all()


def test_camera_inside_the_volume(tmp_path):
    # the eye inside the slab (near = 0): rays start at the eye; the crossing is ln 2 / sigma from it
    scene = slab(tmp_path, **{"camera.projection": "perspective", "camera.eye": [2.0, 2.0, 0.9],
                              "camera.target": [2.0, 2.0, -5.0], "camera.fov": 30.0,
                              "transfer_function.points": [[0.0, 1.0, 1.0, 1.0, 9.0], [1.0, 1.0, 1.0, 1.0, 9.0]]})
    p = pick(scene, 3, 7)
    assert p.distance == pytest.approx(math.log(2.0) / 9.0, abs=1e-9)
    forward = np.array([0.0, 0.0, -1.0])
    assert p.depth == pytest.approx(float((np.subtract(p.position, (2.0, 2.0, 0.9))) @ forward), abs=1e-12)


def blob(tmp_path, centre=(5, 4, 6), **extra):
    """A Gaussian blob over (12, 10, 14) voxels, its maximum 1 at voxel ``centre`` (z, y, x)."""
    z, y, x = np.meshgrid(*(np.arange(n) for n in (12, 10, 14)), indexing="ij")
    c = np.asarray(centre)
    data = np.exp(-((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) / 8.0).astype(np.float32)
    overrides = {"image.width": 16, "image.height": 14, "renderer.sample_distance": 0.25, **extra}
    return array_scene(tmp_path, data, overrides)


def test_mip_depth_is_the_maximum_s_sample(tmp_path):
    centre = np.array([6.0, 4.0, 5.0])  # world (x, y, z) of voxel (5, 4, 6)
    scene = blob(tmp_path, **{"renderer.compositing": "mip", "camera.projection": "orthographic",
                              "camera.eye": [6.0, -20.0, 5.0], "camera.target": [6.0, 4.0, 5.0],
                              "camera.view_height": 7.0})
    p = pick(scene, 8, 7)  # the pixel whose centre is on the view axis through the blob's centre
    assert p.hit and p.index == (5, 4, 6)
    assert abs(p.position[1] - centre[1]) <= 0.125 + 1e-9  # half a segment along the ray (+y)
    np.testing.assert_allclose(np.asarray(p.position)[[0, 2]], centre[[0, 2]] + [0.25, -0.25], atol=1e-9)
    # trilinear interpolation of the separable Gaussian: per axis, linear between 1 and exp(-1/8) one voxel away
    offsets = np.abs(np.subtract(p.position, centre))
    assert p.value == pytest.approx(np.prod(1.0 - offsets * (1.0 - np.exp(-1.0 / 8.0))), rel=1e-6)


def test_isosurface_depth_is_the_hit(tmp_path):
    scene = slab(tmp_path, **{"renderer.compositing": "isosurface", "renderer.iso_value": 0.3})
    p = pick(scene, 6, 5)
    assert p.hit and p.depth == pytest.approx(9.0, abs=1e-9)  # the entry point (value 0.5 >= 0.3)


@pytest.mark.parametrize("mode, extra", [("emission_absorption", {"renderer.jitter": True}),
                                         ("emission_absorption", {"renderer.classification": "preintegrated",
                                                                 "renderer.preintegration_size": 32}),
                                         ("mip", {}), ("minip", {}), ("isosurface", {"renderer.iso_value": 0.5}),
                                         ("xray", {})])
def test_pick_agrees_with_the_depth_image(tmp_path, mode, extra):
    points = [[0.0, 0.2, 0.4, 0.9, 0.0], [1.0, 0.9, 0.8, 0.1, 2.5]]
    scene = blob(tmp_path, **{"renderer.compositing": mode, "transfer_function.points": points,
                              "transfer_function.opacity_model": "extinction", "camera.azimuth": 30.0,
                              "camera.elevation": 20.0, **extra})
    image = render(scene, renderer=JUDGE, depth=True)
    assert image.depth.shape == (14, 16) and np.isfinite(image.depth).any()
    for x, y in [(8, 7), (5, 9), (11, 4), (0, 0)]:
        p = pick(scene, x, y)
        assert p.depth == pytest.approx(float(image.depth[y, x]), rel=1e-6), (x, y)


def test_refusals_in_one_line(tmp_path):
    scene = slab(tmp_path)
    with pytest.raises(SceneError, match="outside the image"):
        pick(scene, 12, 0)
    with pytest.raises(SceneError, match="has no depth"):
        pick(slab(tmp_path, **{"renderer.compositing": "average"}), 6, 5)
    without = [n for n, p in registry.plugins().items() if not p.depth_output]
    if without:
        assert "draws no depth image" in registry.depth_refusal(scene, without[0])


def two_blobs():
    z, y, x = np.meshgrid(*(np.arange(n) for n in (10, 8, 12)), indexing="ij")
    a = np.exp(-((z - 4) ** 2 + (y - 3) ** 2 + (x - 8) ** 2) / 6.0)
    b = np.exp(-((z - 5) ** 2 + (y - 4) ** 2 + (x - 3) ** 2) / 6.0)
    return a.astype(np.float32), b.astype(np.float32)


WARM = [[0.0, 1.0, 0.5, 0.2, 0.0], [1.0, 1.0, 0.5, 0.2, 0.95]]
COLD = [[0.0, 0.2, 0.5, 1.0, 0.0], [1.0, 0.2, 0.5, 1.0, 0.95]]


def test_a_mirrored_volume_picks_as_its_mirror_image():
    """A direction matrix with determinant -1 (drawn in the volume's frame, columns turned back) against the
    same voxels stored flipped: the same depth image and picks, world positions in the patient frame; the
    voxel index is the file's own."""
    from dvr_gl import Volume

    data, _ = two_blobs()
    turned = Volume(data, spacing=(1.0, 1.0, 1.0), direction=np.diag([-1.0, 1.0, 1.0]))
    flipped = Volume(np.ascontiguousarray(data[:, :, ::-1]), spacing=(1.0, 1.0, 1.0), origin=(-11.0, 0.0, 0.0))
    keywords = dict(size=(16, 12), transfer_function=WARM)
    a, b = (render(v, renderer=JUDGE, depth=True, **keywords).depth for v in (turned, flipped))
    np.testing.assert_array_equal(a, b)
    p, q = pick(turned, 8, 5, **keywords), pick(flipped, 8, 5, **keywords)
    assert p.hit and p.depth == q.depth and p.position == q.position and p.value == q.value
    assert p.index[:2] == q.index[:2] and p.index[2] == 11 - q.index[2]


def test_several_fields_name_the_field_and_every_value():
    data = np.stack(two_blobs())
    keywords = dict(size=(16, 12), channel_axis=0, transfer_function=[WARM, COLD])
    image = render(data, renderer=JUDGE, depth=True, **keywords)
    p = pick(data, 8, 5, **keywords)
    assert p.hit and p.depth == pytest.approx(float(image.depth[5, 8]), rel=1e-6)
    assert p.field == "channel 0" and set(p.values) == {"channel 0", "channel 1"}
    assert p.values["channel 0"] > p.values["channel 1"]
    with pytest.raises(SceneError, match="each field has its own mip"):
        pick(data, 8, 5, compositing="mip", **keywords)
