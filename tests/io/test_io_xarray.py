"""xarray DataArrays as volumes: axes by dimension name (a transposed array is read by name, not
misread), coordinates as spacing and origin, and the one-line refusals."""

import numpy as np
import pytest

import dvr_gl
from dvr_gl import Volume
from dvr_gl.errors import VolumeError

xr = pytest.importorskip("xarray", reason="xarray (extra 'xarray')")

DATA = np.arange(4 * 3 * 2, dtype=np.float32).reshape(2, 3, 4)  # [z, y, x]
COORDS = {"z": [10.0, 12.0], "y": [0.0, 0.5, 1.0], "x": [-1.0, -0.75, -0.5, -0.25]}


def test_coordinates_give_spacing_and_origin():
    v = Volume(xr.DataArray(DATA, dims=("z", "y", "x"), coords=COORDS, name="density"))
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.25, 0.5, 2.0) and v.origin == (-1.0, 0.0, 10.0) and v.name == "density"


def test_an_x_y_z_array_is_transposed_by_name():
    da = xr.DataArray(DATA, dims=("z", "y", "x"), coords=COORDS).transpose("x", "y", "z")
    v = Volume.from_xarray(da)
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.25, 0.5, 2.0)


def test_singleton_dims_dropped_and_others_refused():
    da = xr.DataArray(DATA[None], dims=("time", "z", "y", "x"))
    np.testing.assert_array_equal(Volume(da).data, DATA)
    with pytest.raises(VolumeError, match=r"dim 'time' has 2 entries; .* da.isel\(time=...\)"):
        Volume(xr.DataArray(np.stack([DATA, DATA]), dims=("time", "z", "y", "x")))


def test_unnamed_dims_are_refused():
    with pytest.raises(VolumeError, match=r"dims \('dim_0', 'dim_1', 'dim_2'\) names no z, y, x axis"):
        Volume(xr.DataArray(DATA))


def test_uneven_or_decreasing_coordinates_are_refused():
    with pytest.raises(VolumeError, match="'x' coordinate is not evenly spaced"):
        Volume(xr.DataArray(DATA, dims=("z", "y", "x"), coords={**COORDS, "x": [0, 1, 2, 4]}))
    with pytest.raises(VolumeError, match="'y' coordinate is not increasing"):
        Volume(xr.DataArray(DATA, dims=("z", "y", "x"), coords={**COORDS, "y": [2.0, 1.0, 0.0]}))


def test_explicit_geometry_wins():
    v = Volume(xr.DataArray(DATA, dims=("z", "y", "x"), coords=COORDS), spacing=(1, 1, 3), name="mine")
    assert v.spacing == (1.0, 1.0, 3.0) and v.origin == (-1.0, 0.0, 10.0) and v.name == "mine"


def test_render_and_scene_of_keep_an_xarrays_coordinates():
    """dvr_gl.render / scene_of take a DataArray as Volume() does: axes by name, coordinates as geometry."""
    da = xr.DataArray(np.arange(120, dtype=np.float32).reshape(6, 5, 4), dims=("x", "y", "z"),
                      coords={"x": 1.0 + 2.0 * np.arange(6), "y": 0.5 * np.arange(5), "z": 3.0 * np.arange(4)},
                      name="temperature")
    field = dvr_gl.scene_of(da).field
    assert field.dims == (6, 5, 4) and field.spacing == (2.0, 0.5, 3.0) and field.origin == (1.0, 0.0, 0.0)
    assert field.name == "temperature"
    assert field.data[0, 0, 5] == da.isel(x=5, y=0, z=0).item()
