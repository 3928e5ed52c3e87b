"""Multi-resolution (dvr_gl.multires): the downsampler, build_levels, OME-Zarr pyramids read back by
dvr_gl.io, `dvr pyramid`, level choice by projected voxel size, and each level's error."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from conftest import run_cli
from dvr_gl.camera import Camera
from dvr_gl.errors import VolumeError
from dvr_gl.fields.grid import Volume
from dvr_gl.multires import KERNELS, TENT, build_levels, choose_levels, downsample, level_errors, write_pyramid
from dvr_gl.multires import pyramid as pyramid_module
from dvr_gl.multires.downsample import halved_axes, level_geometry
from dvr_gl.renderers.grid.bricking import plan_bricks
from judges import DISCRETE


def ramp(shape, slope=(0.5, -1.25, 2.0), offset=3.0, dtype=np.float32):
    """``offset + slope . (x, y, z)`` on a ``[z, y, x]`` grid of ``shape``."""
    z, y, x = np.indices(shape, dtype=np.float64)
    return (offset + slope[0] * x + slope[1] * y + slope[2] * z).astype(dtype)


# ---------------------------------------------------------------- the downsampler

@pytest.mark.parametrize("dtype,value", [(np.uint8, 200), (np.uint16, 65535), (np.int16, -1024),
                                         (np.float32, 0.1)])
@pytest.mark.parametrize("shape", [(7, 6, 5), (4, 9, 1), (2, 2, 8)])
def test_constant_volume_stays_exactly_constant(dtype, value, shape):
    volume = Volume(np.full(shape, value, dtype), spacing=(0.5, 0.7, 1.0))
    for level in build_levels(volume, count=None) or (downsample(volume),):
        assert level.data.dtype == np.dtype(dtype)
        assert np.array_equal(np.unique(level.data), np.array([value], dtype))  # exactly, edges included


@pytest.mark.parametrize("kernel", ["tent", "binomial"])
@pytest.mark.parametrize("n", [9, 10])
def test_linear_ramp_is_kept(kernel, n):
    """A symmetric kernel keeps linear functions, and the edge taps reflected through the edge sample keep
    them at the edges too; only the extra sample beyond an even axis's box is clipped (its last cell)."""
    data = ramp((n, n, n))
    level = downsample(Volume(data), KERNELS[kernel])
    expected = ramp(level.data.shape, slope=(1.0, -2.5, 4.0))  # spacing doubled: twice the slope per sample
    inside = slice(0, -1) if n % 2 == 0 else slice(None)
    np.testing.assert_allclose(level.data[inside, inside, inside], expected[inside, inside, inside], atol=1e-5)
    assert level.data.min() >= data.min() and level.data.max() <= data.max()  # no overshoot, clip included


@pytest.mark.parametrize("n,coarse,box_hi", [(9, 5, 8.0), (8, 5, 8.0), (3, 2, 2.0), (4, 3, 4.0)])
def test_geometry_keeps_the_origin_and_covers_the_box(n, coarse, box_hi):
    volume = Volume(np.zeros((n, n, n), np.float32), spacing=(1.0, 1.0, 1.0), origin=(-2.0, 3.0, 0.5))
    level = downsample(volume)
    assert level.dims == (coarse,) * 3
    assert level.spacing == (2.0, 2.0, 2.0) and level.origin == volume.origin  # sample j on fine sample 2j
    lo, hi = level.box
    np.testing.assert_allclose(lo, volume.box[0])
    np.testing.assert_allclose(hi - lo, box_hi)  # the level covers level 0's box ((n - 1) fine voxels)
    assert np.all(hi >= volume.box[1]) and np.all(hi - volume.box[1] < np.array(level.spacing))


def test_samples_sit_on_every_other_fine_sample():
    """A spike at an even fine sample lands on one coarse sample with the tent's centre weight."""
    data = np.zeros((9, 9, 9), np.float32)
    data[4, 4, 4] = 64.0
    level = downsample(Volume(data))
    assert level.data[2, 2, 2] == pytest.approx(64.0 / 8)  # 0.5 ** 3 of it
    assert level.data.sum() == pytest.approx(8.0)  # each coarse sample takes its share: 64 / 2 ** 3


