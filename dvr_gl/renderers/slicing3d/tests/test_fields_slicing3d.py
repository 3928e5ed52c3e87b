"""3D texture slicing of several fields (docs/several-fields.md): at each view-aligned slice every field is
sampled in its own grid, the extinctions and emissions added, the slices blended back to front.

Closed forms: constant fields in boxes, a piecewise-constant mixture along every ray, integrated exactly
(:func:`_exact`).  A slice stands for the slab to the next one, so where a box face cuts a slab the slicer's
optical depth is off by up to one slab (the single field's ``box`` tolerance); viewed along an axis with every
face half-way between two slices (:func:`_aligned`), each slab lies inside or outside every box and the slicer is
exact up to float32: measured max 3.0e-7 on these scenes, asserted 2e-6.  Against the oracle (the float64 judge
sampling the same planes): ``conftest.assert_close``, as for one field; measured max 1.5e-6, mean <= 6e-8.
"""

import numpy as np
import pytest

import slice_checks as checks
from conftest import assert_close
from dvr_gl.api import scene_of
from dvr_gl.errors import SceneError
from dvr_gl.fields.color import ColorVolume
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import Member
from dvr_gl.labels import LabelTable
from dvr_gl.rays import intersect_box
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from dvr_gl.transfer_function import TransferFunction
from slab_scenes import tilted

NAME = "slicing3d"
EXACT = 2e-6  # float32 compositing of 21 slabs: measured 3.0e-7 (different grids), 1.2e-7 (one grid)
RED, GREEN, BLUE = (0.9, 0.2, 0.1), (0.1, 0.8, 0.2), (0.2, 0.3, 0.9)


@pytest.fixture(scope="module")
def slicer(shared_gl_context):
    renderer = checks.slicer_on(shared_gl_context, NAME)
    yield renderer
    renderer.close()


@pytest.fixture(autouse=True)
def current_context(gl_context):
    return gl_context


def _constant(value, lo, hi, dims, name):
    """A constant field over the world box ``lo..hi`` (x, y, z) sampled by ``dims`` (x, y, z) voxels."""
    lo, hi, dims = (np.asarray(v, dtype=np.float64) for v in (lo, hi, dims))
    spacing = (hi - lo) / (dims - 1)
    return Volume(np.full(tuple(int(n) for n in dims[::-1]), value, np.float32), spacing=tuple(spacing),
                  origin=tuple(lo), name=name)


def _tf(colour, sigma):
    return TransferFunction(np.array([[0.0, *colour, sigma], [1.0, *colour, sigma]]), opacity_model="extinction")


def _scene(fields, tfs, size=(24, 20), **keywords):
    view = {"projection": "orthographic", "azimuth": 0.0, "elevation": 0.0}  # along +y
    return scene_of(list(fields), transfer_function=list(tfs), renderer=NAME, size=size,
                    ert_threshold=1.0, **{**view, **keywords})


def _exact(scene, sigmas, colours):
    """Per pixel, the exact emission-absorption of constant fields (extinction ``sigmas``, colours ``colours``)
    in their boxes: the ray cut at every box face, each piece's mixture composited exactly, front to back."""
    w, h = scene.image.width, scene.image.height
    o, d = scene.camera.pixel_rays(w, h)
    boxes = [m.field.box for m in scene.field.members]
    cuts = np.array([intersect_box(o, d, lo, hi) for lo, hi in boxes])  # (fields, 2, pixels)
    ts = np.sort(cuts.reshape(-1, len(o)), axis=0)
    ts = np.where(np.isfinite(ts), ts, 0.0)
    rgb, transmittance = np.zeros((len(o), 3)), np.ones(len(o))
    for a, b in zip(ts[:-1], ts[1:]):
        mid = (a + b) / 2.0
        inside = [(mid > t0) & (mid < t1) for t0, t1 in cuts]
        sigma = sum(s * k for s, k in zip(sigmas, inside))
        emitted = sum(s * np.asarray(c) * k[:, None] for s, c, k in zip(sigmas, colours, inside))
        alpha = -np.expm1(-sigma * np.maximum(b - a, 0.0))
        colour = np.divide(emitted, sigma[:, None], out=np.zeros_like(emitted), where=sigma[:, None] > 0)
        rgb += transmittance[:, None] * colour * alpha[:, None]
        transmittance *= 1.0 - alpha
    return np.concatenate([rgb, (1.0 - transmittance)[:, None]], axis=1).reshape(h, w, 4)


def _inner(scene, margin=0.35):
    """Pixels whose rays are at least ``margin`` from every box's side faces (inside or outside): the rasterizer
    may give a pixel on a silhouette to either side."""
    o, d = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    keep = np.ones(len(o), bool)
    for m in scene.field.members:
        lo, hi = m.field.box
        a0, a1 = intersect_box(o, d, lo + margin, hi - margin)
        b0, b1 = intersect_box(o, d, lo - margin, hi + margin)
        keep &= (a1 > a0) | ~(b1 > b0)
    return keep.reshape(scene.image.height, scene.image.width)


