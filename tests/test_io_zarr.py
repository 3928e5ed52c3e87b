"""zarr arrays and OME-Zarr images written here with zarr: axes found by name, levels, the
coordinate transformations as spacing and origin, and the refusals."""

import numpy as np
import pytest

from dvr_gl.errors import VolumeError
from dvr_gl.io import detect_format, load_volume

zarr = pytest.importorskip("zarr", reason="zarr reads zarr stores (extra 'zarr')")

DATA = np.arange(4 * 3 * 2, dtype=np.uint16).reshape(2, 3, 4)  # [z, y, x]


def write_ome(path, data_zyx=DATA, axes=("z", "y", "x"), extra=(), levels=2, translation=(10.0, 20.0, 30.0)):
    """An OME-Zarr 0.4 image: ``axes`` in the stored order (``extra`` axes of size 1 or more in front), each
    level half the last along x and y; scale (z, y, x) = (2, 0.75, 0.5) at level 0."""
    group = zarr.open_group(str(path), mode="w")
    base = {"z": 2.0, "y": 0.75, "x": 0.5}
    shift = dict(zip("zyx", translation))
    datasets = []
    for level in range(levels):
        step = 2 ** level
        zyx = data_zyx[:, ::step, ::step]
        stored = np.transpose(zyx, ["zyx".index(a) for a in axes])
        stored = np.broadcast_to(stored, tuple(n for _, n in extra) + stored.shape)  # t, c in front
        group.create_array(str(level), data=np.ascontiguousarray(stored))
        scale = [1.0] * len(extra) + [base[a] * (1 if a == "z" else step) for a in axes]
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": scale},
            {"type": "translation", "translation": [0.0] * len(extra) + [shift[a] for a in axes]}]})
    kinds = {"t": "time", "c": "channel"}
    group.attrs["multiscales"] = [{"version": "0.4", "datasets": datasets, "axes":
                                   [{"name": n, "type": kinds[n]} for n, _ in extra]
                                   + [{"name": a, "type": "space", "unit": "micrometer"} for a in axes]}]
    return path


def test_plain_array_and_group_with_one_array(tmp_path):
    zarr.save_array(str(tmp_path / "a.zarr"), DATA)
    assert detect_format(tmp_path / "a.zarr") == "zarr"
    np.testing.assert_array_equal(load_volume(tmp_path / "a.zarr").data, DATA)
    group = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    group.create_array("density", data=DATA)
    np.testing.assert_array_equal(load_volume(tmp_path / "g.zarr").data, DATA)
    group.create_array("labels", data=DATA + 1)
    with pytest.raises(VolumeError, match=r"holds 2 arrays \('density', 'labels'\); name one with volume.array"):
        load_volume(tmp_path / "g.zarr")
    np.testing.assert_array_equal(load_volume(tmp_path / "g.zarr", array="labels").data, DATA + 1)


def test_ome_zarr_level_0_scale_and_translation(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.ome.zarr"))
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 0.75, 2.0) and v.origin == (30.0, 20.0, 10.0)


def test_ome_zarr_coarser_level(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.ome.zarr"), level=1)
    np.testing.assert_array_equal(v.data, DATA[:, ::2, ::2])
    assert v.spacing == (1.0, 1.5, 2.0)
    with pytest.raises(VolumeError, match="volume.level 2 is out of range; the image has 2 levels"):
        load_volume(tmp_path / "i.ome.zarr", level=2)


def test_axes_in_another_order_are_transposed_by_name(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.zarr", axes=("x", "y", "z")))
    np.testing.assert_array_equal(v.data, DATA)
    assert v.spacing == (0.5, 0.75, 2.0) and v.origin == (30.0, 20.0, 10.0)


def test_singleton_time_and_channel_are_dropped(tmp_path):
    v = load_volume(write_ome(tmp_path / "i.zarr", extra=(("t", 1), ("c", 1))))
    np.testing.assert_array_equal(v.data, DATA)


def test_several_channels_are_refused(tmp_path):
    with pytest.raises(VolumeError, match="the channel axis 'c' has 3 entries"):
        load_volume(write_ome(tmp_path / "i.zarr", extra=(("c", 3),)))


def test_level_on_a_plain_group_is_refused(tmp_path):
    group = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    group.create_array("density", data=DATA)
    with pytest.raises(VolumeError, match="volume.level applies to OME-Zarr"):
        load_volume(tmp_path / "g.zarr", level=1)


def test_not_a_volume(tmp_path):
    zarr.save_array(str(tmp_path / "a.zarr"), np.zeros((3, 4)))
    with pytest.raises(VolumeError, match=r"shape \(3, 4\); a volume needs 3 dimensions"):
        load_volume(tmp_path / "a.zarr")