def test_integers_are_rounded_in_their_type():
    data = np.zeros((1, 1, 5), np.uint8)
    data[0, 0, 1] = 3  # coarse sample 0 (edge): 3 / 4 * 2 reflected ... ; sample 1 (fine 2): 3 / 4 = 0.75 -> 1
    level = downsample(Volume(data))
    assert level.data.dtype == np.uint8
    assert level.data[0, 0].tolist() == [0, 1, 0]  # rounded, not truncated (0.75 -> 1)
    signed = downsample(Volume(-data.astype(np.int16)))
    assert signed.data[0, 0].tolist() == [0, -1, 0]


def test_one_and_two_sample_axes_are_kept():
    volume = Volume(ramp((2, 1, 9)), spacing=(1.0, 1.0, 1.0))
    assert halved_axes(volume.dims, volume.spacing) == (True, False, False)
    level = downsample(volume)
    assert level.dims == (5, 1, 2) and level.spacing == (2.0, 1.0, 1.0)
    np.testing.assert_allclose(level.box[0], volume.box[0])  # the one-sample axis keeps its slab
    np.testing.assert_allclose(level.box[1], volume.box[1])
    assert downsample(Volume(np.zeros((2, 1, 2), np.float32))).dims == (2, 1, 2)  # nothing can be halved


def test_anisotropic_spacing_halves_the_finer_axes_first():
    dims, spacing, origin = (64, 64, 32), (0.5, 0.5, 2.0), (0.0, 0.0, 0.0)
    steps = []
    for _ in range(3):
        dims, spacing, origin, halved = level_geometry(dims, spacing, origin)
        steps.append((halved, spacing))
    assert steps == [((True, True, False), (1.0, 1.0, 2.0)), ((True, True, False), (2.0, 2.0, 2.0)),
                     ((True, True, True), (4.0, 4.0, 4.0))]
    # within sqrt(2) of the finest counts as finest: (1, 1, 1.4) is halved whole
    assert halved_axes((10, 10, 10), (1.0, 1.0, 1.4)) == (True, True, True)


def test_low_pass_removes_aliasing():
    """Above the coarse Nyquist frequency (0.25 cycles per fine voxel) every other sample keeps a
    sinusoid whole (it aliases); the tent keeps cos^2(pi f) of it."""
    assert KERNELS["nearest"].response(0.375) == pytest.approx(1.0)
    for f in (0.125, 0.25, 0.375):
        assert TENT.response(f) == pytest.approx(math.cos(math.pi * f) ** 2)
    n = 65
    x = np.arange(n)
    wave = np.broadcast_to(np.cos(2 * np.pi * 0.375 * x), (5, 5, n)).astype(np.float32)
    coarse = downsample(Volume(wave, spacing=(1.0, 4.0, 4.0))).data[2, 2, 2:-2]  # away from the edges
    assert np.abs(coarse).max() == pytest.approx(TENT.response(0.375), rel=1e-3)


# ---------------------------------------------------------------- levels

def test_build_levels_stops_at_32_or_count():
    volume = Volume(np.zeros((40, 100, 70), np.uint8), spacing=(1.0, 1.0, 1.0), origin=(1.0, 2.0, 3.0))
    levels = build_levels(volume)
    assert [lv.dims for lv in levels] == [(36, 51, 21), (19, 26, 11)]  # 26 <= 32: the last
    assert all(lv.origin == volume.origin for lv in levels)
    assert [lv.spacing for lv in levels] == [(2.0, 2.0, 2.0), (4.0, 4.0, 4.0)]
    assert len(build_levels(volume, count=1)) == 1 and build_levels(volume, count=0) == ()
    assert volume.with_levels(levels).levels == levels
    with pytest.raises(VolumeError, match="at most 8 levels"):
        build_levels(volume, count=9)


# ---------------------------------------------------------------- OME-Zarr

@pytest.fixture
def zarr_module():
    return pytest.importorskip("zarr", reason="OME-Zarr pyramids need zarr (extra 'zarr')")


