"""The ray caster's 2D transfer function (TRANSFER_FUNCTION_2D, common/transfer_function_2d.glsl): against the
same-discretization reference, and gradient-magnitude opacity as one case of it; on several fields
(FIELD_TABLES_2D, common/fields.glsl) against the oracle, and what it refuses there."""

import dataclasses

import numpy as np
import pytest

from conftest import assert_close, small_scene
from dvr_gl.api import scene_of
from dvr_gl.errors import SceneError
from dvr_gl.fields.color import ColorVolume
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import Member
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.renderers.raycast import fields
from dvr_gl.renderers.raycast.renderer import RayCastRenderer, shader_features
from dvr_gl.transfer_function import TransferFunction
from dvr_gl.transfer_function_2d import TransferFunction2D

BASE = {"volume.size": 16, "image.width": 24, "image.height": 24, "renderer.ert_threshold": 1.0,
        "renderer.lut_size": 256}
POINTS = [[0, 0, 0, 0, 0], [0.2, 0.9, 0.5, 0.2, 0.4], [1, 1, 1, 1, 0.8]]
BOXES = [[0.05, 0.0, 0.2, 4.0, 1.0, 0.3, 0.1, 0.9], [0.15, 1.0, 0.2, 6.0, 0.2, 0.4, 1.0, 0.5]]


@pytest.fixture(scope="module")
def gpu():
    renderer = RayCastRenderer()
    yield renderer
    renderer.close()


@pytest.mark.parametrize("extra", [{}, {"renderer.shading.enabled": True},
                                   {"renderer.order": "back_to_front", "renderer.acceleration": "off"}])
def test_gradient_opacity_is_one_case_within_float32(gpu, extra):
    """``tf(v) min(1, g / ref)`` as a 2D table (the 1D table's value nodes by gradient nodes 0 and ref) renders
    what ``renderer.gradient_opacity`` does: the same products in another order, measured at most 1.2e-7 (one
    float32 step at 1), asserted 1e-6."""
    # the step fixed: the scene-chosen defaults would choose for `two`'s 1D function before it is replaced
    base = {**BASE, "transfer_function.points": POINTS, "renderer.sample_distance_voxels": 0.5, **extra}
    one = small_scene({**base, "renderer.gradient_opacity": True, "renderer.gradient_opacity_reference": 3.0})
    two = small_scene(base).replace(
        transfer_function=TransferFunction2D.from_gradient_opacity(one.transfer_function, 3.0, 256))
    assert "TRANSFER_FUNCTION_2D" in shader_features(two) and "TRANSFER_FUNCTION_2D" not in shader_features(one)
    a, b = gpu.render(one), gpu.render(two)
    assert a[..., 3].max() > 0.1
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-6)


@pytest.mark.parametrize("extra", [{}, {"renderer.shading.enabled": True}, {"renderer.compositing": "xray"},
                                   {"renderer.filter": "cubic_bspline"}, {"renderer.gradient_opacity": True},
                                   {"renderer.shading.enabled": True, "renderer.gradient": "texture"}])
def test_boxes_match_the_reference(gpu, extra):
    """ParaView's boxes on a 64 x 32 table: the ray caster within float32 of the discrete reference (measured
    largest errors 4.0e-6 to 6.5e-6 over these six, none above 1e-4: the project's float32 criterion,
    conftest.assert_close)."""
    scene = small_scene({**BASE, "transfer_function.boxes_2d": BOXES, "transfer_function.size_2d": [64, 32],
                         **extra})
    reference = DiscreteReference(scene).render_float64()
    assert reference[..., 3].max() > 0.1
    assert_close(gpu.render(scene), reference)


# Several fields (common/fields.glsl, FIELD_TABLES_2D): smooth fields, two on one grid and a uint8 third on its own
# grid (other dims, spacing and origin), as test_fields_raycast's.
Z, Y, X = np.mgrid[0:10, 0:11, 0:12].astype(np.float32)
WAVES = Volume((np.sin(X / 3) * np.cos(Y / 4) + Z / 10).astype(np.float32))
BALL = Volume((((X - 6) ** 2 + (Y - 5) ** 2 + (Z - 5) ** 2) / 50).astype(np.float32))
RAMP = Volume((np.add.outer(np.arange(7) * 20, np.arange(9) * 10)[:, :, None] + np.arange(8)[None, None, :] * 5)
              .astype(np.uint8), spacing=(1.1, 0.9, 1.2), origin=(2.0, 1.5, -1.0))
# |gradient| of WAVES about 0.1 to 0.4 per world unit, of RAMP 10 to 25: boxes across both gradient ranges;
# WAVES' below 0.8 transparent (empty blocks: its rays bounded by its table's value marginal)
WAVES_2D = TransferFunction2D.from_boxes([[0.8, 0.0, 1.2, 0.25, 1.0, 0.3, 0.1, 0.6],
                                          [1.0, 0.2, 1.0, 0.3, 0.2, 0.4, 1.0, 0.4]], (-1.0, 2.0), (0.0, 0.5), (64, 32))
