"""The ray caster's side of issue 22: bricks read apart (out of core, coarser levels).

The texture LRU, the acceleration pyramid built from block ranges, the transparency test that
leaves empty bricks out, and images: a volume read out of core renders as the same volume in
memory, a coarse level of a linear field renders as the fine one.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from dvr_gl.renderers import registry
from dvr_gl.renderers.grid.lru import TextureLRU
from dvr_gl.renderers.raycast import acceleration as accel
from dvr_gl.renderers.raycast.out_of_core import transparent
from dvr_gl.transfer_function import TransferFunction


class FakeTexture:
    def __init__(self, log, name):
        self.log, self.name = log, name

    def release(self):
        self.log.append(self.name)


def test_texture_lru_keeps_the_most_recent_within_its_budget():
    released = []
    lru = TextureLRU(budget=30)

    def make(name, size):
        return lambda: ({"u_volume": FakeTexture(released, name)}, size)

    lru.get("a", make("a", 10))
    lru.get("b", make("b", 10))
    lru.get("a", make("a", 10))   # a hit: "a" is now the most recent
    lru.get("c", make("c", 10))
    assert released == [] and lru.used == 30
    lru.get("d", make("d", 10))   # over the budget: the least recently used ("b") goes
    assert released == ["b"]
    assert (lru.hits, lru.misses, lru.uploaded) == (1, 4, 40)
    lru.get("e", make("e", 100))  # alone over the budget: kept (a pass needs its brick), the rest go
    assert sorted(released) == ["a", "b", "c", "d"] and lru.used == 100
    lru.release()
    assert released[-1] == "e" and lru.used == 0


def block_ranges(data, block):
    """Each block's own voxels' minimum and maximum, by brute force."""
    nz, ny, nx = data.shape
    shape = tuple(-(-n // block) for n in data.shape)
    mins, maxs = np.empty(shape), np.empty(shape)
    for k in range(shape[0]):
        for j in range(shape[1]):
            for i in range(shape[2]):
                part = data[k * block:(k + 1) * block, j * block:(j + 1) * block, i * block:(i + 1) * block]
                mins[k, j, i], maxs[k, j, i] = part.min(), part.max()
    return types.SimpleNamespace(mins=mins, maxs=maxs, block_size=block)


@pytest.mark.parametrize("support", [(0, 1), (1, 2)])
def test_pyramid_from_block_ranges_holds_the_exact_one(support):
    """The pyramid from plain block ranges (no pass over the voxels) contains, at every level and
    block, the range the exact pyramid computes from the voxels: skipping by it stays exact."""
    rng = np.random.default_rng(3)
    data = rng.random((40, 37, 70)).astype(np.float32)
    data[:, :, 35:] *= 0.1  # different ranges in different blocks
    exact = accel.MinMaxPyramid.build(data, 8, support)
    wide = accel.MinMaxPyramid.from_ranges(block_ranges(data, 8), support)
    assert len(wide.levels) == len(exact.levels)
    for (emin, emax), (wmin, wmax) in zip(exact.levels, wide.levels):
        assert wmin.shape == emin.shape
        assert (wmin <= emin).all() and (wmax >= emax).all()
    # and it is not the whole volume's range everywhere: blocks far apart keep their own
    assert wide.levels[0][1][:, :, 0].max() > 0.9 and wide.levels[0][1][:, :, -1].max() < 0.11


def test_transparent_finds_every_opaque_value_of_the_range():
    """A range is transparent only where the exact transfer function and the table nodes around it
    are all zero: a narrow spike inside the range is found, one beyond the nodes' reach is not."""
    tf = TransferFunction(np.array([[0, 0, 0, 0, 0.0], [50, 1, 1, 1, 0.0], [50.5, 1, 1, 1, 0.8],
                                    [51, 1, 1, 1, 0.0], [100, 1, 1, 1, 0.0]]))
    grid = [((0.0, 100.0), 101)]  # table nodes at every integer value
    assert transparent(tf, 0, 49, grid)
    assert not transparent(tf, 50.2, 50.7, grid)   # inside the spike
    assert transparent(tf, 49.5, 49.9, grid)       # widened to the nodes 49 .. 50: the spike starts at 50
    assert not transparent(tf, 49.5, 50.1, grid)   # widened to 49 .. 51: the spike is in
    assert transparent(tf, 52.0, 100.0, grid)
    assert not transparent(tf, 51.2, 52.0, [((0.0, 100.0), 11)])  # coarse nodes 50 .. 60 take the spike in


