"""The ray caster on several fields (dvr_gl/renderers/raycast/fields.py, common/fields.glsl) against its oracle
(the same-discretization reference of a FieldSet) and closed forms.

Tolerance: with exact filtering (float32 textures, or any with ``filtering = "shader"``) the GPU differs from
the float64 reference by float32 arithmetic only.  Measured on llvmpipe over every mode below (two fields on one
grid, three on different grids, one of them uint8): max 1.1e-5 (emission, X-ray, pre-integrated, shaded, back to
front, cubic B-spline), 6e-6 (projections), 2.2e-6 (shaded isosurface of smooth fields).  Asserted: 5e-5.
"""

import numpy as np
import pytest

from dvr_gl.api import scene_of
from dvr_gl.errors import SceneError
from dvr_gl.fields.color import ColorVolume
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import FieldSet, Member
from dvr_gl.labels import LabelTable
from dvr_gl.rays import intersect_box
from dvr_gl.renderers import registry
from dvr_gl.renderers.grid.field_textures import upload_fields
from dvr_gl.renderers.raycast.renderer import RayCastRenderer
from dvr_gl.transfer_function import TransferFunction

TOLERANCE = 5e-5
Z, Y, X = np.mgrid[0:10, 0:11, 0:12].astype(np.float32)
WAVES = Volume((np.sin(X / 3) * np.cos(Y / 4) + Z / 10).astype(np.float32), spacing=(1, 1, 1))
BALL = Volume((((X - 6) ** 2 + (Y - 5) ** 2 + (Z - 5) ** 2) / 50).astype(np.float32), spacing=(1, 1, 1))
# a third field on its own grid: other dims, spacing and origin, uint8
RAMP = Volume((np.add.outer(np.arange(7) * 20, np.arange(9) * 10)[:, :, None] + np.arange(8)[None, None, :] * 5)
              .astype(np.uint8), spacing=(1.1, 0.9, 1.2), origin=(2.0, 1.5, -1.0))


def _tf(colour, lo, hi):
    return TransferFunction([[lo, *colour, 0.0], [(lo + hi) / 2, *colour, 0.6], [hi, *colour, 0.2]])


TFS = [_tf((0.9, 0.3, 0.2), -1, 2), _tf((0.2, 0.9, 0.3), 0, 2), _tf((0.2, 0.3, 0.9), 0, 200)]
SETS = {"two on one grid": [WAVES, BALL], "three on different grids": [WAVES, BALL, RAMP]}
MODES = [{"compositing": "emission_absorption"}, {"compositing": "xray"}, {"compositing": "mip"},
         {"compositing": "minip"}, {"compositing": "average"}, {"compositing": "isosurface"},
         {"classification": "preintegrated"},
         {"order": "back_to_front"}, {"shading": True, "gradient_opacity": True},
         {"classification": "preintegrated", "shading": True}, {"filter": "cubic_bspline"}]


@pytest.fixture(scope="module")
def gpu():
    renderer = RayCastRenderer()
    yield renderer
    renderer.close()


def _scene(fields, **settings):
    return scene_of(fields, transfer_function=TFS[:len(fields)], renderer="raycast", size=(20, 16),
                    **{"filtering": "shader", **settings})


@pytest.mark.parametrize("mode", MODES, ids=["-".join(map(str, m.values())) for m in MODES])
@pytest.mark.parametrize("fields", list(SETS), ids=list(SETS))
def test_several_fields_match_the_oracle(gpu, fields, mode):
    scene = _scene(SETS[fields], **mode)
    assert isinstance(scene.field, FieldSet)
    reference = registry.plugin("raycast").oracle_image(scene)
    assert reference[..., 3].max() > 0.1  # the view shows something
    image = gpu.render(scene)
    error = np.abs(image - reference).max()
    assert error <= TOLERANCE, f"max error {error:.3g}"
    assert gpu.stats["field_textures"] == (1 if fields == "two on one grid" else 2)


def test_shaded_isosurface_of_several_fields(gpu):
    """The first hit of any member, shaded by that member's own gradient (smooth fields on one grid: a hit's
    position, in float32, moves the normal of a rough field more than the tolerance)."""
    scene = _scene(SETS["two on one grid"], compositing="isosurface", shading=True)
    reference = registry.plugin("raycast").oracle_image(scene)
    error = np.abs(gpu.render(scene) - reference).max()
    assert error <= TOLERANCE, f"max error {error:.3g}"


def _constant(value, dims=(6, 6, 6), spacing=(0.5, 0.5, 0.5), origin=(0.0, 0.0, 0.0)):
    return Volume(np.full(dims, value, np.float32), spacing=spacing, origin=origin)


def _flat_tf(colour, sigma):
    return TransferFunction([[0.0, *colour, sigma], [1.0, *colour, sigma]], opacity_model="extinction")


def _chords(scene, field):
    """Per pixel (H, W): entry distance and chord length of its ray through ``field``'s box (0: missed)."""
    origins, directions = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    t0, t1 = intersect_box(origins, directions, *field.box)
    shape = (scene.image.height, scene.image.width)
    return t0.reshape(shape), np.maximum(t1 - t0, 0.0).reshape(shape)


