import numpy as np
import pytest

from dvr_gl.errors import SceneError
from dvr_gl.transfer_function import (
    ALPHA_MAX,
    MAX_OPTICAL_DEPTH,
    PRESETS,
    TransferFunction,
    extinction_from_alpha,
    preset,
    segment_opacity,
)

TF = TransferFunction(np.array([[10.0, 1, 0, 0, 0.0], [20.0, 0, 1, 0, 0.5], [40.0, 0, 0, 1, 1.0]]),
                      unit_distance=2.0)


def test_piecewise_linear_and_constant_beyond_the_ends():
    np.testing.assert_allclose(TF.color([0, 10, 15, 30, 50]),
                               [[1, 0, 0], [1, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0.5], [0, 0, 1]])
    np.testing.assert_allclose(TF.opacity([0, 15, 30, 99]), [0, 0.25, 0.75, 1.0])


def test_extinction_from_alpha_per_unit_distance():
    # a layer of unit_distance (2.0) at alpha 0.5 transmits 0.5
    sigma = TF.extinction(20.0)
    assert np.exp(-sigma * 2.0) == pytest.approx(0.5, rel=1e-15)
    # alpha = 1 clamps to the largest float32 below 1
    assert TF.extinction(40.0) == pytest.approx(MAX_OPTICAL_DEPTH / 2.0)
    assert MAX_OPTICAL_DEPTH == pytest.approx(24 * np.log(2))
    assert ALPHA_MAX == np.nextafter(np.float32(1), np.float32(0))


def test_extinction_is_stable_for_tiny_alpha():
    # -log(1 - a) computed naively in float64 loses digits at a = 1e-12; log1p does not
    assert extinction_from_alpha(1e-12, 1.0) == pytest.approx(1e-12, rel=1e-12)
    assert segment_opacity(1e-12, 1.0) == pytest.approx(1e-12, rel=1e-12)


def test_extinction_model_takes_sigma_directly():
    tf = TransferFunction(np.array([[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 4.0]]), opacity_model="extinction")
    np.testing.assert_allclose(tf.extinction([0.25, 2.0]), [1.0, 4.0])


@pytest.mark.parametrize("points, message", [
    ([[1, 0, 0, 0, 0], [0, 0, 0, 0, 0]], "increase strictly.*sort"),
    ([[1, 0, 0, 0, 0], [1, 0, 0, 0, 0]], "increase strictly"),
    ([[0, 0, 0, 0, 1.5]], r"alpha \[1.5\] outside \[0, 1\]"),
    ([[0, 0, 0, 0, -0.1]], "outside"),
    ([[0, 2, 0, 0, 0.5]], "colour"),
    ([[0, np.nan, 0, 0, 0.5]], "finite"),
    ([[0, 0, 0, 0]], r"\[value, r, g, b, opacity\]"),
])
def test_bad_points_are_rejected(points, message):
    with pytest.raises(SceneError, match=message):
        TransferFunction(np.array(points, dtype=float))


def test_bad_unit_distance_and_model():
    with pytest.raises(SceneError, match="unit_distance"):
        TransferFunction(np.array([[0, 0, 0, 0, 0.0]]), unit_distance=0)
    with pytest.raises(SceneError, match="opacity_model"):
        TransferFunction(np.array([[0, 0, 0, 0, 0.0]]), opacity_model="density")


def test_lut_holds_colour_and_extinction_at_its_nodes_and_interpolates_linearly():
    lut = TF.tabulate(31)  # nodes every 1.0 over [10, 40]
    np.testing.assert_allclose(lut.table[10], [0, 1, 0, extinction_from_alpha(0.5, 2.0)])
    colour, sigma = lut.lookup(np.array([20.0, 20.5, 5.0, 45.0]))
    np.testing.assert_allclose(colour[0], [0, 1, 0])
    np.testing.assert_allclose(sigma[1], (lut.table[10, 3] + lut.table[11, 3]) / 2)  # extinction lerped
    np.testing.assert_allclose(colour[2], [1, 0, 0])  # clamped at the ends
    np.testing.assert_allclose(colour[3], [0, 0, 1])
    np.testing.assert_allclose(sigma[3], MAX_OPTICAL_DEPTH / 2.0)