# --- images -------------------------------------------------------------------------------------------

from dvr_gl.api import scene_of  # noqa: E402
from dvr_gl.errors import SceneError  # noqa: E402
from dvr_gl.fields.grid import Volume  # noqa: E402
from dvr_gl.gl.context import make_current  # noqa: E402
from dvr_gl.out_of_core import open_volume, write_synthetic_raw  # noqa: E402
from dvr_gl.renderers.raycast.renderer import RayCastRenderer  # noqa: E402

# The synthetic volume's shell has 0.5 of the range (32767), its blobs up to 1: a transfer function
# from 40000 up shows the blobs only, so the bricks the shell alone crosses are empty.
BLOBS_ONLY = [[0, 0, 0, 0, 0], [40000, 0, 0, 0, 0], [50000, 1, 0.8, 0.5, 0.3], [65535, 1, 1, 1, 0.9]]
SHELL_TOO = [[0, 0, 0, 0, 0], [10000, 0, 0, 0, 0], [30000, 1, 0.8, 0.5, 0.3], [65535, 1, 1, 1, 0.9]]


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A 70x64x60 uint16 synthetic volume on disk, read out of core and in memory."""
    nhdr = write_synthetic_raw(tmp_path_factory.mktemp("ooc") / "s.raw", (70, 64, 60), "uint16")
    return open_volume(nhdr, out_of_core=True, memory_budget_mb=1), open_volume(nhdr, out_of_core=False)


@pytest.fixture(scope="module")
def raycaster(shared_gl_context):
    """A ray caster on the session's context (borrowed: its programs stay compiled for the other modules)."""
    with RayCastRenderer(ctx=make_current(shared_gl_context)) as r:
        yield r


# Bricks of at most 0.05 MB (27 or more) in both: the volume in memory is bricked by the texture budget,
# the one out of core by the smaller of it and an eighth of the memory budget; the same plan, so the
# same textures and the same passes: the images must be equal bit for bit.
CASES = [dict(compositing="emission_absorption"), dict(compositing="emission_absorption", acceleration="on"),
         dict(compositing="emission_absorption", classification="preintegrated"),
         dict(compositing="emission_absorption", classification="pre"),
         dict(compositing="emission_absorption", shading=True),
         dict(compositing="mip"), dict(compositing="mip", acceleration="on"), dict(compositing="xray"),
         dict(compositing="isosurface", iso_value=30000.0)]


@pytest.mark.parametrize("settings", CASES, ids=lambda c: "-".join(str(v) for v in c.values()))
@pytest.mark.parametrize("tf", [BLOBS_ONLY, SHELL_TOO], ids=["blobs", "shell"])
def test_out_of_core_renders_as_in_memory(synthetic, raycaster, settings, tf):
    out_of_core, in_memory = synthetic
    # The step fixed: the scene-chosen defaults simulate on voxels in memory, an out-of-core volume keeps
    # 0.5 voxel (docs/tolerance.md); this test compares the bricks' pipeline at one setting.
    scene = scene_of(in_memory, size=(48, 40), transfer_function=tf, texture_budget_mb=0.05,
                     sample_distance_voxels=0.5, **settings)
    expected = raycaster.render(scene)
    bricks = raycaster.stats["bricks"]
    assert bricks >= 27  # 27 at least (more where segments reach further: wider ghosts, smaller cores)
    image = raycaster.render(scene.replace(volume=out_of_core, camera=scene.camera))
    assert np.array_equal(image, expected)
    assert expected[..., 3].max() > 0.05  # something is drawn
    empty = raycaster.stats.get("bricks_empty") or 0
    assert raycaster.stats["bricks"] + empty == bricks
    if tf is BLOBS_ONLY and settings["compositing"] in ("emission_absorption", "xray"):
        assert empty >= 9  # the shell's bricks were neither read nor drawn
    else:
        assert not empty