def _aligned():
    """Along +y the union box spans y in [0, 7], its centre at 3.5 and the slices (a third apart) at
    3.5 + k / 3; every face (y = 0, 7, 3.5 +- 7/6) lies half-way between two slices."""
    return {"sample_distance": 1.0 / 3.0}


def test_two_overlapping_constant_channels_closed_form(slicer):
    """One grid, two channels (one texture): transmittance exp(-(s1 + s2) L), the extinction-weighted colour."""
    a = _constant(0.5, (0, 0, 0), (7, 7, 7), (8, 8, 8), "a")
    b = _constant(0.5, (0, 0, 0), (7, 7, 7), (8, 8, 8), "b")
    scene = _scene([a, b], [_tf(RED, 0.3), _tf(GREEN, 0.2)], **_aligned())
    image = slicer.render(scene)
    expected = _exact(scene, (0.3, 0.2), (RED, GREEN))
    keep = _inner(scene)
    assert expected[keep][:, 3].max() > 0.9
    np.testing.assert_allclose(expected[keep][:, 3].max(), -np.expm1(-0.5 * 7), rtol=1e-12)
    assert np.abs(image - expected)[keep].max() <= EXACT


def test_fields_on_different_grids_contribute_inside_their_boxes(slicer):
    """A field on a finer grid inside a coarser one: the mixture only inside the inner box."""
    a = _constant(0.5, (0, 0, 0), (7, 7, 7), (8, 8, 8), "a")
    b = _constant(0.5, (2, 3.5 - 7 / 6, 2), (5, 3.5 + 7 / 6, 5), (7, 8, 7), "b")
    scene = _scene([a, b], [_tf(RED, 0.25), _tf(BLUE, 0.8)], **_aligned())
    image = slicer.render(scene)
    expected = _exact(scene, (0.25, 0.8), (RED, BLUE))
    keep = _inner(scene)
    inside_b = np.isclose(expected[..., 3], -np.expm1(-(0.25 * 7 + 0.8 * 7 / 3)))
    assert (keep & inside_b).sum() > 10 and (keep & ~inside_b & (expected[..., 3] > 0)).sum() > 10
    assert np.abs(image - expected)[keep].max() <= EXACT


def test_a_field_hidden_behind_an_opaque_one_contributes_nothing(slicer):
    """An opaque field in front (optical depth 100) hides the one behind it: the image is the front one's."""
    front = _constant(0.5, (0, 0, 0), (7, 3.5 - 1 / 6, 7), (8, 11, 8), "front")
    back = _constant(0.5, (0, 3.5 - 1 / 6, 0), (7, 7, 7), (8, 12, 8), "back")
    scene = _scene([back, front], [_tf(GREEN, 2.0), _tf(RED, 30.0)], **_aligned())
    image = slicer.render(scene)
    keep = _inner(scene)
    seen = keep & (image[..., 3] > 0)
    assert seen.sum() > 50
    assert np.abs(image[seen] - np.array([*RED, 1.0])).max() <= EXACT
    alone = slicer.render(_scene([front, back], [_tf(RED, 30.0), _tf(GREEN, 0.0)], **_aligned()))
    assert np.abs(image - alone)[keep].max() <= EXACT


def test_oblique_view_stays_within_a_slab_of_the_closed_form(slicer):
    """A perspective, oblique view: each face cuts slabs, so the slicer is off by up to one slab's optical
    depth there, (0.4 + 0.6) x 0.25 / cos at most where the boxes overlap: measured 0.064, asserted 0.1."""
    a = _constant(0.5, (0, 0, 0), (5, 6, 7), (6, 7, 8), "a")
    b = _constant(0.5, (1.5, 1, 2), (4, 5, 6.5), (6, 9, 10), "b")
    scene = scene_of([a, b], transfer_function=[_tf(RED, 0.4), _tf(GREEN, 0.6)], renderer=NAME, size=(24, 20),
                     azimuth=27.0, elevation=21.0, fov=35.0, ert_threshold=1.0)
    image = slicer.render(scene)
    expected = _exact(scene, (0.4, 0.6), (RED, GREEN))
    keep = _inner(scene, 0.1)
    assert np.abs(image - expected)[keep].max() <= 0.1


@pytest.mark.parametrize("extra", [{}, {"shading": True}, {"gradient_opacity": True}, {"projection": "perspective"},
                                   {"classification": "preintegrated"}, {"filter": "nearest"},
                                   {"shading": True, "gradient": "texture", "filter": "cubic_bspline"},
                                   {"classification": "preintegrated", "shading": True, "gradient_opacity": True}],
                         ids=["default", "shading", "gradient-opacity", "perspective", "preintegrated", "nearest",
                              "gradient-texture-bspline", "preintegrated-shaded"])
