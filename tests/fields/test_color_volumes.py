"""Colour volumes (dvr_gl/fields/color.py): exact sRGB decoding, luminance, alpha, the grid's conventions, the
role checks, the transfer function of x, the readers (NRRD RGB-color/RGBA-color, npy [z, y, x, 3|4]) and the
scene's rgb member."""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.api import scene_of
from dvr_gl.errors import SceneError, VolumeError
from dvr_gl.fields.color import DEFAULT_OPACITY, ColorVolume, luminance, rgb_transfer_function, srgb_decode
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import FieldSet, Member
from dvr_gl.io import load_volume
from dvr_gl.rays import intersect_box
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.scene.resolve import load_scene
from dvr_gl.scene.schema import TransferFunctionSpec
from judges import CONVERGED, DISCRETE

RNG = np.random.default_rng(42)
CODES = RNG.integers(0, 256, (3, 4, 5, 3), dtype=np.uint8)  # (z, y, x, rgb)


def srgb_formula(v: float) -> float:
    """IEC 61966-2-1, written out."""
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


# --- decoding ----------------------------------------------------------------------------------------------

def test_srgb_decoding_is_exact_at_known_values():
    table = srgb_decode(np.arange(256, dtype=np.uint8))
    assert table[0] == 0.0 and table[255] == 1.0
    # 8-bit codes 10 and 11 sit either side of the 0.04045 breakpoint: the linear piece, then the power
    assert 10 / 255 < 0.04045 < 11 / 255
    assert table[10] == (10 / 255) / 12.92
    # the power piece to numpy's pow: within 1 ulp of the C library's (numpy's AVX-512 pow differs from libm's
    # by 1 ulp at 17 of the 256 codes, measured; without AVX-512 they agree to the bit)
    np.testing.assert_array_max_ulp(table[11], ((11 / 255 + 0.055) / 1.055) ** 2.4, maxulp=1)
    # the breakpoint itself is on the linear piece, and the pieces meet there (to 1e-8: the standard's rounding)
    assert srgb_decode(np.array([0.04045]))[0] == 0.04045 / 12.92
    assert abs(((0.04045 + 0.055) / 1.055) ** 2.4 - 0.04045 / 12.92) < 1e-8
    np.testing.assert_array_max_ulp(table, np.array([srgb_formula(k / 255) for k in range(256)]), maxulp=1)
    assert abs(table[128] - 0.21586050011389926) < 1e-15  # the familiar mid-grey
    assert abs(table[128] - (128 / 255) ** 2.2) > 3e-3  # not a gamma of 2.2


def test_16_bit_codes_decode_over_their_own_range():
    codes = np.array([0, 1, 2650, 2651, 32768, 65535], np.uint16)  # 2650/65535 < 0.04045 < 2651/65535
    expected = np.array([srgb_formula(k / 65535) for k in codes.tolist()])
    np.testing.assert_array_max_ulp(srgb_decode(codes), expected, maxulp=1)  # pow: as above
    assert srgb_decode(codes)[-1] == 1.0


def test_luminance_weighs_linear_colour_by_rec709():
    np.testing.assert_array_equal(luminance(np.eye(3)), [0.2126, 0.7152, 0.0722])
    assert abs(luminance(np.ones(3)) - 1.0) < 1e-15
    cv = ColorVolume.from_srgb(CODES)
    linear = srgb_decode(CODES)
    np.testing.assert_array_equal(cv.data[..., :3], linear.astype(np.float32))
    np.testing.assert_array_equal(cv.data[..., 3], luminance(linear).astype(np.float32))
    assert cv.opacity_source == "luminance" and cv.encoding == "sRGB 8-bit"
    assert cv.value_range == (float(cv.data[..., 3].min()), float(cv.data[..., 3].max()))


def test_alpha_is_linear_and_replaces_luminance():
    rgba = np.concatenate([CODES, np.full(CODES.shape[:3] + (1,), 51, np.uint8)], axis=3)
    cv = ColorVolume.from_srgb(rgba)
    assert cv.opacity_source == "alpha"
    np.testing.assert_array_equal(cv.data[..., 3], np.float32(51 / 255))  # never sRGB-decoded
    np.testing.assert_array_equal(cv.data[..., :3], ColorVolume.from_srgb(CODES).data[..., :3])
    assert ColorVolume.from_srgb(rgba, alpha=False).opacity_source == "luminance"
    given = np.full(CODES.shape[:3], 255, np.uint8)
    np.testing.assert_array_equal(ColorVolume.from_srgb(CODES, alpha=given).data[..., 3], 1.0)
    wide = ColorVolume.from_srgb(rgba.astype(np.uint16) * 257)  # 16-bit: the same fractions
    np.testing.assert_allclose(wide.data, cv.data, rtol=0, atol=0)


