"""The first frame's host steps in float32 (issue 44): the X-ray's classification
(``TransferFunction.classify_voxels`` in float32) and the slice textures' extra columns, against the float64
steps they stand for."""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.renderers.fourier.renderer import extended_into
from dvr_gl.transfer_function import TransferFunction

POINTS = [[0.0, 1.0, 0.5, 0.2, 0.0], [0.3, 0.2, 0.5, 1.0, 0.7], [0.6, 0.1, 0.1, 0.1, 1.0], [0.9, 1.0, 1.0, 1.0, 0.2]]


@pytest.mark.parametrize("associated", [True, False])
@pytest.mark.parametrize("model", ["alpha", "extinction"])
@pytest.mark.parametrize("kind", ["float32", "uint16"])
def test_float32_classification_matches_classify_voxels(model, kind, associated):
    """Values below, inside and above the points (alpha reaching 1, where sigma is steepest): measured
    within 1.1e-7 of the largest value (alpha / extinction: float data 4.4e-8 / 1.1e-7, the integer table
    1.3e-8 / 8.4e-8); asserted 1e-6, a few float32 roundings; the colour not associated as well.  Each channel
    is contiguous."""
    rng = np.random.default_rng(7)
    scale = 1000.0 if kind == "uint16" else 1.0
    data = (rng.random((30, 20, 10)) * 1.2 - 0.1) * scale
    data = np.clip(data, 0, None).astype(np.uint16) if kind == "uint16" else data.astype(np.float32)
    tf = TransferFunction(np.array(POINTS) * [scale, 1, 1, 1, 1], 2.0, model)
    want = tf.classify_voxels(data, associated)
    got = tf.classify_voxels(data, associated, np.float32)
    assert got.dtype == np.float32 and got.shape == want.shape and got[..., 1].flags.c_contiguous
    assert np.abs(got - want).max() <= 1e-6 * np.abs(want).max()


def test_extended_columns_are_the_periodic_spectrum():
    """The textures' columns ``-pad .. M/2 + pad`` (the half not stored from its mirror, conjugated), rolled
    along y and z: measured 1e-13 of the full transform's, small spectra whose mirrors wrap included."""
    rng = np.random.default_rng(0)
    for mz, my, mxh in [(6, 6, 4), (10, 8, 6), (20, 16, 11)]:
        m = 2 * (mxh - 1)
        volume = rng.standard_normal((mz, my, m))
        full, half = np.fft.fftn(volume), np.fft.rfftn(volume)
        out = np.empty((mz, my, mxh + 6), complex)
        extended_into(out, half, 3, 2)
        want = np.roll(full, 2, axis=(0, 1))[:, :, [(c - 3) % m for c in range(mxh + 6)]]
        assert np.abs(out - want).max() <= 1e-12 * np.abs(full).max()


def test_a_sinks_channels_are_the_kept_spectra():
    """``Spectrum(sink=...)`` reuses the z and y passes' grids from channel to channel (their padding
    zeroed again) and pre-multiplies on the way: three channels handed to a sink against the same kept,
    float64: measured 0 (the same operations); asserted to 1e-12 of the largest."""
    from dvr_gl.renderers.fourier.spectrum import Spectrum

    channels = np.random.default_rng(4).random((9, 7, 8, 3))
    kept = Spectrum(channels, "kaiser_bessel", 1.25, 0, 6)
    handed = []
    sunk = Spectrum(channels, "kaiser_bessel", 1.25, 0, 6, sink=lambda c, half: handed.append(half.copy()))
    assert sunk.spectra == [] and sunk.count == 3 and len(handed) == 3
    peak = max(np.abs(s).max() for s in kept.spectra)
    assert max(np.abs(a - b).max() for a, b in zip(kept.spectra, handed)) <= 1e-12 * peak
