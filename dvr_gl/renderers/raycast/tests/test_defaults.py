"""The ray caster's defaults chosen by the scene (issue 44): deterministic, cached, overridden by an
explicit sample distance or tolerance, and within their target against the converged reference."""

import numpy as np
import pytest

from dvr_gl.bench.peers import COMPOSITE_TF
from dvr_gl.bench.tradeoff import converged_truth
from dvr_gl.image import compare_images
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.raycast import defaults
from dvr_gl.scene.resolve import load_scene
from dvr_gl.scene.settings import DEFAULT_SAMPLE_DISTANCE_VOXELS, ERT_DEFAULT
from judges import DISCRETE

# Small scenes, unshaded (the simulation's domain): a semi-transparent tent on Marschner-Lobb, and MIP.
ML = {"volume.demo": "marschner-lobb", "volume.size": 33, "image.width": 48, "image.height": 48,
      "transfer_function.points": [[0.0, 0.1, 0.2, 0.8, 0.0], [0.38, 0.1, 0.4, 0.9, 0.0],
                                   [0.5, 0.9, 0.7, 0.3, 0.3], [0.62, 0.9, 0.3, 0.1, 0.0],
                                   [1.0, 0.9, 0.3, 0.1, 0.0]]}
MIP = {"volume.demo": "blobs", "volume.size": 33, "image.width": 48, "image.height": 48,
       "renderer.compositing": "mip"}


def voxels(scene) -> float:
    return scene.renderer.sample_distance / scene.field.sample_spacing


def test_the_choice_is_deterministic_and_cached(monkeypatch):
    """Two loads of the same data choose the same settings; the second finds the first's choice (by the
    voxels' digest), without simulating again."""
    defaults.CACHE.clear()
    first = load_scene(None, ML)
    calls = []
    real = defaults.simulate_choice
    monkeypatch.setattr(defaults, "simulate_choice", lambda scene: calls.append(1) or real(scene))
    again = load_scene(None, ML)
    assert calls == []
    assert again.renderer.sample_distance == first.renderer.sample_distance
    assert again.renderer.classification == first.renderer.classification
    defaults.CACHE.clear()
    fresh = load_scene(None, ML)
    assert calls == [1]
    assert fresh.renderer.sample_distance == first.renderer.sample_distance
    assert voxels(first) in defaults.LADDER + (defaults.FINEST,)
    assert first.renderer.ert_threshold == pytest.approx(1.0 - defaults.TARGET / 4.0)


def test_an_explicit_sample_distance_wins():
    """A sample distance given (in voxels or world units) keeps what it says, with the fixed early
    termination: the old fixed default is one key away.  (A tolerance takes the tolerance's path,
    test_tolerance.py.)"""
    old = load_scene(None, {**ML, "renderer.sample_distance_voxels": DEFAULT_SAMPLE_DISTANCE_VOXELS})
    assert voxels(old) == pytest.approx(0.5)
    assert old.renderer.ert_threshold == ERT_DEFAULT
    world = load_scene(None, {**ML, "renderer.sample_distance": 0.123})
    assert world.renderer.sample_distance == pytest.approx(0.123)
    ert = load_scene(None, {**ML, "renderer.ert_threshold": 0.9})
    assert ert.renderer.ert_threshold == 0.9  # a threshold given is kept; the distance is still chosen
    assert voxels(ert) == voxels(load_scene(None, ML))


def test_unmodelled_scenes_keep_the_fixed_default():
    """Shading (and the other effects the simulation leaves out) keep 0.5 voxel."""
    shaded = load_scene(None, {**ML, "renderer.shading.enabled": True})
    assert voxels(shaded) == pytest.approx(DEFAULT_SAMPLE_DISTANCE_VOXELS)
    assert not defaults.modelled(shaded)


@pytest.mark.parametrize("keys", [ML, MIP], ids=["emission-absorption", "mip"])
def test_the_defaults_meet_their_target(keys):
    """The default image's RMS error against the converged reference is below the target (one 8-bit step,
    1/255; MIP half a step, defaults.MIP_TARGET).  Measured (48x48, llvmpipe): 2.0e-3 for the tent (33^3
    Marschner-Lobb is fine-grained: no distance of the ladder met the target on the lines, so the fixed 0.5
    voxel stays), 1.2e-5 for the blobs' MIP at the 2.75 voxels chosen (two brackets refined); the targets
    leave 1.9x and 170x of room."""
    scene = load_scene(None, keys)
    with create_renderer("raycast") as renderer:
        rms = compare_images(renderer.render(scene), converged_truth(scene))["rms"]
    assert rms <= defaults.target_of(scene.renderer.compositing), f"{rms:.3g} at {voxels(scene):g} voxel"