def test_lut_keeps_the_optical_depth_of_a_steep_ramp():
    """A ramp from alpha 0 to 1 within one table interval: interpolating extinction keeps most of
    the model's optical depth over the interval (8.3 of 8.8); interpolating alpha would give 1.0."""
    tf = TransferFunction(np.array([[0.0, 1, 1, 1, 0.0], [0.5, 1, 1, 1, 1.0], [2.0, 1, 1, 1, 1.0]]))
    lut = tf.tabulate(3)  # nodes at 0, 1, 2
    v = np.linspace(0.0, 1.0, 200001)
    model = np.trapezoid(tf.extinction(v), v)
    table = np.trapezoid(lut.lookup(v)[1], v)
    assert model == pytest.approx(0.5 + 0.5 * MAX_OPTICAL_DEPTH, rel=1e-3)
    assert table == pytest.approx(0.5 * MAX_OPTICAL_DEPTH, rel=1e-6)


def test_lut_error_shrinks_with_size():
    # The table interpolates extinction between nodes; the model interpolates alpha between
    # control points.  The error comes from that curvature and from the control point at 25.3
    # falling between nodes (a kink cut by an interval of width h): mean error O(h^2), with a
    # constant that depends on where the kink falls.  Measured: 7.9e-4, 1.4e-4, 6.6e-6, 2.6e-7 for
    # 64, 256, 1024, 4096 entries; assert the decrease and at least a quarter of the O(h^2)
    # reduction over 64x more entries.
    tf = TransferFunction(np.array([[0.0, 0, 0, 0, 0], [25.3, 1, 1, 1, 0.9], [100.0, 0, 0, 0, 0]]))
    v = np.linspace(0, 100, 100001)
    errors = [np.abs(tf.tabulate(n).lookup(v)[1] - tf.extinction(v)).mean() for n in (64, 256, 1024, 4096)]
    assert errors[0] > errors[1] > errors[2] > errors[3] > 0
    assert errors[0] / errors[3] > 64 ** 2 / 4


def test_single_point_function_is_constant():
    tf = TransferFunction(np.array([[5.0, 0.2, 0.3, 0.4, 0.1]]))
    colour, sigma = tf.tabulate(8).lookup(np.array([-1e6, 5.0, 1e6]))
    np.testing.assert_allclose(colour, [[0.2, 0.3, 0.4]] * 3)
    np.testing.assert_allclose(sigma, [extinction_from_alpha(0.1, 1.0)] * 3)


def test_breakpoints_include_the_alpha_clamp():
    tf = TransferFunction(np.array([[0.0, 0, 0, 0, 0], [10.0, 1, 1, 1, 1.0]]))
    bp = tf.breakpoints()
    assert bp[0] == 0 and bp[-1] == 10
    assert len(bp) == 3 and bp[1] == pytest.approx(10 * ALPHA_MAX)


@pytest.mark.parametrize("name", list(PRESETS))
def test_presets_are_valid(name):
    tf = preset(name, (0.0, 1000.0))
    assert len(tf.points) >= 2


def test_ct_presets_are_in_hounsfield_units_shifted_by_the_intercept():
    hu = preset("ct-bone-ivory", (0, 4095))
    shifted = preset("ct-bone-ivory", (0, 4095), rescale_intercept=-1024)
    np.testing.assert_allclose(shifted.points[:, 0], hu.points[:, 0] + 1024)
    with pytest.raises(SceneError, match="unknown transfer function preset 'bones'"):
        preset("bones", (0, 1))


@pytest.mark.parametrize("data", [np.linspace(0.0, 50.0, 70000).reshape(70, 1000),  # float: evaluated a voxel
                                  np.arange(70000, dtype=np.uint16).reshape(70, 1000) % 47,  # a table a value
                                  (np.arange(70000, dtype=np.int16).reshape(70, 1000) % 61) - 9,
                                  # offsets from the least value past the type's range (int8: -125 .. 124)
                                  (np.arange(70000).reshape(70, 1000) % 250 - 125).astype(np.int8)])
@pytest.mark.parametrize("associated", [True, False])
def test_pre_classification_is_the_functions_value_at_each_voxel(data, associated):
    """``classify_voxels`` (in place, and through a table of the values for integer data) against colour
    and extinction evaluated at each voxel: equal to the last bit."""
    colour, sigma = TF.evaluate(data.astype(np.float64))
    want = np.concatenate([colour * sigma[..., None] if associated else colour, sigma[..., None]], axis=-1)
    got = TF.classify_voxels(data, associated)
    assert got.shape == data.shape + (4,) and got.dtype == np.float64
    assert np.array_equal(got, want)