def test_out_of_core_refusals_are_one_line(synthetic):
    import dvr_gl

    out_of_core, _ = synthetic
    in_memory = next(n for n, p in registry.plugins().items() if p.needs_gl and not p.out_of_core)
    with pytest.raises(SceneError, match=rf"{in_memory} needs the voxels in memory.*use raycast") as err:
        dvr_gl.render(out_of_core, renderer=in_memory, size=(16, 16))
    assert "\n" not in str(err.value)
    with pytest.raises(SceneError, match="gradient = 'central'"):
        dvr_gl.render(out_of_core, size=(16, 16), shading=True, gradient="texture")


def linear_with_level():
    """A linear field and its level 1 (every other sample: exact for a linear field under trilinear
    interpolation), over the same box (odd sample counts)."""
    z, y, x = np.mgrid[0:33, 0:41, 0:37].astype(np.float32)
    data = (0.3 * x + 0.2 * y + 0.5 * z).astype(np.float32)
    fine = Volume(data, spacing=(1.0, 1.2, 0.9))
    coarse = Volume(data[::2, ::2, ::2].copy(), spacing=(2.0, 2.4, 1.8))
    return fine, fine.with_levels([coarse])


@pytest.mark.parametrize("compositing", ["emission_absorption", "mip"])
def test_a_coarse_level_of_a_linear_field_renders_as_the_fine_one(raycaster, compositing):
    """Bricks drawn from level 1 own the same samples (by level-0 coordinates) and, the field being
    linear, sample the same values: the image equals the fine volume's to float32 rounding (measured
    1.2e-7; 1e-6 allows for the different texture coordinates' rounding)."""
    fine, with_level = linear_with_level()
    tf = [[0, 0, 0, 0, 0], [60, 1, 0.5, 0.2, 0.05]]
    scene = scene_of(fine, size=(64, 48), compositing=compositing, transfer_function=tf, ert_threshold=1.0)
    expected = raycaster.render(scene)
    levelled = scene.replace(volume=with_level, camera=scene.camera).with_renderer(screen_space_error=1e6)
    image = raycaster.render(levelled)
    assert raycaster.stats["brick_levels"] == [0, 1]
    assert np.abs(image - expected).max() < 1e-6
    raycaster.render(levelled.with_renderer(screen_space_error=0.0))
    assert raycaster.stats["brick_levels"] == [1, 0]


def test_smaller_frames_choose_coarser_levels(raycaster):
    """The level follows the frame's pixels: the viewer's interactive frames (fewer pixels) draw from
    coarser levels than the full frame it refines to when idle."""
    from dvr_gl.multires import build_levels

    rng = np.random.default_rng(1)
    fine = Volume(rng.random((64, 64, 64)).astype(np.float32))
    volume = fine.with_levels(build_levels(fine))
    scene = scene_of(volume, size=(256, 256), transfer_function=[[0, 0, 0, 0, 0], [1, 1, 1, 1, 0.2]])
    raycaster.render(scene)
    full = raycaster.stats["brick_levels"]
    raycaster.render(scene.replace(image=scene.image.__class__(width=32, height=32)))
    small = raycaster.stats["brick_levels"]
    mean = lambda counts: np.dot(counts, np.arange(len(counts))) / sum(counts)  # noqa: E731
    assert mean(small) > mean(full)