def test_the_simulation_tracks_the_error_as_the_step_grows():
    """On the lines, the simulated error grows with the sample distance (what the ladder's search relies on)."""
    scene = load_scene(None, ML)
    s, composed, n, step, _ = defaults.box_lines(scene)
    fine = defaults.composite(*defaults.segments(composed, n, 1), step)
    errors = [defaults.rms(defaults.composite(*defaults.segments(composed, n, int(v * defaults.PER_VOXEL)), step),
                           fine) for v in (0.75, 1.75, 3.75)]
    assert errors[0] < errors[1] < errors[2]
    assert np.isfinite(errors).all()


BLOBS = {"volume.demo": "blobs", "volume.size": 33, "image.width": 48, "image.height": 48,
         "renderer.shading.enabled": False}
SPIKE = [[0.0, 0.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0, 0.0], [0.52, 1.0, 1.0, 1.0, 1.0], [0.54, 0.0, 0.0, 0.0, 0.0],
         [1.0, 0.0, 0.0, 0.0, 0.0]]
#: A tent 0.2 of the range wide: on the 33^3 blobs out of reach at 0.5 voxel, pre-integrated 1.75 voxel chosen
#: (the broad ramp: one voxel, its own error being below the display target).
NARROW = [[0.0, 0.0, 0.0, 0.0, 0.0], [0.4, 0.0, 0.0, 0.0, 0.0], [0.5, 1.0, 0.8, 0.6, 1.0], [0.6, 0.0, 0.0, 0.0, 0.0],
          [1.0, 0.0, 0.0, 0.0, 0.0]]


def chosen(scene) -> tuple:
    r = scene.renderer
    return voxels(scene), r.classification, r.ert_threshold, r.extremum_refinement


def test_the_choice_follows_a_new_transfer_function_or_mode():
    """Scene.replace(transfer_function=...) and Scene.with_renderer(...) choose again for what they
    change, as loading the changed scene would; a step the user gave stays; another renderer keeps the
    step (the reference judges the ray caster's discretization)."""
    broad = load_scene(None, BLOBS)
    spiked = load_scene(None, {**BLOBS, "transfer_function.points": NARROW})
    assert chosen(broad) != chosen(spiked)  # the narrow tent is chosen for otherwise
    assert chosen(broad.replace(transfer_function=spiked.transfer_function)) == chosen(spiked)
    assert chosen(spiked.replace(transfer_function=broad.transfer_function)) == chosen(broad)
    ml = load_scene(None, ML)
    assert chosen(ml.with_renderer(compositing="mip")) == chosen(load_scene(None, {**ML, **{
        "renderer.compositing": "mip"}}))
    assert ml.with_renderer(compositing="mip").renderer.extremum_refinement in defaults.REFINEMENT_CHOICES
    given = load_scene(None, {**BLOBS, "renderer.sample_distance_voxels": 0.3})
    assert voxels(given.replace(transfer_function=spiked.transfer_function)) == pytest.approx(0.3)
    assert voxels(given.with_renderer(compositing="mip")) == pytest.approx(0.3)
    assert voxels(broad.with_renderer(name=DISCRETE)) == voxels(broad)  # the judge samples as the ray caster did


def test_a_new_transfer_function_reuses_the_lines_and_can_wait(monkeypatch):
    """Choosing for a new transfer function on the same data classifies the kept line samples again
    (sampled once per field and filter); a transfer function being dragged keeps the old choice."""
    broad = load_scene(None, BLOBS)
    spiked = load_scene(None, {**BLOBS, "transfer_function.points": SPIKE})
    defaults.CACHE.clear()
    calls = []
    sample = defaults.sampled_lines
    monkeypatch.setattr(defaults, "sampled_lines", lambda *a: calls.append(1) or sample(*a))
    defaults.SAMPLED.clear()
    defaults.choose_defaults(broad)
    defaults.choose_defaults(spiked)
    assert len(calls) == 1
    assert chosen(broad.replace(transfer_function=spiked.transfer_function, choose_again=False)) == chosen(broad)


