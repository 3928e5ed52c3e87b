"""Runs and the "auto" decision of empty-space skipping (shaders/blocks.glsl's dense_reach,
acceleration.run_keys and skippable_fraction; docs/acceleration.md)."""

import numpy as np
import pytest

from conftest import array_scene
from dvr_gl.gl.context import make_current
from dvr_gl.renderers.raycast import acceleration as accel
from dvr_gl.renderers.raycast.renderer import AUTO_MIN_SKIPPABLE, RayCastRenderer
from dvr_gl.scene.resolve import load_scene


def _brute_reduce(key, reach, op):
    out = np.empty_like(key)
    for idx in np.ndindex(key.shape):
        window = tuple(slice(max(i - reach, 0), i + reach + 1) for i in idx)
        out[idx] = op.reduce(key[window], axis=None)
    return out


@pytest.mark.parametrize("shape", [(5, 7, 3), (1, 1, 9), (10, 4, 6)])
@pytest.mark.parametrize("op", [np.minimum, np.maximum])
def test_neighbourhood_reduce_matches_brute_force(shape, op):
    key = np.random.default_rng(3).uniform(0, 1, shape).astype(np.float32)
    for reach in (0, 1, 3, 7):
        np.testing.assert_array_equal(accel.neighbourhood_reduce(key, reach, op), _brute_reduce(key, reach, op))


def test_run_keys_per_mode():
    rng = np.random.default_rng(4)
    classes = np.zeros((6, 6, 6, 4), np.float32)
    classes[..., 3] = np.where(rng.uniform(size=(6, 6, 6)) < 0.8, -1.0, 0.0)  # 80 % not skippable
    keys = accel.run_keys(classes, "emission")
    for i, radius in enumerate(accel.RUN_RADII):
        dense = _brute_reduce(classes[..., 3] < 0, radius - 1, np.logical_and)
        np.testing.assert_array_equal(keys[..., i] > 0.5, dense)
    minmax = np.sort(rng.uniform(size=(6, 6, 6, 2)), axis=-1).astype(np.float32)
    keys = accel.run_keys(minmax, "max")
    np.testing.assert_array_equal(keys[..., 2], _brute_reduce(minmax[..., 1], 3, np.minimum))
    keys = accel.run_keys(minmax, "minip")
    np.testing.assert_array_equal(keys[..., 3], _brute_reduce(minmax[..., 0], 7, np.maximum))


@pytest.fixture(scope="module")
def gpu(shared_gl_context):
    """A counting ray caster on the session's context (borrowed: its programs stay compiled for the other
    modules of the run, which compile many of the same)."""
    renderer = RayCastRenderer(count_samples=True, ctx=make_current(shared_gl_context))
    yield renderer
    renderer.close()


DENSE = {"volume.demo": "marschner-lobb", "volume.size": 64, "image.width": 24, "image.height": 24,
         "renderer.block_size": 4, "renderer.ert_threshold": 1.0, "transfer_function.preset": "viridis"}


@pytest.mark.parametrize("mode, order", [("emission_absorption", "front_to_back"),
                                         ("emission_absorption", "back_to_front"), ("mip", "front_to_back")])
def test_dense_volume_is_looked_up_once_per_run(gpu, mode, order):
    """No block of the Marschner-Lobb volume can be skipped: a ray looks up its neighbourhood of
    +-7 blocks (28 voxels at least in every direction) and samples on to its edge, so a ray of at
    most 64 sqrt 3 = 111 voxels makes at most 4 lookups (the 16 blocks it crosses would make 16 to
    30 without runs); the image is the unaccelerated one exactly.  MIP skips a few blocks once the
    maximum so far passes theirs: each jump adds a lookup, and its own after it."""
    scene = load_scene(None, {**DENSE, "renderer.compositing": mode, "renderer.order": order})
    plain = gpu.render(scene.with_renderer(acceleration="off"))
    image = gpu.render(scene.with_renderer(acceleration="on"))
    jumps = gpu.stats["jumps_per_ray"]
    assert gpu.stats["accelerated"] and (jumps == 0.0 if mode != "mip" else jumps < 0.2), jumps
    assert 1.0 <= gpu.stats["lookups_per_ray"] <= 4.0 + 2 * jumps, gpu.stats["lookups_per_ray"]
    np.testing.assert_array_equal(image, plain)