def test_pyramid_is_read_back_by_dvr_gl_io(tmp_path, zarr_module, monkeypatch):
    from dvr_gl.io import load_volume

    rng = np.random.default_rng(0)
    data = rng.integers(0, 4000, size=(13, 22, 17)).astype(np.int16)
    volume = Volume(data, spacing=(0.5, 0.75, 1.5), origin=(-3.0, 2.0, 10.0), name="noise")
    monkeypatch.setattr(pyramid_module, "BLOCK_BYTES", 20000)  # many small tiles: the slab seams are tested
    out = tmp_path / "p.zarr"
    plan = write_pyramid(volume, out, levels=3, chunks=4, unit="millimeter")
    # x (0.5) first; y (0.75, beyond sqrt(2) x 0.5) at level 2; z (1.5) waits
    assert [p[0] for p in plan] == [(17, 22, 13), (9, 22, 13), (5, 12, 13)]
    level0 = load_volume(out)
    assert np.array_equal(level0.data, data)
    assert level0.spacing == volume.spacing and level0.origin == volume.origin
    in_memory = build_levels(volume)
    for index, level in enumerate(in_memory, 1):  # the slab-by-slab writer equals the in-memory levels
        read = load_volume(out, level=index)
        assert np.array_equal(read.data, level.data)
        assert read.spacing == level.spacing and read.origin == level.origin
    attrs = zarr_module.open_group(str(out), mode="r").attrs["multiscales"][0]
    assert attrs["version"] == "0.4" and [a["name"] for a in attrs["axes"]] == ["z", "y", "x"]
    assert attrs["axes"][0]["unit"] == "millimeter" and attrs["type"] == "tent"
    assert not [p for p in tmp_path.iterdir() if p.name != "p.zarr"]  # no temporary left


def test_pyramid_refusals(tmp_path, zarr_module):
    volume = Volume(np.zeros((8, 8, 8), np.uint8))
    (tmp_path / "there.zarr").mkdir()
    for kwargs, message in [({"out_path": tmp_path / "there.zarr"}, "already exists"),
                            ({"out_path": tmp_path / "a.zarr", "levels": 0}, "at least 1"),
                            ({"out_path": tmp_path / "a.zarr", "levels": 9}, "at most 4 levels"),
                            ({"out_path": tmp_path / "a.zarr", "chunks": 2}, "chunk size"),
                            ({"out_path": tmp_path / "a.zarr", "unit": "furlong"}, "space unit")]:
        with pytest.raises(VolumeError, match=message):
            write_pyramid(volume, **kwargs)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["there.zarr"]  # nothing written, nothing left


# ---------------------------------------------------------------- dvr pyramid

def test_dvr_pyramid(tmp_path, capsys, zarr_module):
    source = tmp_path / "v.npy"
    data = ramp((9, 10, 11), dtype=np.float32)
    np.save(source, data)
    out = tmp_path / "v.zarr"
    code, stdout, err = run_cli(capsys, "pyramid", source, out, "--levels", "2", "--chunks", "8")
    assert code == 0, err
    assert "level 1: 6x6x5, spacing 2, 2, 2" in stdout
    code, stdout, _ = run_cli(capsys, "info", out, "--level", "1")
    assert code == 0 and "6x6x5" in stdout
    # refusals: one line each, exit 1, nothing overwritten or left behind
    before = sorted(p.name for p in tmp_path.iterdir())
    for argv, message in [((source, out), "already exists"), ((source, tmp_path / "b.zarr", "--levels", "0"),
                                                              "at least 1"),
                          ((source, tmp_path / "b.zarr", "--levels", "7"), "at most 5 levels"),
                          ((tmp_path / "missing.npy", tmp_path / "b.zarr"), "not found")]:
        code, _, err = run_cli(capsys, "pyramid", *argv)
        assert code == 1 and message in err and len(err.strip().splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_dvr_pyramid_without_zarr(tmp_path, capsys, monkeypatch):
    np.save(tmp_path / "v.npy", np.zeros((4, 4, 4), np.float32))
    monkeypatch.setitem(sys.modules, "zarr", None)  # import zarr raises ImportError
    code, _, err = run_cli(capsys, "pyramid", tmp_path / "v.npy", tmp_path / "v.zarr")
    assert code == 1 and "pip install -e '.[zarr]'" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "v.zarr").exists()


# ---------------------------------------------------------------- level choice

def levels_of(n=33, spacing=1.0):
    volume = Volume(np.zeros((n, n, n), np.uint8), spacing=(spacing,) * 3)
    return (volume, *build_levels(volume, count=3))  # voxels of 1, 2, 4, 8 world units