def test_decoding_a_slab_at_a_time_changes_nothing(monkeypatch):
    import dvr_gl.fields.color as color

    def both():
        linear = ColorVolume.from_linear(srgb_decode(CODES), alpha=CODES[..., 0] / 255)
        return ColorVolume.from_srgb(CODES).data, linear.data

    whole = both()
    monkeypatch.setattr(color, "SLAB_VOXELS", 7)  # one z at a time (20 voxels a slice)
    for a, b in zip(both(), whole):
        np.testing.assert_array_equal(a, b)


def test_linear_floats_are_taken_as_they_are():
    colour = RNG.random((2, 3, 4, 3))
    cv = ColorVolume.from_linear(colour)
    np.testing.assert_array_equal(cv.data[..., :3], colour.astype(np.float32))
    assert cv.encoding == "linear"
    assert ColorVolume.from_stored(colour.astype(np.float32)).encoding == "linear"
    assert ColorVolume.from_stored(CODES).encoding == "sRGB 8-bit"
    srgb = ColorVolume.from_srgb(colour)  # sRGB-encoded floats
    np.testing.assert_array_equal(srgb.data[..., :3], srgb_decode(colour).astype(np.float32))


@pytest.mark.parametrize("make, what", [
    (lambda: ColorVolume.from_srgb(np.zeros((2, 2, 2), np.uint8)), "got shape (2, 2, 2)"),
    (lambda: ColorVolume.from_srgb(np.zeros((2, 2, 2, 5), np.uint8)), "(z, y, x, 3)"),
    (lambda: ColorVolume.from_srgb(np.zeros((2, 2, 2, 3), np.int16)), "uint8, uint16 or floats"),
    (lambda: ColorVolume.from_srgb(np.full((2, 2, 2, 3), 1.5)), "outside [0, 1]"),
    (lambda: ColorVolume.from_linear(np.zeros((2, 2, 2, 3), np.uint8)), "use ColorVolume.from_srgb"),
    (lambda: ColorVolume.from_linear(np.full((2, 2, 2, 3), np.nan)), "NaN"),
    (lambda: ColorVolume.from_linear(np.full((2, 2, 2, 3), -0.1)), "24 linear colour values outside [0, 1]"),
    (lambda: ColorVolume.from_srgb(CODES, alpha=np.ones((1, 2, 3))), "alpha must have the colour's shape"),
    (lambda: ColorVolume.from_srgb(CODES, alpha=True), "no fourth component"),
    (lambda: ColorVolume.from_srgb(CODES, spacing=(1, 0, 1)), "spacing"),
    (lambda: ColorVolume.from_srgb(CODES, direction=np.ones((3, 3))), "orthonormal"),
    (lambda: ColorVolume.from_srgb(np.zeros((0, 2, 2, 3), np.uint8)), "zero-sized"),
    (lambda: ColorVolume(np.zeros((2, 2, 2, 3), np.float32)), "holds (z, y, x, 4)"),
])
def test_bad_colour_is_one_line(make, what):
    with pytest.raises(VolumeError) as info:
        make()
    assert what in str(info.value) and "\n" not in str(info.value)


# --- the grid --------------------------------------------------------------------------------------------

def test_geometry_is_a_grids():
    geometry = {"spacing": (0.5, 2.0, 1.0), "origin": (1.0, 2.0, 3.0)}
    cv = ColorVolume.from_srgb(CODES, **geometry, name="slab")
    grid = Volume(CODES[..., 0], **geometry)
    assert cv.kind == "grid" and cv.dims == grid.dims == (5, 4, 3)
    for a, b in zip(cv.box, grid.box):
        np.testing.assert_array_equal(a, b)
    assert cv.sample_spacing == grid.sample_spacing == 0.5
    assert cv.dtype == np.float32 and cv.nbytes == 3 * 4 * 5 * 4 * 4
    assert not cv.data.flags.writeable
    assert cv.read((1, 1, 0), (2, 2, 3)).shape == (3, 2, 2, 4)
    assert "5x4x3 colour (sRGB 8-bit" in cv.describe() and "luminance" in cv.describe()
    assert repr(cv).startswith("ColorVolume('slab', 5x4x3 sRGB 8-bit")
    single = ColorVolume.from_srgb(CODES[:1])  # one slice: a slab one spacing thick, as a grid's
    assert single.box[1][2] - single.box[0][2] == 1.0