BALL_1D = TransferFunction([[0.0, 0.2, 0.9, 0.3, 0.0], [1.0, 0.2, 0.9, 0.3, 0.6], [2.0, 0.2, 0.9, 0.3, 0.2]])
RAMP_2D = TransferFunction2D.from_boxes([[0.0, 5.0, 200.0, 25.0, 0.9, 0.8, 0.2, 0.3]], (0.0, 200.0), (0.0, 30.0),
                                        (32, 16))
FIELD_SETS = {"two on one grid, one 2D": ([WAVES, BALL], [WAVES_2D, BALL_1D], "1, 0"),
              "three on two grids, two 2D": ([WAVES, BALL, RAMP], [WAVES_2D, BALL_1D, RAMP_2D], "1, 0, 1")}
FIELD_MODES = [{}, {"shading": True, "gradient_opacity": True}, {"compositing": "xray"},
               {"order": "back_to_front"}, {"acceleration": "on", "block_size": 4}]


@pytest.mark.parametrize("mode", FIELD_MODES, ids=["-".join(map(str, m.values())) or "emission" for m in FIELD_MODES])
@pytest.mark.parametrize("fields", list(FIELD_SETS))
def test_several_fields_with_2d_transfer_functions_match_the_oracle(gpu, fields, mode):
    """Each 2D member looked up by its own value and gradient magnitude, in one stacked table: the ray caster
    against its oracle (the same-discretization reference of the FieldSet) within the several-fields tolerance
    (test_fields_raycast.TOLERANCE, 5e-5; measured here at most 4.3e-6 over these ten, float32 arithmetic); rays
    bounded by a 2D member's blocks where its table's value marginal is transparent."""
    volumes, tfs, flags = FIELD_SETS[fields]
    scene = scene_of(volumes, transfer_function=tfs, renderer="raycast", size=(20, 16), filtering="shader", **mode)
    reference = registry.plugin("raycast").oracle_image(scene)
    assert reference[..., 3].max() > 0.1
    image = gpu.render(scene)
    assert gpu.stats["defines"]["FIELD_TABLE_2D_OF"] == flags
    assert gpu.stats["ray_bounds"] == ("acceleration" in mode)
    error = np.abs(image - reference).max()
    assert error <= 5e-5, f"max error {error:.3g}"


def test_several_fields_with_1d_transfer_functions_compile_and_upload_no_2d_table(gpu, monkeypatch):
    def never(*args):
        raise AssertionError("a 2D table uploaded for 1D transfer functions")

    monkeypatch.setattr(fields, "Tables2D", never)
    scene = scene_of([WAVES, BALL], transfer_function=[BALL_1D, BALL_1D], renderer="raycast", size=(8, 8))
    gpu.render(scene)
    assert not {"FIELD_TABLES_2D", "FIELD_TABLE_2D_OF"} & set(gpu.stats["defines"])


REFUSED = [({"classification": "preintegrated"}, "classification = 'preintegrated' with a 2D"),
           ({"classification": "pre"}, "classification = 'pre' with a 2D"),
           ({"compositing": "mip"}, "compositing = 'mip' with a 2D"),
           ({"compositing": "isosurface"}, "compositing = 'isosurface' with a 2D")]


@pytest.mark.parametrize("settings, words", REFUSED, ids=[w.split(" with")[0] for _, w in REFUSED])
def test_what_several_fields_with_a_2d_transfer_function_cannot_do_is_refused_in_one_line(settings, words):
    scene = scene_of([WAVES, BALL], transfer_function=[WAVES_2D, BALL_1D], renderer="raycast", size=(8, 8),
                     **settings)
    with pytest.raises(SceneError, match=words) as info:
        registry.check(scene)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("role", ["label", "rgb"])
def test_a_label_or_rgb_member_with_a_2d_transfer_function_is_refused_in_one_line(role):
    """Such a member has no value to classify by value and gradient magnitude (a scene file can give it one; the
    API turns a label map's into a label table first): the ray caster and both references refuse it."""
    rng = np.random.default_rng(0)
    other = Member(Volume((rng.random((8, 8, 8)) * 3).astype(np.uint8)), "label") if role == "label" else \
        ColorVolume.from_srgb((rng.random((8, 8, 8, 3)) * 255).astype(np.uint8))
    scene = scene_of([Volume(rng.random((8, 8, 8)).astype(np.float32)), other], size=(8, 8))
    scene = dataclasses.replace(scene, transfer_functions=(BALL_1D, WAVES_2D))
    takers = registry.renderers_with(lambda q: "fields" in q.transfer_function_2d)   # the ray caster, references
    assert "raycast" in takers and len(takers) >= 3
    for name in takers:
        with pytest.raises(SceneError, match=f"{role} field is classified by .*not by a 2D") as info:
            registry.check(scene, name)
        assert "\n" not in str(info.value)
