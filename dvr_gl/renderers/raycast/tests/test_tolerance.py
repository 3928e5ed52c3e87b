"""Render to a tolerance: the frequency model, the choice, and the promise (measured error <= E)."""

import numpy as np
import pytest

from conftest import array_scene
from dvr_gl.apps.cli import main
from dvr_gl.bench.quality import spike
from dvr_gl.bench.tradeoff import converged_truth
from dvr_gl.errors import SceneError
from dvr_gl.gl.context import make_current
from dvr_gl.image import compare_images, read_image
from dvr_gl.phantoms import marschner_lobb, shepp_logan
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.renderers.raycast import tolerance
from dvr_gl.scene.resolve import load_scene

# 32x32 images: the promise's RMS errors measured at 32x32 and at 48x48 are alike (at most 0.47 E against
# 0.45 E; scene by scene within 0.05 E), and the a-posteriori check renders 1024 pixels instead of 2304.
ML = {"volume.demo": "marschner-lobb", "volume.size": 33, "image.width": 32, "image.height": 32,
      "transfer_function.opacity_model": "extinction"}


def test_bandwidth_of_a_sinusoid():
    """A sinusoid of 0.3 cycles per unit, sampled at 0.05 over whole periods: all its energy is at
    0.3 (one FFT bin of 1/200 = 0.005 wide)."""
    t = np.arange(4000) * 0.05
    signal = np.sin(2 * np.pi * 0.3 * t)[None, :] * np.ones((3, 1))
    assert tolerance.bandwidth(signal, 0.05) == pytest.approx(0.3, abs=0.005)
    assert tolerance.bandwidth(np.ones((2, 100)), 0.1) == 0.0


def test_narrower_features_need_finer_sampling():
    """The composed signal's Nyquist distance shrinks as the transfer-function spike narrows; a
    transfer function that is zero everywhere has nothing to resolve (amplitude 0)."""
    d = [tolerance.sampling_model(load_scene(None, {**ML, "transfer_function.points": spike(w, 1.0)})).post
         for w in (0.4, 0.1, 0.02)]
    assert d[0] > d[1] > d[2]
    empty = load_scene(None, {**ML, "transfer_function.points": [[0, 1, 1, 1, 0], [1, 1, 1, 1, 0]]})
    model = tolerance.sampling_model(empty)
    assert model.amplitude == 0.0
    assert tolerance.choose(empty, 1e-3).sample_distance == pytest.approx(8.0)   # the cap: 8 voxels


CASES = {
    "Marschner-Lobb, 5 % spike": {**ML, "transfer_function.points": spike(0.05, 1.0)},
    "Marschner-Lobb, viridis ramp": {**ML, "transfer_function.preset": "viridis",
                                     "transfer_function.opacity_model": "alpha", "camera.azimuth": 70.0},
    "Shepp-Logan": {"volume.demo": "shepp-logan", "volume.size": 40, "image.width": 32, "image.height": 32},
}


@pytest.fixture(scope="module")
def raycaster(shared_gl_context):
    """One ray caster on the session's context for the module's renders and a-posteriori checks: its
    programs are compiled once, not again in a context of each check's own."""
    with create_renderer("raycast", ctx=make_current(shared_gl_context)) as renderer:
        yield renderer


def assert_tolerances_met(renderer, scene, tolerances=(1e-2, 3e-3, 1e-3)):
    """Render with what each tolerance chooses (checked by ``renderer`` too); the RMS error against the
    converged reference is <= E."""
    truth = converged_truth(scene)
    for e in tolerances:
        chosen, choice = tolerance.apply(scene, e, renderer=renderer)
        rms = compare_images(renderer.render(chosen), truth)["rms"]
        assert rms <= e, f"E = {e:g}: measured {rms:.3g} with {choice.describe(1.0)}"
        assert choice.estimated_error <= tolerance.MARGIN * e