@pytest.mark.parametrize("filter", ["nearest", "linear", "cubic_bspline", "catmull_rom"])
def test_components_are_filtered_alike_and_shading_reads_x(filter):
    cv = ColorVolume.from_srgb(CODES, spacing=(0.5, 0.7, 1.1))
    points = RNG.random((20, 3)) * np.array([2.0, 2.1, 2.2])
    r = cv.reconstruct(filter)
    sampled = r.sample(points)
    assert sampled.shape == (20, 4) and sampled.dtype == np.float64
    for k in range(4):
        alone = Volume(cv.data[..., k], spacing=cv.spacing).reconstruct(filter)
        np.testing.assert_allclose(sampled[:, k], alone.sample(points), rtol=0, atol=1e-12)
    x = Volume(cv.data[..., 3], spacing=cv.spacing).reconstruct(filter)
    np.testing.assert_allclose(r.gradient(points), x.gradient(points), rtol=0, atol=1e-12)
    if filter == "linear":  # luminance is linear: the filtered x is the filtered colour's luminance
        np.testing.assert_allclose(sampled[:, 3], luminance(sampled[:, :3]), rtol=0, atol=1e-7)


# --- role and transfer function --------------------------------------------------------------------------

def test_a_colour_volume_is_an_rgb_member_only():
    cv = ColorVolume.from_srgb(CODES)
    assert FieldSet([cv]).members[0].role == "rgb"
    assert FieldSet([Volume(CODES[..., 0]), cv]).groups() == [[0], [1]]
    with pytest.raises(SceneError, match="this is a colour volume: give it role rgb"):
        Member(cv, "scalar")
    with pytest.raises(SceneError, match="needs a colour volume"):
        Member(Volume(CODES[..., 0]), "rgb")


def tf_spec(**keys) -> TransferFunctionSpec:
    """A transfer-function table as scene resolution hands it on: its unit distance resolved (here 1)."""
    return TransferFunctionSpec(**{"unit_distance": 1.0, **keys})


def test_default_opacity_ramps_over_luminance_and_is_alpha_itself_with_alpha():
    cv = ColorVolume.from_srgb(CODES)
    tf = rgb_transfer_function(tf_spec(), cv)
    lo, hi = cv.value_range
    np.testing.assert_array_equal(tf.points, [[lo, 1, 1, 1, 0], [hi, 1, 1, 1, DEFAULT_OPACITY]])
    rgba = np.concatenate([CODES, CODES[..., :1]], axis=3)
    identity = rgb_transfer_function(tf_spec(unit_distance=2.0), ColorVolume.from_srgb(rgba))
    alpha = np.linspace(0, 1, 7)
    np.testing.assert_allclose(identity.opacity(alpha), alpha, rtol=0, atol=1e-15)
    assert identity.unit_distance == 2.0
    flat = ColorVolume.from_linear(np.full((2, 2, 2, 3), 0.5))  # one luminance: the ramp spans lo .. lo + 1
    assert rgb_transfer_function(tf_spec(), flat).domain == (0.5, 1.5)


def test_given_points_and_presets_are_over_x():
    cv = ColorVolume.from_srgb(CODES)
    points = [[0.0, 0, 0, 0, 0.0], [0.5, 0, 0, 0, 0.8]]
    tf = rgb_transfer_function(tf_spec(points=points, opacity_model="extinction"), cv)
    assert tf.opacity_model == "extinction" and tf.domain == (0.0, 0.5)
    assert rgb_transfer_function(tf_spec(preset="viridis"), cv).domain == cv.value_range
    with pytest.raises(SceneError, match="needs points"):
        rgb_transfer_function(tf_spec(opacity_model="extinction"), cv)
    with pytest.raises(SceneError, match="role rgb needs a colour volume"):
        rgb_transfer_function(tf_spec(), Volume(CODES[..., 0]))


def test_the_api_takes_a_colour_volume_or_its_member():
    cv = ColorVolume.from_srgb(CODES)
    for data in (cv, Member(cv, "rgb"), [cv], [Member(cv, "rgb")]):
        layers = scene_of(data, size=8).layers
        assert [(layer.role, layer.field) for layer in layers] == [("rgb", cv)]
        assert layers[0].transfer_function.points[-1, 4] == DEFAULT_OPACITY
    two = scene_of([CODES[..., 0], cv], size=8)
    assert [layer.role for layer in two.layers] == ["scalar", "rgb"]