def test_several_fields_match_the_same_plane_reference(slicer, extra):
    """Two channels on one grid and a third on its own: against the float64 judge sampling the same planes."""
    rng = np.random.default_rng(7)
    data = rng.random((3, 10, 11, 12)).astype(np.float32)
    other = Volume(rng.random((7, 8, 9)).astype(np.float32), spacing=(1.3, 1.1, 1.2), origin=(1.5, 0.5, 2.0),
                   name="other")
    fields = [Volume(data[0], name="c0"), Volume(data[1], name="c1"), other]
    tfs = [[[0, 1, 0, 1, 0], [1, 1, 0, 1, 0.6]], [[0, 0, 1, 0, 0.1], [1, 0, 1, 0, 0.4]],
           [[0, 0, 1, 1, 0], [0.5, 0, 1, 1, 0.8], [1, 0, 0.5, 1, 0.2]]]
    view = {"azimuth": 33.0, "elevation": 18.0, "projection": "orthographic"}
    scene = scene_of(fields, transfer_function=tfs, renderer=NAME, size=(24, 24), ert_threshold=1.0,
                     **{**view, **extra})
    reference = checks.same_planes(scene, NAME)
    assert reference[..., 3].max() > 0.1
    assert_close(slicer.render(scene), reference)


@pytest.mark.parametrize("keywords, message", [
    ({"classification": "pre"}, "not per voxel"),
    ({"scattering": True}, "scattering"),
    ({"texture_budget_mb": 1e-4}, "over renderer.texture_budget_mb"),
])
def test_several_fields_refuse_what_slicing_cannot_mix(keywords, message):
    a = _constant(0.5, (0, 0, 0), (3, 3, 3), (4, 4, 4), "a")
    scene = scene_of([a, a], renderer=NAME, size=(8, 8), **keywords)
    with pytest.raises(SceneError, match=message):
        registry.check(scene)


# A label map beside a scalar field (an image with its segmentation) and a colour volume on its own grid.
_Z, _Y, _X = np.mgrid[0:10, 0:11, 0:12].astype(np.float32)
WAVES = Volume((0.5 + 0.5 * np.sin(_X / 2.0) * np.cos(_Y / 3.0) * np.cos(_Z / 2.5)).astype(np.float32), name="waves")
WAVES_TF = [[0, 0.9, 0.6, 0.2, 0.0], [0.5, 0.9, 0.6, 0.2, 0.3], [1, 0.3, 0.3, 1.0, 0.6]]
LABELS = np.zeros((10, 11, 12), np.uint8)
LABELS[3:8, 2:9, 4:10], LABELS[5:10, 6:11, 2:7], LABELS[1:4, 1:5, 8:12] = 1, 2, 3
TABLE = LabelTable([1, 2, 3], [[1, 0.2, 0.2], [0.2, 1, 0.2], [0.2, 0.2, 1]], [0.5, 0.8, 0.0])  # 3: transparent
COLOUR = ColorVolume(np.stack([_X / 12, _Y / 11, _Z / 10, np.clip((_X + _Y) / 23, 0, 1)], -1).astype(np.float32),
                     spacing=(1.1, 0.9, 1.0), origin=(1.0, 0.5, 0.0))
COLOUR_TF = TransferFunction(np.array([[0, 1, 1, 1, 0.0], [1, 1, 1, 1, 0.5]]))
ROLES = {"scalar and label": ([WAVES, Member(Volume(LABELS), "label")], [WAVES_TF, TABLE]),
         "scalar and rgb": ([WAVES, Member(COLOUR, "rgb")], [WAVES_TF, COLOUR_TF]),
         "label and rgb": ([Member(Volume(LABELS), "label"), Member(COLOUR, "rgb")], [TABLE, COLOUR_TF])}
ROLE_MODES = [{}, {"shading": True}, {"classification": "preintegrated"}, {"filter": "nearest"},
              {"projection": "orthographic", "gradient_opacity": True}]


@pytest.mark.parametrize("mode", ROLE_MODES, ids=["-".join(map(str, m.values())) or "post" for m in ROLE_MODES])
@pytest.mark.parametrize("fields", list(ROLES), ids=list(ROLES))
def test_label_and_rgb_members_match_the_same_plane_reference(slicer, fields, mode):
    """Label members by the label rule (common/labels.glsl: never a label no tap holds; pre-integrated: the
    class at the slice over its slab), shaded by their indicator; rgb members' colour from the data, extinction
    from their x.  Measured max 1.1e-6, but for one pixel of the 320 in perspective, off by 0.02: the scalar
    field rendered alone (one field, the old path) shows the same pixel."""
    data, tfs = ROLES[fields]
    scene = scene_of(data, transfer_function=tfs, renderer=NAME, size=(20, 16), ert_threshold=1.0, **mode)
    reference = checks.same_planes(scene, NAME)
    assert reference[..., 3].max() > 0.1
    assert_close(slicer.render(scene), reference)


