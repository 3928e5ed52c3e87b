import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.fields.grid import Volume, replace_non_finite


def test_geometry_follows_the_node_centred_convention():
    v = Volume(np.zeros((4, 3, 2), np.uint8), spacing=(0.5, 2.0, 1.0), origin=(1.0, 2.0, 3.0))
    assert v.dims == (2, 3, 4)
    lo, hi = v.box
    np.testing.assert_array_equal(lo, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(hi, [1.5, 6.0, 6.0])  # origin + (n - 1) * spacing
    # sample i of n has texture coordinate (i + 0.5) / n
    tex = v.world_to_texture(np.array([[1.0, 2.0, 3.0], [1.5, 6.0, 6.0]]))
    np.testing.assert_allclose(tex, [[0.25, 1 / 6, 1 / 8], [0.75, 5 / 6, 7 / 8]])


def test_single_sample_axis_gets_a_one_spacing_slab():
    v = Volume(np.zeros((1, 3, 3), np.float32), spacing=(1.0, 1.0, 2.0))
    lo, hi = v.box
    assert lo[2] == -1.0 and hi[2] == 1.0
    one = Volume(np.ones((1, 1, 1), np.float32), spacing=(1.0, 2.0, 3.0))
    lo, hi = one.box
    np.testing.assert_array_equal(hi - lo, [1.0, 2.0, 3.0])


@pytest.mark.parametrize("dtype, expect", [
    (np.uint8, np.uint8), (np.uint16, np.uint16), (np.int16, np.int16), (np.float32, np.float32),
    (">i2", np.int16), (np.int8, np.int16), (np.bool_, np.uint8), (np.float64, np.float32),
    (np.int32, np.float32), (np.uint32, np.float32)])
def test_scalar_types_are_normalized(dtype, expect):
    v = Volume(np.arange(8).reshape(2, 2, 2).astype(dtype))
    assert v.data.dtype == np.dtype(expect)
    assert v.data.dtype.isnative
    expected_max = 1.0 if dtype == np.bool_ else 7.0
    assert v.value_range == (0.0, expected_max)


def test_data_is_read_only_and_value_range_is_known():
    v = Volume(np.array([[[-3, 5]]], np.int16))
    assert v.value_range == (-3.0, 5.0)
    with pytest.raises(ValueError):
        v.data[0, 0, 0] = 1


@pytest.mark.parametrize("shape", [(0, 2, 2), (2, 0, 2), (2, 2, 0)])
def test_zero_sized_dims_are_an_error(shape):
    with pytest.raises(VolumeError, match="zero-sized"):
        Volume(np.zeros(shape, np.uint8))


def test_wrong_rank_is_an_error():
    with pytest.raises(VolumeError, match="3D"):
        Volume(np.zeros((2, 2), np.uint8))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_are_an_error_unless_replaced(bad):
    data = np.ones((2, 2, 2), np.float32)
    data[1, 1, 1] = bad
    with pytest.raises(VolumeError, match="1 NaN or Inf.*nan_value"):
        Volume(data)
    v = Volume(replace_non_finite(data, 0.0))
    assert v.data[1, 1, 1] == 0.0 and v.value_range == (0.0, 1.0)


@pytest.mark.parametrize("scale", [1e-35, 1e-40, 1e-45])
def test_float_values_too_close_for_the_gpu_are_refused(scale):
    """Values spanning less than 1e-33 (here 1e-35, and subnormal ones) rendered silently black or wrong on the GPU
    (fields/grid.py, NARROWEST_FLOAT_RANGE): refused in one line that says how to fix them; a constant volume and
    values spanning 1e-30 are kept."""
    data = np.zeros((2, 2, 2), np.float32)
    data[1, 1, 1] = np.float32(scale)
    with pytest.raises(VolumeError, match="too narrow for float32 arithmetic.*scale the data"):
        Volume(data)
    kept = np.zeros((2, 2, 2), np.float32)
    kept[1, 1, 1] = np.float32(1e-30)
    assert Volume(kept).value_range == (0.0, float(np.float32(1e-30)))
    assert Volume(np.full((2, 2, 2), 1e-40, np.float32)).value_range[0] > 0  # constant: nothing to tell apart


def test_float64_beyond_float32_range_is_an_error():
    with pytest.raises(VolumeError, match="float32 range"):
        Volume(np.full((1, 1, 2), 1e300))


@pytest.mark.parametrize("spacing", [(0, 1, 1), (-1, 1, 1), (1, np.nan, 1), (1, 1)])
def test_bad_spacing_is_an_error(spacing):
    with pytest.raises(VolumeError, match="spacing"):
        Volume(np.zeros((2, 2, 2), np.uint8), spacing=spacing)


def test_voxel_distance_uses_the_smallest_spacing():
    v = Volume(np.zeros((2, 2, 2), np.uint8), spacing=(0.5, 2.0, 3.0))
    assert v.voxels_to_world(2.0) == 1.0