# --- readers ---------------------------------------------------------------------------------------------

def write_nrrd(path, array, *lines):
    """An attached raw NRRD with exactly the header lines given."""
    path.write_bytes(("NRRD0004\n" + "".join(f"{line}\n" for line in lines) + "\n").encode() + array.tobytes())
    return path


def test_npy_colour_round_trips(tmp_path):
    for array in (CODES, CODES.astype(np.uint16) * 257, srgb_decode(CODES).astype(np.float32),
                  np.concatenate([CODES, CODES[..., :1]], axis=3)):
        np.save(tmp_path / "c.npy", array)
        cv = load_volume(tmp_path / "c.npy", role="rgb", spacing=(1, 2, 3))
        np.testing.assert_array_equal(cv.data, ColorVolume.from_stored(array).data)
        assert cv.spacing == (1.0, 2.0, 3.0) and cv.name == "c.npy"
    np.save(tmp_path / "f.npy", np.asfortranarray(CODES))
    np.testing.assert_array_equal(load_volume(tmp_path / "f.npy", role="rgb").data, ColorVolume.from_srgb(CODES).data)


def test_nrrd_colour_round_trips(tmp_path):
    expect = ColorVolume.from_srgb(CODES).data
    common = ("type: uint8", "dimension: 4", "encoding: raw")
    first = write_nrrd(tmp_path / "first.nrrd", CODES, *common, "sizes: 3 5 4 3",
                       "kinds: RGB-color domain domain domain", "space: left-posterior-superior",
                       "space directions: none (2,0,0) (0,3,0) (0,0,4)", "space origin: (1,2,3)")
    cv = load_volume(first)  # the header says colour: no role needed
    np.testing.assert_array_equal(cv.data, expect)
    assert cv.spacing == (2.0, 3.0, 4.0) and cv.origin == (1.0, 2.0, 3.0)
    last = write_nrrd(tmp_path / "last.nrrd", np.ascontiguousarray(np.moveaxis(CODES, -1, 0)), *common,
                      "sizes: 5 4 3 3", "kinds: domain domain domain RGB-color")
    np.testing.assert_array_equal(load_volume(last).data, expect)
    plain = write_nrrd(tmp_path / "plain.nrrd", CODES, *common, "sizes: 3 5 4 3")
    np.testing.assert_array_equal(load_volume(plain, role="rgb").data, expect)
    rgba = np.concatenate([CODES, CODES[..., :1]], axis=3)
    four = write_nrrd(tmp_path / "rgba.nrrd", rgba, *common, "sizes: 4 5 4 3", "kinds: RGBA-color space space space")
    assert load_volume(four).opacity_source == "alpha"


@pytest.mark.parametrize("name, array, lines, role, what", [
    ("plain", CODES, ("sizes: 3 5 4 3",), None, "set volume.role = rgb"),
    ("scalar", CODES[..., 0].copy(), ("dimension: 3", "sizes: 5 4 3"), "rgb", "has no colour axis"),
    ("hsv", CODES, ("sizes: 3 5 4 3", "kinds: HSV-color domain domain domain"), None, "convert it to RGB"),
    ("short", CODES, ("sizes: 3 5 4 3", "kinds: RGBA-color domain domain domain"), None, "not 4"),
    ("space", CODES, ("sizes: 3 5 4 3", "kinds: domain domain domain domain"), "rgb", "has no colour axis"),
])
def test_bad_nrrd_colour_is_one_line(tmp_path, name, array, lines, role, what):
    header = ["type: uint8", "encoding: raw", *lines]
    if not any(line.startswith("dimension") for line in lines):
        header.append("dimension: 4")
    path = write_nrrd(tmp_path / f"{name}.nrrd", array, *header)
    with pytest.raises(VolumeError) as info:
        load_volume(path, role=role)
    assert what in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("shape, role, what", [
    ((3, 4, 5, 3), None, "set volume.role = rgb"),
    ((3, 4, 5), "rgb", "expected colour indexed [z, y, x, c]"),
    ((3, 4, 5, 5), "rgb", "got shape (3, 4, 5, 5)"),
])
def test_bad_npy_colour_is_one_line(tmp_path, shape, role, what):
    np.save(tmp_path / "c.npy", np.zeros(shape, np.uint8))
    with pytest.raises(VolumeError) as info:
        load_volume(tmp_path / "c.npy", role=role)
    assert what in str(info.value) and "\n" not in str(info.value)


