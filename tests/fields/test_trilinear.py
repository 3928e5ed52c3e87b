"""The scalar trilinear path of SampledField.sample (``_trilinear``, axis by axis in chunks) against the
general taps (``taps()``: the 8 samples and their weights, clamped to the edge), and against a closed form."""

import numpy as np
import pytest

from dvr_gl.fields import reconstruction
from dvr_gl.fields.reconstruction import SampledField


def taps_value(field: SampledField, points: np.ndarray) -> np.ndarray:
    rows, weights = field.taps(points)
    return (field.flat[rows, 0] * weights).sum(axis=1)


@pytest.mark.parametrize("shape", [(7, 5, 9), (1, 1, 1), (1, 4, 2), (3, 1, 1), (2, 2, 2)])
@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.float32])
def test_trilinear_equals_the_taps_inside_on_and_beyond_the_box(shape, dtype, monkeypatch):
    """Axes of one and two samples, points beyond the box (clamped to the edge), on its faces and at sample
    positions; several chunks (CHUNK made small).  Float64 rounding only: the two paths sum the same eight
    products in another order (measured up to 4e-16 of the values)."""
    monkeypatch.setattr(reconstruction, "CHUNK", 97)
    rng = np.random.default_rng(3)
    data = (rng.random(shape) * 200 - (50 if dtype == np.int16 else 0)).astype(dtype)
    spacing, origin = np.array([0.5, 1.25, 2.0]), np.array([1.0, -2.0, 0.25])
    field = SampledField(data, spacing, origin)
    extent = (np.array(shape[::-1]) - 1) * spacing
    points = origin - 0.3 * extent - 1.0 + rng.random((1000, 3)) * (1.6 * extent + 2.0)
    corners = origin + np.array([[0, 0, 0], [1, 1, 1], [0.5, 0, 1], [1, 0.25, 0]]) * extent
    points = np.concatenate([points, corners])
    got = field.sample(points)
    assert got.shape == (len(points),) and got.dtype == np.float64
    scale = max(1.0, float(np.abs(data).max()))
    assert np.max(np.abs(got - taps_value(field, points))) <= 1e-14 * scale


def test_trilinear_reproduces_a_trilinear_function_exactly():
    """A field trilinear in x, y, z (its own interpolant) is reproduced everywhere inside the box."""
    z, y, x = np.meshgrid(np.arange(4.0), np.arange(6.0), np.arange(5.0), indexing="ij")
    f = lambda x, y, z: 1.0 + 2.0 * x - y + 0.5 * z + 0.25 * x * y * z  # noqa: E731  in voxel units
    field = SampledField(f(x, y, z), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    p = np.random.default_rng(0).random((500, 3)) * [4.0, 5.0, 3.0]
    assert np.allclose(field.sample(p), f(p[:, 0], p[:, 1], p[:, 2]), rtol=0, atol=1e-12)
