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


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_compiled_chord_integrals_equal_numpy(dtype, monkeypatch, tmp_path):
    """The short chords' integrals of the trilinear field (:func:`..projection.direct_integrals`) compiled and
    in numpy, on a grid of anisotropic spacing off the origin: random chords through the box, chords along an
    axis (no knots across the others), along a face (clamped), a grazing one, and empty ones (``t1 <= t0``)."""
    from types import SimpleNamespace

    from dvr_gl.rays import intersect_box
    from dvr_gl.scene.resolve import load_scene

    rng = np.random.default_rng(7)
    np.save(tmp_path / "v.npy", (rng.random((5, 7, 6)) * 200).astype(dtype))
    scene = load_scene(None, {"volume.path": str(tmp_path / "v.npy"), "volume.spacing": [0.7, 1.3, 2.1],
                              "volume.origin": [-2, 1, 3], "renderer.name": "fourier",
                              "renderer.compositing": "average", "camera.projection": "orthographic",
                              "image.width": 8, "image.height": 8})
    lo, hi = (np.asarray(v, float) for v in scene.volume.bounds)
    n = 300
    origins = lo + (hi - lo) * rng.uniform(-0.5, 1.5, (n, 3))
    directions = rng.normal(size=(n, 3))
    origins[:60] = lo + (hi - lo) * rng.uniform(0.0, 1.0, (60, 3))  # within the box's slabs: chords for sure
    directions[:20, 1:] = 0.0  # along x
    directions[20:40, :2] = 0.0  # along z
    origins[40:50, 1] = lo[1]  # on a face
    directions[40:50, 1] = 0.0
    origins[50:60] = lo + [-1.0, 0.3, 0.5] * (hi - lo)
    directions[50:60] = [1.0, 1e-9, 0.0]  # grazing
    t0, t1 = intersect_box(origins, directions, lo, hi)
    hit = np.isfinite(t0) & np.isfinite(t1) & (t1 > t0)  # the short chords are chords: rays that meet the box
    assert hit[:60].all()
    origins, directions, t0, t1 = origins[hit], directions[hit], t0[hit], t1[hit]
    t1[60:70] = t0[60:70]  # empty
    rays = SimpleNamespace(origins=origins, directions=directions, t0=t0, t1=t1)
    rows = np.arange(len(t0))
    compiled = projection.direct_integrals(scene, rays, rows)
    with monkeypatch.context() as m:
        m.setattr(projection, "compiled_average", lambda: None)
        reference = projection.direct_integrals(scene, rays, rows)
    assert (compiled[60:70] == 0).all() and (np.abs(reference) > 1).sum() > 100  # chords that hold something
    # the same pieces, nodes and taps in the same order: the sums within a few roundings
    np.testing.assert_allclose(compiled, reference, rtol=1e-13, atol=1e-13 * np.abs(reference).max())
