"""The SPH sum at points: the compiled pair sum (numba) equals the numpy path, and the numpy path
still sums without numba."""

import numpy as np
import pytest

from dvr_gl.fields import particles


def _sums(monkeypatch, compiled):
    cloud = particles.plummer_sphere(600, seed=3)
    values = np.stack([cloud.values, np.arange(len(cloud), dtype=np.float64)], axis=1)
    points = np.concatenate([cloud.positions, cloud.positions[:200] + 0.03 * cloud.smoothing_lengths[:200, None]])
    if not compiled:
        monkeypatch.setattr(particles, "_compiled_pair_sum", lambda: None)
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
