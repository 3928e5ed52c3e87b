"""The SPH sum at points: the compiled pair sum and the compiled scatter through grids of the points (numba)
equal the numpy path, and the numpy path still sums without numba."""

import numpy as np
import pytest

from dvr_gl.fields import particle_scatter, particles, sph


def _sums(monkeypatch, compiled):
    cloud = particles.plummer_sphere(600, seed=3)
    values = np.stack([cloud.values, np.arange(len(cloud), dtype=np.float64)], axis=1)
    points = np.concatenate([cloud.positions, cloud.positions[:200] + 0.03 * cloud.smoothing_lengths[:200, None]])
    if not compiled:
        monkeypatch.setattr(particles, "_compiled_pair_sum", lambda: None)
        monkeypatch.setattr(particle_scatter, "compiled", lambda: None)
    return cloud.reconstruct_values(values).sample(points)


def test_compiled_sum_equals_numpy(monkeypatch):
    pytest.importorskip("numba")
    fast = _sums(monkeypatch, compiled=True)
    slow = _sums(monkeypatch, compiled=False)
    # the same pairs summed in the same order: only the kernel's rounding (q**3 against q*q*q) differs,
    # measured 1e-16 relative; 1e-12 leaves room for another compiler's fused multiply-adds
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-14 * np.abs(slow).max())
    assert np.abs(slow).max() > 0


def test_numpy_path_without_numba(monkeypatch):
    slow = _sums(monkeypatch, compiled=False)
    assert slow.shape[1] == 2 and np.isfinite(slow).all() and (slow[:, 0] > 0).any()


def test_scatter_equals_the_gather(monkeypatch):
    """As many points as particles or more (the value range, a reader's density): the sums scattered through
    grids of the points, a level per size of particle, are the gathered ones."""
    pytest.importorskip("numba")
    cloud = particles.plummer_sphere(600, seed=3)
    levels = particle_scatter.plan(cloud.positions, cloud.positions, sph.SUPPORT * cloud.smoothing_lengths)
    assert levels is not None and len(levels) >= 3  # the Plummer sphere's sizes span 2^3
    fast = _sums(monkeypatch, compiled=True)
    monkeypatch.setattr(particle_scatter, "compiled", lambda: None)
    gathered = _sums(monkeypatch, compiled=True)
    # the same pairs added in another order: measured 7e-16 relative; 1e-12 as above
    np.testing.assert_allclose(fast, gathered, rtol=1e-12, atol=1e-14 * np.abs(gathered).max())


def test_points_far_apart_are_gathered():
    """Points 1e17 apart would need a grid of 1e17 cells a side: no plan (the sparse index gathers)."""
    points = np.array([[0.0, 0, 0], [1e17, 0, 0]])
    assert particle_scatter.plan(points, points, np.ones(2)) is None


def test_the_scatter_counts_its_memory(monkeypatch):
    """Over the memory budget the scattered sum refuses in one line naming itself, before allocating."""
    pytest.importorskip("numba")
    from dvr_gl import sandbox

    cloud = particles.plummer_sphere(300, seed=1)
    monkeypatch.setattr(particle_scatter, "check_bytes", lambda n, what, fix: sandbox.check_bytes(n * 1e9, what, fix))
    with pytest.raises(sandbox.SandboxError, match="the SPH sum at the points would take"):
        cloud.reconstruct().sample(cloud.positions)


@pytest.mark.parametrize("quantity", ["density", "signed"])
def test_a_large_sets_value_range_from_its_extreme_particles(monkeypatch, quantity):
    """Above RANGE_SAMPLED_ABOVE particles (lowered here to 1000, 64 samples) the value range is the interpolant
    at the particles of the most extreme quantities: a lower bound of the full range's ends in general, and on
    the Plummer sphere's density (its peak where the densities peak) and a signed smooth quantity (x - 0.3 y,
    both ends) the full range itself (measured: to the last bit, and to 3e-16); without numba, the full sum
    (gathered: the same pairs, another order's rounding)."""
    pytest.importorskip("numba")
    cloud = particles.plummer_sphere(5000, seed=7)
    if quantity == "signed":
        x = cloud.positions
        cloud = particles.ParticleSet(x, cloud.smoothing_lengths, cloud.masses, cloud.densities,
                                      x[:, 0] - 0.3 * x[:, 1], array="q")
    full = cloud.reconstruct().sample(cloud.positions)
    monkeypatch.setattr(particles, "RANGE_SAMPLED_ABOVE", 1000)
    monkeypatch.setattr(particles, "RANGE_SAMPLES", 64)
    lo, hi = cloud._range_at_extremes()
    assert (lo, hi) == pytest.approx((min(0.0, full.min()), full.max()), rel=1e-15, abs=0.0)
    assert (lo == 0.0) == (quantity == "density") and min(0.0, full.min()) <= lo and hi <= full.max() * (1 + 1e-15)
    monkeypatch.setattr(particle_scatter, "compiled", lambda: None)
    assert cloud._range_at_extremes() is None
    assert cloud.value_range == pytest.approx((min(0.0, full.min()), full.max()), rel=1e-12)  # gathered