def test_two_overlapping_constant_channels_closed_form(gpu):
    """Transmittance exp(-(s1 + s2) L) over each pixel's chord L and the extinction-weighted colour."""
    s1, s2, c1, c2 = 0.9, 0.5, np.array([0.9, 0.5, 0.2]), np.array([0.1, 0.4, 0.9])
    fields = [_constant(0.4), _constant(0.7)]
    scene = scene_of(fields, transfer_function=[_flat_tf(c1, s1), _flat_tf(c2, s2)], renderer="raycast",
                     size=(16, 16), ert_threshold=1.0)
    image = gpu.render(scene)
    _, length = _chords(scene, fields[0])
    alpha = -np.expm1(-(s1 + s2) * length)
    expected = np.concatenate([((s1 * c1 + s2 * c2) / (s1 + s2))[None, None] * alpha[..., None],
                               alpha[..., None]], axis=-1)
    assert (length > 1.0).sum() > 50  # the view crosses the box
    error = np.abs(image - expected).max()
    assert error <= 1e-5, f"max error {error:.3g}"  # float32 arithmetic: measured 1.2e-6


def test_a_channel_behind_an_opaque_one_contributes_nothing(gpu):
    """Two fields on different grids side by side: where a ray crosses the opaque one (optical depth at least
    100) first, the bright one behind it adds nothing: the pixel is the opaque one's colour, alpha 1."""
    front, back = _constant(0.5), _constant(0.5, origin=(3.0, 0.0, 0.0))
    red, green = np.array([0.9, 0.1, 0.1]), np.array([0.1, 0.9, 0.1])
    scene = scene_of([front, back], transfer_function=[_flat_tf(red, 200.0), _flat_tf(green, 5.0)],
                     renderer="raycast", size=(24, 16), ert_threshold=1.0, azimuth=-60.0, elevation=10.0)
    image = gpu.render(scene)
    t_red, l_red = _chords(scene, front)
    t_green, l_green = _chords(scene, back)
    hidden = (l_red > 0.5) & (l_green > 0.5) & (t_red < t_green)
    seen = (l_green > 0.5) & (l_red == 0)
    assert hidden.sum() >= 5 and seen.sum() >= 5, (hidden.sum(), seen.sum())  # both cases in the view
    assert np.abs(image[hidden] - np.append(red, 1.0)).max() <= 1e-6
    assert image[seen][:, 1].min() > 0.5  # the green one, where it is not hidden


@pytest.mark.parametrize("settings, words", [({"classification": "pre"}, "classification = 'pre'"),
                                             ({"texture_budget_mb": 0.001}, "texture_budget_mb")])
def test_refused_in_one_line(gpu, settings, words):
    with pytest.raises(SceneError, match=words) as caught:
        gpu.render(_scene(SETS["two on one grid"], **settings))
    assert "\n" not in str(caught.value)


def test_four_channels_travel_in_one_texture(gl_context):
    """Four int16 channels on one grid: one RGBA texture, each channel's values back exactly."""
    data = [np.arange(60, dtype=np.int16).reshape(3, 4, 5) * (k + 1) - 40 for k in range(4)]
    fields = FieldSet(tuple(Volume(d, spacing=(1, 1, 1)) for d in data))
    textures = upload_fields(gl_context, fields)
    try:
        assert len(textures.groups) == 1 and textures.channel == (0, 1, 2, 3)
        raw = np.frombuffer(textures.groups[0].texture.read(), np.uint16).reshape(3, 4, 5, 4)
        for k in range(4):
            values = raw[..., k] / 65535.0 * textures.value_scale[k] + textures.value_offset[k]
            np.testing.assert_allclose(values, data[k], atol=1e-6)
    finally:
        textures.release()


@pytest.mark.parametrize("mode", [{}, {"classification": "preintegrated"}, {"compositing": "xray"},
                                  {"order": "back_to_front"}], ids=["post", "preintegrated", "xray", "back"])
def test_rays_bounded_by_every_members_blocks_change_no_pixel(gpu, mode):
    """Two balls on different grids, most blocks empty: the rays bounded by the union of both members'
    non-empty blocks give the image of unbounded rays, bit for bit (the segments left out add zero)."""
    z, y, x = np.mgrid[0:24, 0:24, 0:24].astype(np.float32)
    a = Volume(np.maximum(0, 1 - ((x - 6) ** 2 + (y - 8) ** 2 + (z - 12) ** 2) / 20), spacing=(1, 1, 1))
    b = Volume(np.maximum(0, 1 - ((x - 16) ** 2 + (y - 14) ** 2 + (z - 10) ** 2) / 16), spacing=(1, 1, 1),
               origin=(3.0, 0.0, 0.0))
    tfs = [TransferFunction([[0, *c, 0.0], [0.05, *c, 0.0], [1, *c, 0.8]]) for c in ((1, 0, 1), (0, 1, 0))]
    images = []
    for acceleration in ("off", "on"):
        scene = scene_of([a, b], transfer_function=tfs, renderer="raycast", size=(24, 24),
                         acceleration=acceleration, **mode)
        images.append(gpu.render(scene))
        assert gpu.stats["ray_bounds"] == (acceleration == "on")
    assert images[1][..., 3].max() > 0.1
    np.testing.assert_array_equal(images[0], images[1])