def peak_rss_mib(args: list[str]) -> float:
    """Peak resident memory (MiB) of ``dvr render ARGS`` in a child process: its ``VmHWM``, the high-water
    mark of the pages it touched, mapped files' and (on llvmpipe) textures' included, as ``/usr/bin/time
    -v`` reports it.  Not ``getrusage``'s ``ru_maxrss``: a child forked from this test process starts
    with the parent's (measured: 2.8 GiB within the full suite), whatever it does itself."""
    import subprocess
    import sys

    code = ("import re, sys; from dvr_gl.apps.cli import main; rc = main(sys.argv[1:]); "
            "print('VMHWM', re.search(r'VmHWM:\\s*(\\d+)', open('/proc/self/status').read()).group(1)); "
            "sys.exit(rc)")
    done = subprocess.run([sys.executable, "-c", code, "render", *args], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return int(done.stdout.split("VMHWM")[-1].split()[0]) / 1024


def test_peak_memory_rendering_a_volume_four_times_the_budget(tmp_path):
    """Rendering a 160 MiB volume with renderer.memory_budget_mb = 32 and texture_budget_mb = 8 (its
    bricks read and uploaded one at a time, empty ones skipped): the peak resident memory (VmHWM) over the same
    command on a 64^3 volume in memory (Python, numpy, GL, programs) stays within the two budgets
    plus 32 MiB (a mapped window of the reader, 16 MiB, and the frame's buffers); measured +23 MiB (a 320 MiB
    volume with budgets of 64 and 16 MiB, the same ratios, took 1.3x the time: +30 to +65 MiB of 112).  Loading it
    whole instead adds its 160 MiB and more (measured +338 MiB): the control that the measure sees the voxels."""
    nhdr = write_synthetic_raw(tmp_path / "big.raw", (512, 320, 512), "uint16")
    np.save(tmp_path / "tiny.npy", np.zeros((64, 64, 64), np.uint16))
    budgets = ["--size", "128", "--set", "renderer.memory_budget_mb=32", "--set", "renderer.texture_budget_mb=8"]
    baseline = peak_rss_mib([str(tmp_path / "tiny.npy"), "-o", str(tmp_path / "t.png"), *budgets])
    out_of_core = peak_rss_mib([str(nhdr), "-o", str(tmp_path / "a.png"), *budgets])
    assert out_of_core - baseline <= 32 + 8 + 32, (baseline, out_of_core)
    whole = peak_rss_mib([str(nhdr), "-o", str(tmp_path / "b.png"), "--size", "128", "--set",
                          "volume.out_of_core=false"])
    assert whole - baseline > 160


def test_bench_scale_sizes_prints_its_table(tmp_path, capsys):
    """``dvr bench scale --part sizes`` on a 10 MiB volume, 64x64 frames: a row per run, peak memory within the
    bound; a size outside 8 to 4096 is refused in one line."""
    from dvr_gl.apps.cli import main

    assert main(["bench", "scale", "--part", "sizes", "--sizes", "0.01", "--data-dir", str(tmp_path),
                 "--size", "64"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| 0.01 |")]
    assert [row.split("|")[3].strip() for row in rows] == ["first", "again"]
    assert all(float(row.split("|")[-2]) < 1.0 for row in rows)  # peak / bound
    assert list(tmp_path.glob("*.dvr-ranges.npz"))  # the first run wrote the block ranges' sidecar
    assert main(["bench", "scale", "--part", "sizes", "--size", "4"]) == 1
    err = capsys.readouterr().err
    assert "--size must be 8 to 4096, got 4" in err and len(err.strip().splitlines()) == 1


def test_an_ome_zarr_pyramid_read_out_of_core_renders_its_levels(tmp_path, raycaster):
    """An OME-Zarr pyramid written by dvr_gl.multires and opened out of core (its levels too) renders
    bit for bit as the same volume in memory with the same levels (build_levels), brick by brick, at
    every screen-space error; a large error draws coarser levels."""
    pytest.importorskip("zarr", reason="OME-Zarr needs the zarr extra")
    from dvr_gl.multires import build_levels, write_pyramid

    rng = np.random.default_rng(5)
    z, y, x = np.mgrid[0:40, 0:36, 0:44]
    data = (1000 * np.exp(-((x - 20) ** 2 + (y - 18) ** 2 + (z - 22) ** 2) / 150.0)
            + rng.integers(0, 60, size=x.shape)).astype(np.uint16)
    fine = Volume(data, spacing=(1.0, 1.1, 0.9))
    store = tmp_path / "p.zarr"
    write_pyramid(fine, store, levels=3, chunks=16)
    on_disk = open_volume(store, out_of_core=True, memory_budget_mb=0.25)
    assert len(on_disk.levels) == 2
    in_memory = fine.with_levels(build_levels(fine, 2))  # the coarser levels only (write_pyramid counts all)
    tf = [[0, 0, 0, 0, 0], [100, 0, 0, 0, 0], [800, 1, 0.7, 0.4, 0.2]]
    for error in (0.0, 1.0, 50.0):
        scene = scene_of(in_memory, size=(40, 32), transfer_function=tf, screen_space_error=error,
                         texture_budget_mb=0.25 / 8, sample_distance_voxels=0.5)  # as out of core (above)
        expected = raycaster.render(scene)
        levels = raycaster.stats["brick_levels"]
        image = raycaster.render(scene.replace(volume=on_disk, camera=scene.camera))
        assert raycaster.stats["brick_levels"] == levels and sum(levels) > 1
        assert np.array_equal(image, expected)
    assert levels[0] == 0  # at 50 pixels a voxel, every brick from a coarser level


def test_subsample_and_dvr_info_of_a_volume_read_out_of_core(synthetic, tmp_path, capsys, monkeypatch):
    """``dvr info`` on a volume larger than renderer.memory_budget_mb's default opens it out of core: the
    value range from the block ranges (exact), the histogram from an even subsample (every s-th voxel)."""
    import dvr_gl.out_of_core as ooc
    from dvr_gl.apps.cli import main

    out_of_core, in_memory = synthetic
    sub = out_of_core.subsample(4000)
    stride = 5  # ceil((70 * 64 * 60 / 4000) ** (1/3)) = ceil(4.07)
    assert np.array_equal(sub, in_memory.data[::stride, ::stride, ::stride]) and sub.size <= 4000
    monkeypatch.setattr(ooc, "MEMORY_BUDGET_MB", 0.1)  # the default budget, for this test: under the volume
    path = out_of_core.source.path.with_suffix(".nhdr")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    lo, hi = in_memory.value_range
    assert f"value range: {lo:g} .. {hi:g}" in out and "read out of core" in out and "histogram (8 bins" in out


def test_a_frame_whose_every_brick_is_empty(synthetic, raycaster):
    """A transfer function transparent over the whole value range leaves every brick out: the frame is
    transparent, drawn with no pass (it ended in an IndexError before), and so is render_state's."""
    out_of_core, _ = synthetic
    scene = scene_of(out_of_core, size=(16, 16), transfer_function=[[0, 0, 0, 0, 0], [65535, 1, 1, 1, 0]])
    image = raycaster.render(scene)
    assert raycaster.stats["bricks"] == 0 and raycaster.stats["bricks_empty"] >= 1
    assert not image.any()
    assert not raycaster.render_state(scene, raycaster.brick_plan(scene)).any()


def test_a_forged_sidecar_does_not_empty_the_picture(tmp_path, raycaster, caplog):
    """Issue 40: a sidecar forged with the data's real key (size, modification time) and every block's
    range 0..0 would have every brick skipped as empty, a blank picture with exit 0; unsigned by this
    user's key, it is computed again (one warning) and the picture is the one from the true ranges."""
    import json

    nhdr = write_synthetic_raw(tmp_path / "s.raw", (70, 64, 60), "uint16")
    volume = open_volume(nhdr, out_of_core=True, memory_budget_mb=1)
    scene = scene_of(volume, size=(32, 24), transfer_function=BLOBS_ONLY, texture_budget_mb=0.05)
    expected = raycaster.render(scene)
    assert expected[..., 3].max() > 0.05
    sidecar = volume.ranges.sidecar
    with np.load(sidecar) as z:
        zeros, key = np.zeros_like(z["mins"]), z["key"]
    assert json.loads(str(key))["size"] == (tmp_path / "s.raw").stat().st_size
    np.savez(sidecar, mins=zeros, maxs=zeros, key=key, non_finite=np.array(0))
    with caplog.at_level("WARNING", logger="dvr_gl"):
        forged = open_volume(nhdr, out_of_core=True, memory_budget_mb=1)
        image = raycaster.render(scene.replace(volume=forged, camera=scene.camera))
    assert np.array_equal(image, expected)
    assert "not written by dvr-gl for this user" in caplog.text