def test_a_format_without_colour_refuses_the_rgb_role(tmp_path):
    (tmp_path / "v.raw").write_bytes(bytes(8))
    with pytest.raises(VolumeError, match="colour volumes are read from .*nrrd.* files; this raw file holds scalars"):
        load_volume(tmp_path / "v.raw", dims=(2, 2, 2), dtype="uint8", role="rgb")


def test_scene_files_read_colour(tmp_path):
    np.save(tmp_path / "c.npy", CODES)
    scene = load_scene(None, {"volume.path": str(tmp_path / "c.npy"), "volume.role": "rgb", "image.width": 8,
                              "image.height": 8})
    assert isinstance(scene.field, FieldSet) and [layer.role for layer in scene.layers] == ["rgb"]
    np.testing.assert_array_equal(scene.layers[0].field.data, ColorVolume.from_srgb(CODES).data)
    path = write_nrrd(tmp_path / "c.nrrd", CODES, "type: uint8", "dimension: 4", "encoding: raw", "sizes: 3 5 4 3",
                      "kinds: RGB-color domain domain domain")
    scene = load_scene(None, {"volume.path": str(path), "image.width": 8, "image.height": 8})
    assert [layer.role for layer in scene.layers] == ["rgb"]
    with pytest.raises(SceneError, match="role label takes scalars; this is a colour volume"):
        load_scene(None, {"volume.path": str(path), "volume.role": "label"})
    with pytest.raises(SceneError, match="needs a colour volume"):
        load_scene(None, {"volume.demo": "blobs", "volume.size": 8, "volume.role": "rgb"})


# --- through the references --------------------------------------------------------------------------------

def chord_lengths(s, box) -> np.ndarray:
    """Each pixel ray's length inside ``box`` (world units), as the references clip it."""
    rays = DiscreteReference(s).rays
    a, b = intersect_box(rays.origins, rays.directions, *box)
    span = np.minimum(b, rays.t1) - np.maximum(a, rays.t0)
    return np.maximum(span, 0.0) * np.linalg.norm(rays.directions, axis=1)


@pytest.mark.parametrize("judge, classification", [(DISCRETE, "post"), (DISCRETE, "preintegrated"),
                                                    (CONVERGED, "post")])  # the converged one integrates exactly
def test_a_constant_colour_slab_beside_a_channel_is_the_closed_form(judge, classification):
    """A constant RGBA slab (alpha 102/255: its default opacity is alpha per unit distance) mixed with a constant
    scalar channel over the same box: transmittance ``exp(-(s1 + s2) L)``, colour ``(s1 c1 + s2 c2) / (s1 + s2)``
    times the opacity, ``c1`` the slab's decoded colour.  Measured error: 5.6e-13 (discrete, post), 6.0e-12
    (discrete, pre-integrated: its tables), 1.6e-10 (converged, to its tolerance); asserted 1e-9."""
    codes = np.empty((8, 8, 8, 4), np.uint8)
    codes[...] = (200, 120, 40, 102)
    slab = ColorVolume.from_srgb(codes)
    channel = Volume(np.full((8, 8, 8), 0.5, np.float32))
    green = (0.0, 0.8, 0.3)
    s = scene_of([slab, channel], transfer_function=[None, [[0, *green, 0.6], [1, *green, 0.6]]], renderer=judge,
                 size=(16, 14), azimuth=23.0, elevation=17.0, projection="perspective", fov=40.0, ert_threshold=1.0,
                 classification=classification)
    image = (DiscreteReference if judge == DISCRETE else ConvergedReference)(s).render_float64()
    s1, s2 = -np.log1p(-float(np.float32(102 / 255))), -np.log1p(-0.6)  # x is stored in float32
    c1 = srgb_decode(np.array([200, 120, 40], np.uint8))
    colour = (s1 * c1.astype(np.float32) + s2 * np.array(green)) / (s1 + s2)
    alpha = -np.expm1(-(s1 + s2) * chord_lengths(s, slab.box))
    exact = np.concatenate([colour * alpha[:, None], alpha[:, None]], axis=1).reshape(14, 16, 4)
    assert exact[..., 3].max() > 0.99 and (exact[..., 3] == 0).any()
    np.testing.assert_allclose(image, exact, rtol=0, atol=1e-9)