# A label map beside the waves (the common case: an image with its segmentation) and a colour volume on its own grid.
LABELS = np.zeros((10, 11, 12), np.uint8)
LABELS[3:8, 2:9, 4:10], LABELS[5:10, 6:11, 2:7], LABELS[1:4, 1:5, 8:12] = 1, 2, 3
TABLE = LabelTable([1, 2, 3], [[1, 0.2, 0.2], [0.2, 1, 0.2], [0.2, 0.2, 1]], [0.5, 0.8, 0.0])  # 3: transparent
COLOUR = ColorVolume(np.stack([X / 12, Y / 11, Z / 10, np.clip((X + Y) / 23, 0, 1)], -1).astype(np.float32),
                     spacing=(1.1, 0.9, 1.0), origin=(1.0, 0.5, 0.0))
COLOUR_TF = TransferFunction([[0, 1, 1, 1, 0.0], [1, 1, 1, 1, 0.5]])
ROLES = {"scalar and label": ([WAVES, Member(Volume(LABELS, spacing=(1, 1, 1)), "label")], [TFS[0], TABLE]),
         "scalar and rgb": ([WAVES, Member(COLOUR, "rgb")], [TFS[0], COLOUR_TF]),
         "label and rgb": ([Member(Volume(LABELS, spacing=(1, 1, 1)), "label"), Member(COLOUR, "rgb")],
                           [TABLE, COLOUR_TF])}
ROLE_MODES = [{}, {"shading": True}, {"classification": "preintegrated"}, {"compositing": "isosurface"},
              {"compositing": "isosurface", "shading": True}, {"compositing": "xray"}, {"filter": "nearest"}]


@pytest.mark.parametrize("mode", ROLE_MODES, ids=["-".join(map(str, m.values())) or "post" for m in ROLE_MODES])
@pytest.mark.parametrize("fields", list(ROLES), ids=list(ROLES))
def test_label_and_rgb_members_match_the_oracle(gpu, fields, mode):
    """Label members by the label rule (common/labels.glsl: never a label no tap holds), shaded by their
    indicator; rgb members' colour from the data, extinction from their x.  Measured max 3.2e-6."""
    data, tfs = ROLES[fields]
    scene = scene_of(data, transfer_function=tfs, renderer="raycast", size=(20, 16), filtering="shader", **mode)
    reference = registry.plugin("raycast").oracle_image(scene)
    assert reference[..., 3].max() > 0.1
    error = np.abs(gpu.render(scene) - reference).max()
    assert error <= TOLERANCE, f"max error {error:.3g}"


def test_projections_of_a_label_member_are_refused(gpu):
    data, tfs = ROLES["scalar and label"]
    with pytest.raises(SceneError, match="label field has none to project"):
        gpu.render(scene_of(data, transfer_function=tfs, renderer="raycast", size=(8, 8), compositing="mip"))


def test_rays_bounded_by_a_label_members_blocks_change_no_pixel(gpu):
    """A label map mostly of transparent labels (0, and 3 listed without opacity): its empty blocks bound the
    rays, and the image is the unbounded one, bit for bit."""
    labels = np.zeros((24, 24, 24), np.uint8)
    labels[4:10, 5:12, 3:9], labels[14:20, 12:18, 15:21] = 1, 2
    labels[0:4, 0:4, 20:24] = 3
    data = [Member(Volume(labels, spacing=(1, 1, 1)), "label"),
            Volume(np.zeros((24, 24, 24), np.float32), spacing=(1, 1, 1))]
    images = []
    for acceleration in ("off", "on"):
        scene = scene_of(data, transfer_function=[TABLE, TFS[1]], renderer="raycast", size=(24, 24),
                         acceleration=acceleration, shading=True)
        images.append(gpu.render(scene))
        assert gpu.stats["ray_bounds"] == (acceleration == "on")
    assert images[1][..., 3].max() > 0.1
    np.testing.assert_array_equal(images[0], images[1])


def test_rays_ending_at_geometry_match_the_oracle(gpu, tmp_path):
    """Several fields on different boxes with a mesh in the volume: the rays end at its surface, the last
    segment shortened, its sample anywhere (near an inner box face too, which is tested exactly).  Measured
    max 8e-7."""
    (tmp_path / "triangle.obj").write_text("v 1 1 1\nv 10 1 1\nv 1 10 10\nf 1 2 3\n")
    moved = Volume(BALL.data, spacing=(1, 1, 1), origin=(2.0, 0.0, 0.0))
    scene = scene_of([WAVES, moved], transfer_function=TFS[:2], renderer="raycast", size=(20, 16),
                     filtering="shader", geometry=[{"path": str(tmp_path / "triangle.obj")}])
    reference = registry.plugin("raycast").oracle_image(scene)
    error = np.abs(gpu.render(scene) - reference).max()
    assert "GEOMETRY" in gpu.stats["defines"]
    assert error <= TOLERANCE, f"max error {error:.3g}"