def _sparse_scene(tmp_path, n):
    """An n^3 volume empty but for a random 8 x 12 x 16 box at its centre: mostly skippable."""
    data = np.zeros((n, n, n), np.float32)
    z, y, x = n // 2 - 4, n // 2 - 6, n // 2 - 8
    data[z:z + 8, y:y + 12, x:x + 16] = np.random.default_rng(5).uniform(0.4, 1.0, (8, 12, 16))
    return array_scene(tmp_path, data, {"image.width": 32, "image.height": 32, "renderer.ert_threshold": 1.0,
                                        "renderer.block_size": 4})


def _shell_scene(tmp_path, n, sample_distance=None):
    """An n^3 volume empty but for a random spherical shell (radius 0.43 n to 0.48 n): the ray bounds
    leave out what lies outside the shell, block skipping what lies inside it."""
    z, y, x = np.mgrid[:n, :n, :n] - (n - 1) / 2
    r = np.sqrt(x * x + y * y + z * z)
    values = np.random.default_rng(5).uniform(0.4, 1.0, r.shape)
    data = np.where((r > 0.43 * n) & (r < 0.48 * n), values, 0.0).astype(np.float32)
    extra = {"renderer.sample_distance": sample_distance} if sample_distance else {}
    return array_scene(tmp_path, data, {"image.width": 32, "image.height": 32, "renderer.ert_threshold": 1.0,
                                        "renderer.block_size": 4, **extra})


def test_auto_skips_only_where_it_pays(gpu, tmp_path):
    """auto: neither ray bounds nor skipping on a dense volume (estimates 0).  On a mostly empty one,
    the ray bounds alone (inside them there is little to skip), the image exactly off's (they leave
    out exact zeros) and the estimate of the samples they leave out within 0.1 of the count.  Inside
    a hollow shell sampled finely, both, the image on's, and the estimate of all samples saved
    within 0.1 of the count."""
    dense = load_scene(None, DENSE)
    gpu.render(dense)
    assert gpu.stats["skippable_estimate"] == 0.0 and gpu.stats["outside_bounds_estimate"] == 0.0
    assert not gpu.stats["accelerated"] and not gpu.stats["ray_bounds"]
    for scene, in_loop in ((_sparse_scene(tmp_path, 48), False), (_shell_scene(tmp_path, 64, 0.05), True)):
        off = gpu.render(scene.with_renderer(acceleration="off"))
        off_samples = gpu.stats["samples"]
        on = gpu.render(scene.with_renderer(acceleration="on"))
        auto = gpu.render(scene)
        stats = gpu.stats
        assert stats["ray_bounds"] and stats["accelerated"] == in_loop, stats
        assert not in_loop or stats["skippable_estimate"] >= AUTO_MIN_SKIPPABLE
        outside, skippable = stats["outside_bounds_estimate"], stats["skippable_estimate"]
        estimate = 1.0 - (1.0 - outside) * (1.0 - skippable) if in_loop else outside
        assert abs(estimate - (1.0 - stats["samples"] / off_samples)) <= 0.1, (estimate, stats["samples"])
        np.testing.assert_array_equal(auto, on if in_loop else off)
        assert np.abs(on - off).max() <= 2e-6  # closed-form jumps: float32 rounding (test_acceleration)


def test_auto_estimate_follows_the_state_of_mip(tmp_path):
    """MIP: a block is skippable once the maximum so far reaches its own; the estimate bounds the
    maximum so far by the largest block minimum met, so a bright front plate hides what lies behind."""
    data = np.random.default_rng(6).uniform(0.0, 0.5, (32, 32, 32)).astype(np.float32)  # no block skippable
    data[:, :, :8] = 1.0   # x < 8: a plate of the highest value
    level0 = accel.minmax_textures(accel.MinMaxPyramid.build(data, 4, accel.SUPPORT["linear"]), "linear")[0]
    scene = array_scene(tmp_path, data, {"camera.azimuth": -90.0, "camera.elevation": 0.0})
    seen_from_plate = accel.skippable_fraction(level0, "max", 4, scene.volume, scene.camera)
    scene = array_scene(tmp_path, data, {"camera.azimuth": 90.0, "camera.elevation": 0.0})
    seen_from_back = accel.skippable_fraction(level0, "max", 4, scene.volume, scene.camera)
    # from the back only the plate's own far blocks pass (after its first block sets the bound to 1)
    assert seen_from_plate > 0.9 and seen_from_back < 0.1, (seen_from_plate, seen_from_back)