def test_richardson_estimate_of_a_power_law():
    """Images whose error is ``c d^p`` (p = 2): the estimate from d, d/2, d/4 is the error at d and
    the measured order is 2; an order below 1 counts as 1 (the safe side)."""
    truth = np.zeros((4, 4, 4))
    pattern = np.linspace(0.5, 1.0, 64).reshape(4, 4, 4)
    coarse, middle, fine = (truth + pattern * 1e-2 * h ** 2 for h in (1.0, 0.5, 0.25))
    estimate, order = tolerance.richardson(coarse, middle, fine)
    assert order == pytest.approx(2.0)
    assert estimate == pytest.approx(compare_images(coarse, truth)["rms"], rel=1e-6)
    _, order = tolerance.richardson(coarse, coarse * 0.9, coarse * 0.85)
    assert order == 1.0


def narrow(kind: str, bits: int, width: float, centre: float, spike: bool):
    """A generated volume quantized to ``bits`` and a transfer function zero but for a tent ``width``
    of the value range wide at its base: alpha 0.6 at its peak, or (``spike``) extinction 0.3 / width
    per voxel (the same area for every width)."""
    data = (marschner_lobb if kind == "ml" else shepp_logan)(32)
    top = 2 ** bits - 1
    data = np.round((data - data.min()) / (data.max() - data.min()) * top).astype(f"uint{bits}")
    peak = 0.3 / width if spike else 0.6
    c, w = centre * top, width * top
    points = [[0, 1, 0.5, 0.2, 0], [c - w / 2, 1, 0.5, 0.2, 0], [c, 1, 0.9, 0.6, peak], [c + w / 2, 0.4, 0.6, 1, 0],
              [top, 0.4, 0.6, 1, 0]]
    return data, {"transfer_function.points": points, "image.width": 32, "image.height": 32,
                  "transfer_function.opacity_model": "extinction" if spike else "alpha",
                  "renderer.shading.enabled": False, "camera.azimuth": 35.0}


NARROW = {  # not the scenes the check was measured on (docs/tolerance.md): other sizes, centres, views
    "8-bit Marschner-Lobb, 5 % tent": ("ml", 8, 0.05, 0.6, False),
    "8-bit Shepp-Logan, 2 % spike": ("sl", 8, 0.02, 0.25, True),
    "16-bit Marschner-Lobb, 0.5 % tent": ("ml", 16, 0.005, 0.4, False),
    "16-bit Shepp-Logan, 0.5 % spike": ("sl", 16, 0.005, 0.2, True),
}


@pytest.mark.parametrize("case", list(NARROW))
def test_tolerance_is_met_on_narrow_features(tmp_path, raycaster, case):
    """Issue 14: transfer-function features of 0.5-5 % of the range on 8- and 16-bit data.  The
    a-priori model alone measured up to 11x E on such scenes; the a-posteriori check (renders at
    d, d/2, d/4) holds the promise, measured 0.2-0.5 E on the calibration scenes (here, 32x32: 0.19-0.47 E)."""
    data, overrides = narrow(*NARROW[case])
    assert_tolerances_met(raycaster, array_scene(tmp_path, data, overrides))


@pytest.mark.parametrize("case", list(CASES))
def test_tolerance_is_met(raycaster, case):
    """The promise, on small scenes not used for the fit: the chosen settings' RMS error against the
    converged reference is at most E, for E from 1e-2 to 1e-3.  (The law is the upper envelope of
    the calibration, so the measured error is typically 2-4x below E; docs/tolerance.md's table shows it.)"""
    scene = load_scene(None, CASES[case])
    assert_tolerances_met(raycaster, scene)


def test_tighter_tolerance_samples_more():
    scene = load_scene(None, CASES["Shepp-Logan"])
    d = [tolerance.choose(scene, e).sample_distance for e in (3e-2, 3e-3, 1e-3)]
    assert d[0] > d[1] > d[2]
    assert tolerance.choose(scene, 1e-3).ert_threshold >= 1 - 1e-3 / 4