def test_choose_levels_orthographic_zoom():
    """Orthographic: one voxel of spacing s spans s * H / view_height pixels everywhere."""
    levels = levels_of()
    bricks = plan_bricks(levels[0].dims, 20)
    assert len(bricks) > 1
    for view_height, expected in [(100.0, 0), (200.0, 1), (400.0, 2), (1000.0, 3), (5000.0, 3)]:
        # 100 pixels high: level L's voxel (2^L units) spans 2^L * 100 / view_height pixels
        cam = Camera((16.0, -500.0, 16.0), (16.0, 16.0, 16.0), projection="orthographic", view_height=view_height)
        assert choose_levels(bricks, levels, cam, 100, 100) == [expected] * len(bricks)
    cam = Camera((16.0, -500.0, 16.0), (16.0, 16.0, 16.0), projection="orthographic", view_height=400.0)
    assert set(choose_levels(bricks, levels, cam, 100, 100, pixel_error=0.5)) == {1}  # 2 px at level 2


def test_choose_levels_perspective_distance():
    """Perspective, fov 90 (tan 45 = 1), 100 pixels high: a voxel of s at distance d spans 50 s / d pixels;
    the brick's nearest point is what counts."""
    levels = levels_of()
    brick = plan_bricks(levels[0].dims, 64)[0]  # the whole box [0, 32]^3
    for distance, expected in [(49.0, 0), (60.0, 0), (101.0, 1), (150.0, 1), (201.0, 2), (401.0, 3)]:
        cam = Camera((16.0, -distance, 16.0), (16.0, 16.0, 16.0), fov=90.0)  # nearest point (16, 0, 16)
        assert choose_levels([brick], levels, cam, 100, 100) == [expected], distance
    bricks = plan_bricks(levels[0].dims, 20)  # nearer bricks get finer levels
    cam = Camera((16.0, -90.0, 16.0), (16.0, 16.0, 16.0), fov=90.0)  # near bricks at 90, far ones at 106
    chosen = choose_levels(bricks, levels, cam, 100, 100)
    near = [c for b, c in zip(bricks, chosen) if b.core_lo[1] == 0]
    far = [c for b, c in zip(bricks, chosen) if b.core_lo[1] > 0]
    assert set(near) == {0} and set(far) == {1}


def test_choose_levels_eye_inside_a_brick_is_full_resolution():
    levels = levels_of()
    bricks = plan_bricks(levels[0].dims, 20)
    cam = Camera((3.0, 3.0, 3.0), (30.0, 30.0, 30.0), fov=90.0)
    chosen = choose_levels(bricks, levels, cam, 10, 10)  # 10 pixels: far bricks are coarse
    inside = [c for b, c in zip(bricks, chosen) if all(lo <= 3 <= hi for lo, hi in zip(b.core_lo, b.core_hi))]
    assert inside == [0] and max(chosen) > 0


# ---------------------------------------------------------------- measured error

def test_level_errors_decrease_with_finer_levels(gl_context):
    from dvr_gl.phantoms import demo_scene
    from dvr_gl.scene.resolve import load_scene

    scene = load_scene(None, {"volume.size": 40, "image.width": 40, "image.height": 40}, demo_scene("blobs"))
    levels = (scene.field, *build_levels(scene.field, count=2))
    rows = level_errors(scene, levels, ctx=gl_context)
    assert [r["level"] for r in rows] == [0, 1, 2] and rows[0]["rms"] == 0.0
    # each level loses more than the one finer (blobs are smooth: no feature vanishes early); a floor of
    # 1e-3 so that the GPU's float32 noise (1e-6) cannot pass for a level's error
    assert 1e-3 < rows[1]["rms"] < rows[2]["rms"]
    assert rows[2]["voxel_px"] == pytest.approx(2 * rows[1]["voxel_px"]) == pytest.approx(4 * rows[0]["voxel_px"])
    reference = level_errors(scene, levels, renderer=DISCRETE)  # the float64 integrator agrees
    for gpu, ref in zip(rows[1:], reference[1:]):
        assert gpu["rms"] == pytest.approx(ref["rms"], rel=0.05)  # same samples; float32 and texture filtering
