"""Several fields with their own orientations (dvr_gl/fields/layers.py: the shared frame is the first member's;
another member's direction matrix makes it an oriented box there, FIELDS_ORIENTED in common/fields.glsl).

* Exactness: a member stored rotated 90 degrees about z (array transposed and flipped, direction and origin set
  so that every sample keeps its world position) renders as the member unrotated.  The float64 reference:
  measured max 5e-16 (rounding of the map ``q = A p + b``), asserted 1e-12.  The ray caster: its texture
  coordinates come from ``turn * p + shift`` in float32 instead of ``p``: measured max 3.6e-7, asserted 2e-6.
* An oblique member (30 degrees about z, then 20 about x) against the oracle (the same-discretization
  reference): the several-fields tolerance of test_fields_raycast.py (5e-5); measured max 1.2e-6 (emission,
  MIP, shaded, average, pre-integrated), 2.0e-6 (a label member, shaded).  (A label member's shaded isosurface
  is not compared here: a few pixels differ by up to 0.12 with or without a turn, as with an unturned label
  member at this origin; the quarter turn of it is exact.)
"""

import numpy as np
import pytest

from dvr_gl.api import scene_of
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import FieldSet, Member
from dvr_gl.renderers import registry
from dvr_gl.renderers.raycast.renderer import RayCastRenderer

from .test_fields_raycast import LABELS, TABLE, TFS, TOLERANCE, WAVES, X, Y, Z

ROTATED = 2e-6  # float32 texture coordinates through the 90-degree map: measured 3.6e-7
BALL = Volume((((X - 6) ** 2 + (Y - 5) ** 2 + (Z - 5) ** 2) / 50).astype(np.float32), spacing=(1.0, 0.9, 1.1),
              origin=(0.5, -0.5, 0.3))


def quarter_turn(volume: Volume) -> Volume:
    """``volume`` stored turned 90 degrees about z: new index x along the old +y, new y along the old -x; the
    same samples at the same points (identity-direction ``volume``)."""
    nx = volume.dims[0]
    sx, sy, sz = volume.spacing
    ox, oy, oz = volume.origin
    data = np.ascontiguousarray(volume.data.transpose(0, 2, 1)[:, ::-1, :])
    return Volume(data, spacing=(sy, sx, sz), origin=(ox + (nx - 1) * sx, oy, oz),
                  direction=((0, -1, 0), (1, 0, 0), (0, 0, 1)), name=volume.name)


def oblique(volume: Volume, degrees: float = 30.0) -> Volume:
    """``volume``'s samples with index axes turned ``degrees`` about z, then 20 degrees about x."""
    a, b = np.radians(degrees), np.radians(20.0)
    about_z = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    about_x = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    return Volume(volume.data, spacing=volume.spacing, origin=(3.0, -2.0, 1.0), direction=about_z @ about_x,
                  name=volume.name)


@pytest.fixture(scope="module")
def gpu():
    renderer = RayCastRenderer()
    yield renderer
    renderer.close()


def _scene(fields, tfs=TFS, **settings):
    return scene_of(fields, transfer_function=tfs[:len(fields)], renderer="raycast", size=(20, 16),
                    **{"filtering": "shader", **settings})


MODES = [{}, {"compositing": "mip"}, {"shading": True, "gradient_opacity": True}]
IDS = ["emission", "mip", "shaded"]


def test_the_shared_frame_maps_a_quarter_turn_exactly():
    turned = FieldSet((WAVES, quarter_turn(BALL)))
    assert turned.oriented and not FieldSet((WAVES, BALL)).oriented
    points = np.array([[0.5, -0.5, 0.3], [3.0, 2.0, 1.0], [11.5, 8.5, 10.2]])
    a, b = turned.transforms[1]
    own = turned.to_member(1, points)
    np.testing.assert_allclose((own - b) @ a, points, atol=1e-12)  # rigid, invertible
    index = (own - np.array(turned.members[1].field.origin)) / np.array(turned.members[1].field.spacing)
    old = (points - np.array(BALL.origin)) / np.array(BALL.spacing)  # the same sample, x and y exchanged
    np.testing.assert_allclose(index, [[o[1], BALL.dims[0] - 1 - o[0], o[2]] for o in old], atol=1e-12)
    for lo, hi in zip(turned.bounds, FieldSet((WAVES, BALL)).bounds):
        np.testing.assert_allclose(lo, hi, atol=1e-12)


@pytest.mark.parametrize("mode", MODES, ids=IDS)
def test_a_quarter_turned_member_renders_as_unturned(gpu, mode):
    plain, turned = _scene([WAVES, BALL], **mode), _scene([WAVES, quarter_turn(BALL)], **mode)
    oracle = registry.plugin("raycast").oracle_image
    reference = oracle(plain)
    assert reference[..., 3].max() > 0.1
    error = np.abs(oracle(turned) - reference).max()
    assert error <= 1e-12, f"reference: max error {error:.3g}"
    expected = gpu.render(plain)
    image = gpu.render(turned)
    assert gpu.stats["defines"].get("FIELDS_ORIENTED")
    error = np.abs(image - expected).max()
    assert error <= ROTATED, f"ray caster: max error {error:.3g}"


@pytest.mark.parametrize("mode", MODES, ids=IDS)
def test_an_oblique_member_matches_the_oracle(gpu, mode):
    scene = _scene([WAVES, oblique(BALL)], **mode)
    reference = registry.plugin("raycast").oracle_image(scene)
    assert reference[..., 3].max() > 0.1
    image = gpu.render(scene)
    assert gpu.stats["defines"].get("FIELDS_ORIENTED") and not gpu.stats["ray_bounds"]
    error = np.abs(image - reference).max()
    assert error <= TOLERANCE, f"max error {error:.3g}"


def test_an_oblique_label_member_matches_the_oracle(gpu):
    """A label map turned obliquely beside the waves, shaded by its indicator's gradient turned back."""
    labels = oblique(Volume(LABELS, spacing=(1, 1, 1)), 40.0)
    scene = _scene([WAVES, Member(labels, "label")], [TFS[0], TABLE], shading=True)
    reference = registry.plugin("raycast").oracle_image(scene)
    assert reference[..., 3].max() > 0.1
    error = np.abs(gpu.render(scene) - reference).max()
    assert error <= TOLERANCE, f"max error {error:.3g}"


def test_a_quarter_turned_label_member_renders_as_unturned(gpu):
    """The label rule and its indicator's gradient in the member's own grid, turned back: measured 0 in both."""
    labels = Volume(LABELS, spacing=(1, 1, 1))
    scenes = [_scene([WAVES, Member(m, "label")], [TFS[0], TABLE], shading=True) for m in (labels,
                                                                                       quarter_turn(labels))]
    oracle = registry.plugin("raycast").oracle_image
    assert np.abs(oracle(scenes[1]) - oracle(scenes[0])).max() <= 1e-12
    assert np.abs(gpu.render(scenes[1]) - gpu.render(scenes[0])).max() <= ROTATED