def test_acceleration_setting_reads_old_booleans():
    base = {"volume.demo": "blobs", "volume.size": 8}
    assert load_scene(None, {**base, "renderer.acceleration": True}).renderer.acceleration == "on"
    assert load_scene(None, {**base, "renderer.acceleration": False}).renderer.acceleration == "off"
    assert load_scene(None, base).renderer.acceleration == "auto"


def test_emission_classes_carry_the_runs():
    """Emission-absorption folds the runs into level 0: a block that cannot be skipped holds -R for the
    largest dense radius R, skippable blocks keep their class."""
    rng = np.random.default_rng(7)
    classes = rng.uniform(0, 1, (9, 9, 9, 4)).astype(np.float32)
    classes[..., 3] = np.where(rng.uniform(size=(9, 9, 9)) < 0.9, -1.0, classes[..., 3])
    out = accel.classes_with_runs(classes)
    skippable = classes[..., 3] >= 0
    np.testing.assert_array_equal(out[skippable], classes[skippable])
    np.testing.assert_array_equal(out[..., :3], classes[..., :3])
    # per radius, whether a block's neighbourhood holds a skippable block: brute force, once for every block
    near_skippable = {r: _brute_reduce(skippable, r - 1, np.logical_or) for r in accel.RUN_RADII}
    for idx in zip(*np.nonzero(~skippable)):
        expected = max(r for r in accel.RUN_RADII if not near_skippable[r][idx])
        assert out[idx + (3,)] == -expected


def test_auto_decides_once_for_all_bricked_passes(gpu, tmp_path):
    """Bricked (8 bricks and more): "auto" makes the same decision from the same estimate as one
    pass, and its passes skip where it decides to (counted over all passes)."""
    dense = load_scene(None, {**DENSE, "volume.size": 32})
    gpu.render(dense.with_renderer(texture_budget_mb=1 / 16))
    assert gpu.stats["bricks"] >= 8 and gpu.stats["skippable_estimate"] == 0.0 and not gpu.stats["accelerated"]
    assert gpu.stats["jumps_per_ray"] == 0.0 and gpu.stats["lookups_per_ray"] == 0.0
    shell = _shell_scene(tmp_path, 48, 0.05)
    one_pass = gpu.render(shell)
    estimate = gpu.stats["skippable_estimate"]
    auto = gpu.render(shell.with_renderer(texture_budget_mb=1 / 16))
    assert gpu.stats["bricks"] >= 8 and gpu.stats["accelerated"] and gpu.stats["skippable_estimate"] == estimate
    assert gpu.stats["ray_bounds"] and gpu.stats["jumps_per_ray"] > 1.0
    on = gpu.render(shell.with_renderer(texture_budget_mb=1 / 16, acceleration="on"))
    np.testing.assert_array_equal(auto, on)
    assert np.abs(auto - one_pass).max() <= 2e-6


def test_auto_weighs_lookups_against_samples_saved(gpu, tmp_path):
    """auto's cost model: the same hollow shell is skipped inside at fine sampling and not where a
    sample falls nearly every block (a jump then saves about one sample and costs a lookup:
    renderer.worth_skipping, at the dearer lookup within the ray bounds: 0.05 voxel is fine enough,
    0.25 not).  The estimate counts fewer lookups than the shader (here 6.2 against 9.9 a ray within
    the ray bounds: rays along coarse block faces re-look up; on the benchmark
    volumes 0.7-1.4x of the count), which the fitted LOOKUP_COST absorbs; it must still count some."""
    from dvr_gl.renderers.raycast.renderer import worth_skipping

    shell = _shell_scene(tmp_path, 48, 0.05)
    gpu.render(shell)
    estimate = gpu._skippable[1]
    assert gpu.stats["accelerated"] and gpu.stats["lookups_estimate"] == estimate.lookups
    gpu.render(shell.with_renderer(acceleration="on"))
    assert 1.0 < estimate.lookups < gpu.stats["lookups_per_ray"] < 2.0 * estimate.lookups
    coarse = shell.with_renderer(sample_distance=3.0)  # 3/4 of a block a sample
    gpu.render(coarse)
    # nor the ray bounds there: they would leave out 2.7 samples a ray, less than they cost
    assert not gpu.stats["accelerated"] and not gpu.stats["ray_bounds"]
    assert not worth_skipping(estimate, 3.0) and not worth_skipping(estimate, 0.25)
    assert worth_skipping(estimate, shell.renderer.sample_distance)
