"""The average's compiled classification (:mod:`..average_compiled`) against the numpy code it replaces
(:func:`..projection.average_rgba` without numba), on the cases that take different branches: rays off the
box, means below, at and beyond the transfer function's end points and on its points, both opacity models,
alpha at its clamp, and a single-point transfer function."""

import numpy as np
import pytest

from dvr_gl.renderers.fourier import projection
from dvr_gl.transfer_function import ALPHA_MAX, TransferFunction

pytest.importorskip("numba")

EPS = np.finfo(np.float64).eps


def numpy_rgba(tf, sums, chord, monkeypatch):
    with monkeypatch.context() as m:
        m.setattr(projection, "compiled_average", lambda: None)
        return projection.average_rgba(tf, sums, chord)


def means_and_chords(points, rng):
    """Chords (a quarter off the box, zero) and sums whose means fall everywhere: random over and beyond the
    points' range, on each point exactly, and at the ends."""
    chord = rng.uniform(0.5, 40.0, (37, 29))
    chord[rng.random(chord.shape) < 0.25] = 0.0
    lo, hi = points[0, 0], points[-1, 0]
    mean = rng.uniform(lo - 0.3 * (hi - lo) - 1, hi + 0.3 * (hi - lo) + 1, chord.shape)
    mean.flat[:len(points)] = points[:, 0]  # on the points (the last: at the end, constant beyond) ...
    chord.flat[:len(points)] = 1.0  # ... exactly
    return mean * chord, chord  # the kernel divides back: the means to within a rounding of these


@pytest.mark.parametrize("model", ["alpha", "extinction"])
def test_compiled_classification_equals_numpy(model, monkeypatch):
    rng = np.random.default_rng(44)
    points = np.array([[-3.0, 0.1, 0.2, 0.9, 0.0], [10.0, 0.2, 0.5, 0.9, 0.02], [64.0, 0.9, 0.8, 0.3, 0.6],
                       [64.5, 1.0, 0.3, 0.1, 1.0], [255.0, 0.9, 0.3, 0.1, 0.3]])
    if model == "extinction":
        points[:, 4] *= 7.0  # per world unit: alpha up to 1 - exp(-7)
    tf = TransferFunction(points, unit_distance=0.37, opacity_model=model)
    sums, chord = means_and_chords(points, rng)
    compiled = projection.average_rgba(tf, sums, chord)
    assert compiled.shape == (37, 29, 4)
    reference = numpy_rgba(tf, sums, chord, monkeypatch)
    off = chord == 0
    assert not compiled[off].any() and not reference[off].any()
    assert reference[~off, 3].max() > 0.5 and (reference[~off, 3] == 0).any()  # opaque and clear pixels
    if model == "alpha":  # alpha 1 at 64.5 is clamped to ALPHA_MAX, as numpy's path clamps it
        assert np.isclose(reference[..., 3].max(), ALPHA_MAX, rtol=1e-12, atol=0)
    # libm's log1p and expm1 against numpy's vectorized ones: a few ulp of each value
    np.testing.assert_allclose(compiled, reference, rtol=8 * EPS, atol=0)


def test_a_single_point_transfer_function(monkeypatch):
    """One point: constant colour and opacity everywhere on the box (no segment to scan)."""
    tf = TransferFunction(np.array([[5.0, 0.3, 0.6, 0.9, 0.25]]))
    sums, chord = means_and_chords(tf.points, np.random.default_rng(3))
    compiled = projection.average_rgba(tf, sums, chord)
    np.testing.assert_allclose(compiled, numpy_rgba(tf, sums, chord, monkeypatch), rtol=8 * EPS, atol=0)
    assert np.allclose(compiled[chord > 0, 3], 0.25, rtol=1e-14)