def _centred_fields():
    """Two channels on one grid and a third field on its own, about the origin (where the tilted mesh lies)."""
    rng = np.random.default_rng(11)
    data = rng.random((2, 12, 13, 14)).astype(np.float32)
    centre = (-6.5, -6.0, -5.5)
    other = Volume(rng.random((7, 8, 9)).astype(np.float32), spacing=(1.3, 1.1, 1.2), origin=(-4.0, -3.0, -6.0),
                   name="other")
    tfs = [[[0, 1, 0, 1, 0], [1, 1, 0, 1, 0.5]], [[0, 0, 1, 0, 0.1], [1, 0, 1, 0, 0.3]],
           [[0, 0, 1, 1, 0], [0.5, 0, 1, 1, 0.7], [1, 0, 0.5, 1, 0.2]]]
    return [Volume(data[0], origin=centre, name="c0"), Volume(data[1], origin=centre, name="c1"), other], tfs


@pytest.mark.parametrize("extra", [
    {"clipping": {"planes": [[1.0, 0.4, -0.3, 1.0]], "box": [[-9.0, -4.0, -9.0], [9.0, 5.0, 6.0]]}},
    {"geometry": "tilted"},
    {"geometry": "tilted", "classification": "preintegrated", "shading": True},
], ids=["clipping", "geometry", "geometry-preintegrated-shaded"])
def test_several_fields_clipped_and_with_meshes_as_the_same_planes(tmp_path, slicer, extra):
    """Clipping drops a fragment outside the kept region, an opaque mesh the fragments behind it, for every
    field alike, as the oracle drops its plane crossings (measured: max 8.6e-7)."""
    fields, tfs = _centred_fields()
    if extra.get("geometry") == "tilted":
        extra = {**extra, "geometry": tilted(tmp_path)}
    scene = scene_of(fields, transfer_function=tfs, renderer=NAME, size=(20, 16), ert_threshold=1.0, **extra)
    reference = checks.same_planes(scene, NAME)
    assert reference[..., 3].max() > 0.1
    assert_close(slicer.render(scene), reference)


def test_the_two_channel_nucleus_as_the_same_planes(slicer, shared_data):
    """Real data: the confocal/widefield nucleus (133 x 130 x 45, two 16-bit channels on one grid, each with its
    channel colour) against the same-plane oracle (measured: one value of 16384 off by 1.2e-4, mean 1.6e-8)."""
    scene = load_scene(None, {"volume.path": str(shared_data / "microscopy" / "xyzc_16bit__dna_conf_wf.tif"),
                              "image.width": 64, "image.height": 64, "renderer.name": NAME,
                              "renderer.ert_threshold": 1.0})
    assert len(scene.layers) == 2
    reference = checks.same_planes(scene, NAME)
    assert reference[..., 3].max() > 0.5
    assert_close(slicer.render(scene), reference)


@pytest.mark.parametrize("extra", [{}, {"shading": True}], ids=["default", "shading"])
def test_an_oblique_field_matches_the_same_plane_reference(slicer, extra):
    """A second field with its own direction matrix (30 degrees about z, 20 about x): sampled in its own grid
    through common/fields.glsl's FIELDS_ORIENTED map, as the judge does.  Measured max 1.2e-6, mean 5e-8."""
    rng = np.random.default_rng(8)
    a, b = np.radians(30.0), np.radians(20.0)
    about_z = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    about_x = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    fields = [Volume(rng.random((10, 11, 12)).astype(np.float32), name="first"),
              Volume(rng.random((7, 8, 9)).astype(np.float32), spacing=(1.3, 1.1, 1.2), origin=(3.0, -2.0, 1.0),
                     direction=about_z @ about_x, name="turned")]
    tfs = [[[0, 1, 0, 1, 0], [1, 1, 0, 1, 0.6]], [[0, 0, 1, 1, 0], [0.5, 0, 1, 1, 0.8], [1, 0, 0.5, 1, 0.2]]]
    scene = scene_of(fields, transfer_function=tfs, renderer=NAME, size=(24, 24), ert_threshold=1.0,
                     azimuth=33.0, elevation=18.0, projection="orthographic", **extra)
    assert scene.field.oriented
    reference = checks.same_planes(scene, NAME)
    assert reference[..., 3].max() > 0.1
    assert_close(slicer.render(scene), reference)