def test_a_thin_shell_meets_the_target(shared_data):
    """A narrow tent (alpha 0.5 over 10 of 255 units) on the hydrogen atom is a shell a voxel or two thick
    that 5 of the 128 uniform lines meet: the error counted over the lines that meet the content, with more
    drawn through it (defaults.visible_lines), keeps the image within the target.  Measured (64x64, the
    bench's camera, llvmpipe): 0.95/255 at the 0.75 voxel now chosen; over all the uniform lines 1.25 voxel
    was chosen and the image missed the target, 1.13/255 (docs/peers.md, hydrogen-shell)."""
    path = shared_data / "regular" / "hydrogen_atom.nhdr"
    if not path.exists():
        pytest.skip(f"{path} absent (the shared datasets)")
    keys = {"volume.path": str(path), "image.width": 64, "image.height": 64, "renderer.shading.enabled": False,
            "camera.azimuth": 30.0, "camera.elevation": 20.0, "camera.fov": 30.0,
            "camera.projection": "perspective", "camera.distance": 1.8 * 220.0,
            "transfer_function.unit_distance": 1.0, "transfer_function.points": COMPOSITE_TF["hydrogen"]}
    scene = load_scene(None, keys)
    with create_renderer("raycast") as renderer:
        rms = compare_images(renderer.render(scene), converged_truth(scene))["rms"]
    assert rms <= defaults.TARGET, f"{rms * 255:.3g}/255 at {voxels(scene):g} voxel"


def test_a_target_out_of_reach_costs_no_more_than_one_sample_a_voxel(shared_data):
    """The buckyball's narrow shell (32^3, alpha 0.6 over 20 units): even 0.5 voxel misses the target by more
    than defaults.OUT_OF_REACH on the lines, so the defaults take the cheapest choice no less accurate there than
    one sample a voxel, post-classified, at most one voxel apart (pre-integrated: two): pre-integrated 1.75
    voxel, against 0.5 voxel post-classified before.  The image is then at least as close to the converged one
    as the one-voxel image (measured, 64x64, the bench's camera: RMS 0.054 against 0.067, where the lines put
    them at 0.122 and 0.146; 1.05x allowed, the lines' estimate being a ratio, not a bound), for fewer samples a
    ray."""
    path = shared_data / "regular" / "bucky.nhdr"
    if not path.exists():
        pytest.skip(f"{path} absent (the shared datasets)")
    keys = {"volume.path": str(path), "image.width": 64, "image.height": 64, "renderer.shading.enabled": False,
            "camera.azimuth": 30.0, "camera.elevation": 20.0, "camera.fov": 30.0,
            "camera.projection": "perspective", "camera.distance": 1.8 * 31.0 * 3 ** 0.5,
            "transfer_function.unit_distance": 1.0, "transfer_function.points": COMPOSITE_TF["bucky"]}
    scene = load_scene(None, keys)
    choice = defaults.choose_defaults(scene)
    assert choice.out_of_reach and choice.estimated_error <= choice.classic_target
    assert 1.0 < voxels(scene) <= 2.0 and scene.renderer.classification == "preintegrated"
    one = load_scene(None, {**keys, "renderer.sample_distance_voxels": 1.0})
    truth = converged_truth(scene)
    with create_renderer("raycast") as renderer:
        chosen_rms = compare_images(renderer.render(scene), truth)["rms"]
        one_rms = compare_images(renderer.render(one), truth)["rms"]
    assert chosen_rms <= 1.05 * one_rms, f"{chosen_rms:.3g} against one voxel's {one_rms:.3g}"


def test_the_defaults_are_never_less_accurate_than_one_sample_a_voxel():
    """Where one sample a voxel, post-classified (the classic default, the peers'), is more accurate on the lines
    than the display target asks, the defaults take no less accurate a choice than it: the broad ramp on the
    33^3 blobs meets the target at 2.75 voxels (simulated 3.2e-4) but one voxel gives 2.0e-4, so one voxel it is,
    and its image is the one-voxel image (the same settings).  Where the target is tighter than one voxel's error
    (the tent on Marschner-Lobb: 0.5 voxel), the target decides."""
    blobs = load_scene(None, BLOBS)
    choice = defaults.choose_defaults(blobs)
    assert choice.classic_target is not None and not choice.out_of_reach
    assert (blobs.renderer.classification, voxels(blobs)) == ("post", 1.0)
    assert choice.estimated_error <= choice.classic_target < defaults.TARGET
    ml = defaults.choose_defaults(load_scene(None, ML))
    assert ml.classic_target is None and ml.sample_distance_voxels < 1.0
    one = load_scene(None, {**BLOBS, "renderer.sample_distance_voxels": 1.0, "renderer.ert_threshold": ERT_DEFAULT})
    truth = converged_truth(blobs)
    with create_renderer("raycast") as renderer:
        chosen_rms = compare_images(renderer.render(blobs), truth)["rms"]
        one_rms = compare_images(renderer.render(one), truth)["rms"]
    assert chosen_rms <= 1.05 * one_rms, f"{chosen_rms:.3g} against one voxel's {one_rms:.3g}"