def test_scene_key_cli_and_effective_scene(tmp_path, capsys):
    """``--tolerance`` (the scene key renderer.tolerance) prints what it chose; the effective scene
    holds the chosen settings, and rendering it gives the same image, bit for bit."""
    out, saved = tmp_path / "t.exr", tmp_path / "t.toml"
    common = ["--demo", "marschner-lobb", "--set", "volume.size=24", "--size", "32", "--no-shading"]
    assert main(["render", *common, "--tolerance", "3e-3", "-o", str(out), "--save-scene", str(saved)]) == 0
    assert "predicted RMS error" in capsys.readouterr().out
    text = saved.read_text()
    assert "\ntolerance =" not in text and "\nsample_distance = " in text
    again = tmp_path / "again.exr"
    assert main(["render", str(saved), "-o", str(again)]) == 0
    assert np.array_equal(read_image(out), read_image(again))


def test_bad_tolerances_are_one_line_errors(tmp_path, capsys):
    out = tmp_path / "x.png"
    other = next(n for n, p in registry.plugins().items() if p.needs_gl and p.declared("tolerance") is None)
    for extra, message in ((["--tolerance", "1e-6", "--no-shading"], "outside the range"),
                           (["--tolerance", "1e-2", "--shading"], "without shading"),
                           (["--tolerance", "1e-2", "--no-shading", "--renderer", other],
                            f"{other} does not support renderer.tolerance"),
                           (["--tolerance", "1e-2", "--no-shading", "--compositing", "mip"], "emission_absorption")):
        assert main(["render", "--demo", "shepp-logan", "--set", "volume.size=16", *extra, "-o", str(out)]) == 1
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
        assert not out.exists()
    with pytest.raises(SceneError, match="tolerance or a sample distance"):
        load_scene(None, None, {"volume": {"demo": "shepp-logan", "size": 16},
                                "renderer": {"tolerance": 1e-2, "sample_distance": 1.0}})


SHARED = {  # small datasets of ../shared/data with a feature-revealing transfer function
    "nucleon": ("regular/nucleon.nhdr", None),
    "neghip, narrow shell": ("regular/neghip.nhdr", [[0, 0, 0, 0, 0], [60, 0.9, 0.5, 0.2, 0], [70, 0.9, 0.5, 0.2, 0.7],
                                                     [80, 0.9, 0.5, 0.2, 0], [255, 0, 0, 0, 0]]),
    "bucky": ("regular/bucky.nhdr", [[0, 0, 0, 0, 0], [100, 0.2, 0.6, 1, 0], [255, 1, 1, 1, 0.8]]),
}


@pytest.mark.parametrize("name", list(SHARED))
def test_tolerance_is_met_on_shared_datasets(shared_data, raycaster, name):
    """The promise on real data (small datasets, 32x32 images): measured RMS <= E (0.02-0.30 E; at 48x48
    0.02-0.39 E)."""
    path, points = SHARED[name]
    overrides = {"volume.path": str(shared_data / path), "image.width": 32, "image.height": 32}
    if points:
        overrides["transfer_function.points"] = points
    scene = load_scene(None, overrides)
    assert_tolerances_met(raycaster, scene)


def test_a_tolerance_the_check_cannot_reach_is_refused(tmp_path, monkeypatch):
    """Never a silently wrong image: where the a-posteriori estimate still exceeds E after the last
    halving, the render is refused in one line naming renderer.tolerance.  With no halving allowed,
    the model's own guess on a 0.5 % tent (which it under-predicts, up to 11x E measured) is refused
    at E = 1e-3."""
    monkeypatch.setattr(tolerance, "CHECK_HALVINGS", 0)
    data, overrides = narrow(*NARROW["16-bit Marschner-Lobb, 0.5 % tent"])
    scene = array_scene(tmp_path, data, overrides)
    choice = tolerance.choose(scene, 1e-3)
    with pytest.raises(SceneError, match=r"renderer.tolerance 0.001 cannot be met: the error is still estimated"):
        tolerance.check(scene, choice, 1e-3)
