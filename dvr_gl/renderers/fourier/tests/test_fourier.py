"""Fourier volume rendering: the GL slice against its same-slices reference, the model against the
closed-form projection of Gaussian blobs and the converged reference, the pre-multiplication's
direction, padding, caching and refusals."""

import math

import numpy as np
import pytest

from conftest import array_scene, assert_close, small_scene
from dvr_gl.rays import intersect_box
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.renderers import registry
from dvr_gl.renderers.fourier import spectrum as spectrum_module
from dvr_gl.renderers.fourier.oracle import oracle as same_slices
from dvr_gl.renderers.fourier.renderer import FourierRenderer

ORTHO = {"renderer.name": "fourier", "camera.projection": "orthographic", "camera.azimuth": 31.0,
         "camera.elevation": 22.0}
K = 0.05  # extinction per unit value: the average and the X-ray invert to the line integral


@pytest.fixture(scope="module")
def fourier(shared_gl_context):
    r = FourierRenderer(ctx=shared_gl_context)
    yield r
    r.close()


def blob(n=32, sigma_fraction=0.1):
    """A Gaussian blob off the centre (peak 1, standard deviation n / 10 voxels) and its centre (x, y, z)."""
    centre = (n - 1) / 2.0 + np.array([2.1, -1.3, 0.7]) * n / 64
    z, y, x = np.mgrid[:n, :n, :n]
    s = sigma_fraction * n
    data = np.exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2) / (2 * s * s))
    return data.astype(np.float32), centre, s


def blob_scene(tmp_path, data, extra=None, size=48):
    return array_scene(tmp_path, data, {**ORTHO, "renderer.compositing": "average",
                                        "transfer_function.points": [[0, 1, 1, 1, 0], [1, 1, 1, 1, K]],
                                        "transfer_function.opacity_model": "extinction",
                                        "image.width": size, "image.height": size, **(extra or {})})


def line_integrals(scene, image):
    """The average's line integrals back from the image (extinction K per unit value, unit distance 1)."""
    o, d = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    t0, t1 = intersect_box(o, d, *scene.field.bounds)
    return -np.log1p(-image[..., 3].astype(np.float64).ravel()) / K * np.maximum(t1 - t0, 0.0), o, d


CASES = [{}, {"renderer.slice_interpolation": "trilinear"}, {"renderer.filter": "gaussian"},
         {"renderer.slice_interpolation": "windowed_sinc"},
         {"renderer.slice_interpolation": "windowed_sinc", "renderer.compositing": "xray", "renderer.depth_cue": 0.4},
         {"renderer.compositing": "xray"},
         {"renderer.compositing": "xray", "renderer.slice_interpolation": "trilinear"},
         {"renderer.padding": 1.3, "camera.view_height": 9.0}, {"camera.target": [3.0, -2.0, 1.0], "image.width": 30},
         {"renderer.depth_cue": 0.2, "transfer_function.points": [[0, 1, 0.5, 0.2, 0], [0.3, 0.2, 0.5, 1, 3.0]],
          "transfer_function.opacity_model": "extinction"},
         {"renderer.depth_cue": 0.2, "renderer.compositing": "xray", "renderer.slice_interpolation": "trilinear"},
         {"renderer.hemispherical_shading": True, "transfer_function.opacity_model": "extinction",
          "transfer_function.points": [[0, 1, 0.5, 0.2, 0], [0.3, 0.2, 0.5, 1, 3.0]]},
         {"renderer.hemispherical_shading": True, "renderer.compositing": "xray", "renderer.depth_cue": 0.5,
          "renderer.shading.lights": [{"type": "directional", "direction": [1.0, -0.5, 0.3]}]},
         {"renderer.compositing": "xray", "renderer.slice_bandwidth": 2.0, "camera.view_height": 40.0},
         {"renderer.filter": "cubic_bspline"}, {"renderer.slice_interpolation": "kaiser_bessel"},
         {"renderer.slice_interpolation": "kaiser_bessel", "renderer.compositing": "xray", "renderer.depth_cue": 0.3,
          "renderer.padding": 1.5},
         {"renderer.slice_taps": 6}, {"renderer.slice_taps": 6, "renderer.slice_interpolation": "windowed_sinc",
                                      "renderer.compositing": "xray", "renderer.depth_cue": 0.5},
         {"renderer.filter": "cubic_bspline", "renderer.compositing": "xray", "renderer.depth_cue": 0.5,
          "camera.azimuth": 0.0, "camera.elevation": 0.0}]


@pytest.mark.parametrize("extra", CASES, ids=lambda e: "-".join(f"{k.split('.')[-1]}={v}" for k, v in e.items())
                         or "default")
def test_against_its_same_slices_reference(fourier, extra):
    """The GL slice (complex64 spectrum, float32 texture, weights, kernel table and filter) against the same
    interpolation in float64 numpy, then the same host steps (the GL's in float32 since issue 44's second
    round): measured at most 5.0e-7, the cued extinction case (5.7e-7 just before the float32 host steps; 3e-8
    before the complex64 spectrum; asserted: the float32 assertion of every GPU renderer)."""
    assert_matches_same_slices(fourier, extra)


def assert_matches_same_slices(fourier, extra):
    """The GL's image of the 14^3 phantom at 20x20 (the average by default, pre-classified, unshaded, with
    ``extra``) within the float32 assertion of every GPU renderer of the same-slices reference, which must
    show something (alpha above 1e-3)."""
    scene = small_scene({**ORTHO, "renderer.compositing": "average", "renderer.classification": "pre",
                         "volume.size": 14, "image.width": 20, "image.height": 20, "renderer.shading.enabled": False,
                         **extra})
    image = fourier.render(scene)
    oracle = same_slices(scene)
    assert oracle[..., 3].max() > 1e-3
    assert_close(image, oracle)


@pytest.mark.parametrize("extra", [{}, {"renderer.filter": "cubic_bspline", "renderer.depth_cue": 0.4},
                                   {"renderer.compositing": "average", "camera.azimuth": 90.0,
                                    "camera.elevation": 0.0}],
                         ids=["linear", "cubic-cued", "average-along-an-axis"])
def test_anisotropic_spacing_off_centre_box(tmp_path, fourier, extra):
    """Random data (nothing zero at the faces: the shell pass runs) in an off-centre, anisotropic box."""
    rng = np.random.default_rng(3)
    scene = array_scene(tmp_path, rng.random((7, 9, 8)).astype(np.float32),
                        {**ORTHO, "renderer.compositing": "xray", "renderer.classification": "pre",
                         "image.width": 20, "image.height": 18, **extra},
                        spacing=(0.5, 0.8, 1.3), origin=(40.0, -7.0, 3.0))
    assert_close(fourier.render(scene), same_slices(scene))


@pytest.mark.parametrize("extra", [{"renderer.depth_cue": 0.4}, {"camera.azimuth": 90.0, "camera.elevation": 0.0},
                                   {"camera.azimuth": 0.0, "camera.elevation": 90.0,
                                    "renderer.compositing": "average"}], ids=["cued", "along-x", "along-z"])
def test_the_face_walk_integrates_the_shell(tmp_path, fourier, extra):
    """The shell pass's face walk (the trilinear field: the faces' layers, ``ShellTexture.faces``) against the
    float64 whole-line integrals beyond the box, oblique and along the axes (lines within the faces' planes),
    faces of three sizes: the largest error over the largest value measured 1.4e-5, 1.1e-6 and 7e-6 (the
    whole volume's walk: 1.3e-5, 2e-6, 7e-6); asserted 5e-5."""
    from dvr_gl.renderers.fourier.projection import Frame, channels, shell_integrals

    rng = np.random.default_rng(3)
    scene = array_scene(tmp_path, rng.random((7, 9, 8)).astype(np.float32),
                        {**ORTHO, "renderer.compositing": "xray", "renderer.classification": "pre",
                         "image.width": 40, "image.height": 36, **extra},
                        spacing=(0.5, 0.8, 1.3), origin=(40.0, -7.0, 3.0))
    fourier.render(scene)
    data, _, border = channels(scene)
    assert fourier._cache["shell texture"][1].faces
    exact = shell_integrals(scene, data, border)
    got = fourier._shell(scene, Frame(scene), data, border)
    assert np.abs(got - exact).max() <= 5e-5 * np.abs(exact).max()


PADDING_2 = {"renderer.padding": 2.0, "renderer.slice_taps": 4}  # the defaults before issue 44


@pytest.mark.parametrize("interpolation, extra, bound", [
    ("cubic_bspline", PADDING_2, 1e-4), ("trilinear", PADDING_2, 1e-2), ("windowed_sinc", PADDING_2, 5e-3),
    ("kaiser_bessel", PADDING_2, 5e-4), ("kaiser_bessel", {}, 1e-4)])
def test_gaussian_blob_against_its_closed_form_projection(tmp_path, fourier, interpolation, extra, bound):
    """With the Gaussian filter the field of a sampled Gaussian blob is the blob widened by the kernel
    (variance sigma^2 + 0.7^2, to the lattice's ripple), whose projection is a 2D Gaussian: the error
    over the peak, padding 2 (four taps a side for the windowed kernels), measured 2.7e-5 with the cubic
    B-spline slice (asserted 1e-4), 1.5e-4 with the Kaiser-Bessel kernel (asserted 5e-4; the issue asks
    1e-3 of the defaults: the blob sits at the padded grid's centre, where the B-spline ghosts nothing),
    2.8e-3 trilinear (asserted 1e-2) and 1.5e-3 with the windowed sinc (Kaiser beta 6; beta 3, 9 and 12
    measured 4.8e-3, 1.9e-2 and 4.3e-2; asserted 5e-3).  The defaults, the Kaiser-Bessel kernel of six taps
    at padding 1.25: 1.9e-5 (asserted 1e-4)."""
    data, centre, s = blob()
    scene = blob_scene(tmp_path, data, {"renderer.filter": "gaussian", "renderer.slice_interpolation": interpolation,
                                        **extra})
    p, o, d = line_integrals(scene, fourier.render(scene))
    along = ((centre - o) * d).sum(axis=1)
    rho2 = ((o + along[:, None] * d - centre) ** 2).sum(axis=1)
    var = s * s + 0.7 ** 2
    exact = (s / math.sqrt(var)) ** 3 * math.sqrt(2 * math.pi * var) * np.exp(-rho2 / (2 * var))
    assert np.abs(p - exact).max() < bound * exact.max()


@pytest.mark.parametrize("interpolation, compositing, bound", [
    ("cubic_bspline", "average", 1e-4), ("cubic_bspline", "xray", 1e-3),
    ("kaiser_bessel", "average", 1e-4), ("kaiser_bessel", "xray", 1e-3)])
def test_blob_against_the_converged_reference(tmp_path, fourier, interpolation, compositing, bound):
    """The trilinear field, slice bandwidth 1 (K = 2), against reference-converged of the same field.
    Cubic B-spline slice: measured at most 4.5e-5 and RMS 4.7e-6 (average, alpha up to 0.44), 6.4e-4 and
    7.1e-5 (X-ray, pre-classified, alpha up to 1); at bandwidth 0 with the first-order ghost layer and no
    spatial integrals of short chords they were 4.6e-4 / 1.3e-5 and 4.4e-4 / 5.8e-5; both at padding 2.
    Kaiser-Bessel (the default, six taps at padding 1.25): 2.1e-5 / 1.4e-6 and 2.4e-4 / 2.7e-5 (four taps at
    padding 2, the defaults before issue 44: 2.4e-4 / 2.7e-5 and 4.2e-3 / 5.0e-4).  The B-spline's
    transform vanishes at the integers, so
    the centre of the padded grid, where this blob lies, gets no replica from it, while the
    Kaiser-Bessel kernel ghosts 1.5e-4 of it there; near the grid's edges, where real data lies, it is
    the other way round (1.2e-2 against 4e-4; dvr_gl/renderers/fourier/README.md).  Asserted the bound, RMS a tenth."""
    data, _, _ = blob()
    scene = blob_scene(tmp_path, data, {"renderer.compositing": compositing, "renderer.classification": "pre",
                                        "renderer.converged_tolerance": 1e-6,
                                        "renderer.slice_interpolation": interpolation,
                                        # the cubic B-spline's replicas fall with the padding: 2 for it
                                        "renderer.padding": 2.0 if interpolation == "cubic_bspline" else 1.25,
                                        "transfer_function.points": [[0, 1, 0.5, 0.2, 0], [1, 0.2, 0.5, 1, 3.0]]},
                       size=32)
    image = fourier.render(scene).astype(np.float64)
    converged = ConvergedReference(scene).render_float64()
    assert converged[..., 3].max() > 0.2
    error = np.abs(image - converged)
    assert error.max() < bound and np.sqrt(np.mean(error ** 2)) < bound / 10


@pytest.mark.parametrize("compositing", ["average", "xray"])
def test_depth_cue_against_the_converged_reference(tmp_path, fourier, compositing):
    """Linear depth cueing (Totsuka and Levoy): the projection of the depth-weighted field from the slice
    of the spectrum's derivative along the view (the kernel's derivative weights), against
    reference-converged integrating the same weight (the cubic B-spline slice, whose replicas miss this
    centred blob; the Kaiser-Bessel kernel's are the blob test's): at depth_cue 0.3 the image changes by 0.12
    (average) and 0.30 (X-ray), and the two agree to 2.3e-5 and 6.4e-4 (measured, as without the cue;
    9.6e-4 and 3.8e-4 before the short chords' spatial integrals and the slice bandwidth); asserted 1e-3."""
    data, _, _ = blob()
    scene = blob_scene(tmp_path, data, {"renderer.compositing": compositing, "renderer.classification": "pre",
                                        "renderer.depth_cue": 0.3, "renderer.converged_tolerance": 1e-6,
                                        "renderer.slice_interpolation": "cubic_bspline", "renderer.padding": 2.0,
                                        "transfer_function.points": [[0, 1, 0.5, 0.2, 0], [1, 0.2, 0.5, 1, 3.0]]},
                       size=32)
    image = fourier.render(scene).astype(np.float64)
    converged = ConvergedReference(scene).render_float64()
    plain = ConvergedReference(scene.with_renderer(depth_cue=1.0)).render_float64()
    assert np.abs(converged - plain).max() > 0.1
    assert np.abs(image - converged).max() < 1e-3


@pytest.mark.parametrize("compositing, bound", [("average", 1e-4), ("xray", 1e-3)])
def test_hemispherical_shading_against_the_converged_reference(tmp_path, fourier, compositing, bound):
    """Totsuka and Levoy's shading, ambient E + diffuse h (G + grad E . L) / 2 (the model's, linear in the
    samples): the central differences as a multiplier on the slice, the gradient magnitudes G as one
    more transformed channel each; a directional light and a depth cue of 0.4; the cubic B-spline slice
    (as for the depth cue).  Against
    reference-converged integrating the same emission: the shading moves the image by 0.22 (average) and
    0.43 (X-ray), and they agree to 2.9e-5 and 3.8e-4 (measured).  At slice bandwidth 0 the X-ray's
    difference was 2.9e-3, G's: a gradient's magnitude has a cusp where it vanishes (the blob's centre)
    whose projection has frequencies above the pixels' Nyquist limit, which bandwidth 1 (K = 2) takes in.
    Asserted 1e-4 and 1e-3."""
    data, _, _ = blob()
    scene = blob_scene(tmp_path, data, {"renderer.compositing": compositing, "renderer.classification": "pre",
                                        "renderer.hemispherical_shading": True, "renderer.depth_cue": 0.4,
                                        "renderer.slice_interpolation": "cubic_bspline", "renderer.padding": 2.0,
                                        "renderer.shading.lights": [{"type": "directional",
                                                                     "direction": [1.0, -0.5, 0.3]}],
                                        "renderer.converged_tolerance": 1e-6,
                                        "transfer_function.points": [[0, 1, 0.5, 0.2, 0], [1, 0.2, 0.5, 1, 3.0]]},
                       size=32)
    image = fourier.render(scene).astype(np.float64)
    converged = ConvergedReference(scene).render_float64()
    plain = ConvergedReference(scene.with_renderer(hemispherical_shading=False)).render_float64()
    assert np.abs(converged - plain).max() > 0.2
    assert np.abs(image - converged).max() < bound


def test_slice_bandwidth_reaches_the_references_point_samples():
    """Pixels 3.3 voxels wide (24^3 Shepp-Logan at 12x12, X-ray): the references point-sample the
    projection, whose frequencies go on past the pixels' Nyquist limit.  The slice on a grid K times
    finer, the image its every K-th sample, takes them in: RMS against reference-converged measured
    1.6e-2 at the pixels' limit (bandwidth 0), 1.8e-3, 1.1e-4 and 2.2e-5 at 1, 2 and 4 times the voxels'
    (K = 4, 7, 14; the Kaiser-Bessel slice, 3.4e-5 at 4 with the cubic B-spline).  Asserted: each step
    at least 3x smaller, and 5e-5 at 4."""
    from dvr_gl.renderers.fourier.projection import oversampling

    scene = small_scene({**ORTHO, "renderer.compositing": "xray", "renderer.classification": "pre",
                         "volume.size": 24, "image.width": 12, "image.height": 12, "camera.view_height": 40.0,
                         "renderer.shading.enabled": False, "renderer.converged_tolerance": 1e-6})
    truth = ConvergedReference(scene).render_float64()
    assert truth[..., 3].max() > 0.3
    rms, ks = [], []
    for bandwidth in (0.0, 1.0, 2.0, 4.0):
        banded = scene.with_renderer(slice_bandwidth=bandwidth)
        ks.append(oversampling(banded))
        rms.append(float(np.sqrt(np.mean((same_slices(banded) - truth) ** 2))))
    assert ks == [1, 4, 7, 14]
    assert all(b < a / 3 for a, b in zip(rms, rms[1:])) and rms[-1] < 5e-5


@pytest.mark.parametrize("extra", [{}, {"renderer.depth_cue": 0.3}, {"renderer.hemispherical_shading": True}],
                         ids=["plain", "depth_cue", "hemispherical"])
def test_short_chords_are_integrated_in_the_spatial_domain(monkeypatch, extra):
    """The average divides the line integral by the chord, which goes to zero at the box's silhouette: the
    band-limited integral's error divided by it made the largest errors (blobs 24^3 at 24x24, chords
    under 4 voxels: measured 4.1e-3, 3.1e-3 and 2.3e-3, against 5.9e-4 elsewhere).  Integrated from the
    field's pieces instead, they are the model's integral (measured 0; asserted 1e-9) while the rest is
    untouched; and without it the error is back (asserted over 1e-3)."""
    from dvr_gl.renderers.fourier import projection

    scene = small_scene({**ORTHO, "volume.demo": "blobs", "volume.size": 24, "image.width": 24, "image.height": 24,
                         "renderer.compositing": "average", "renderer.slice_interpolation": "cubic_bspline",
                         "renderer.classification": "pre", "renderer.shading.enabled": False,
                         "renderer.converged_tolerance": 1e-6, **extra})
    truth = ConvergedReference(scene).render_float64()
    rays = projection.RayBatch.for_camera(scene.camera, 24, 24, scene.volume.bounds)
    chord = np.maximum(rays.t1 - rays.t0, 0.0).reshape(24, 24)
    short = (chord > 0) & (chord < projection.SHORT_CHORD_VOXELS * min(scene.volume.spacing))
    assert short.sum() > 20
    error = np.abs(same_slices(scene) - truth).max(axis=2)
    assert error[short].max() < 1e-9
    monkeypatch.setattr(projection, "SHORT_CHORD_VOXELS", 0.0)
    unfixed = np.abs(same_slices(scene) - truth).max(axis=2)
    assert unfixed[short].max() > 1e-3
    assert np.array_equal(unfixed[~short], error[~short])


@pytest.mark.parametrize("filter_, compositing, bound", [("linear", "average", 3e-4), ("linear", "xray", 2.5e-3),
                                                        ("cubic_bspline", "average", 3e-4),
                                                        ("cubic_bspline", "xray", 2e-3)])
def test_the_box_clip_is_exact(tmp_path, monkeypatch, filter_, compositing, bound):
    """A blob cut by the box (up to 0.92 on its faces): the references clip the rays at the box, Fourier
    rendering integrates whole lines, and the shell pass takes off what lies beyond the box.  RMS against
    reference-converged measured 1.2e-4 / 1.1e-3 (trilinear field, average / X-ray) and 1.4e-4 / 9.7e-4
    (cubic B-spline field), against 2.9e-3 / 1.4e-2 and 1.4e-2 / 4.7e-2 with the first-order ghost layer
    instead (13x to 97x).  What is left is the slice's interpolation (padding 4 and slice bandwidth 4 take
    the trilinear ones to 7.9e-6 / 6.4e-5 with the cubic B-spline slice).  Asserted: the bounds (about 2x
    the measured) and 4x better than the ghost layer."""
    from dvr_gl.renderers.fourier import oracle, projection

    n = 24
    z, y, x = np.mgrid[:n, :n, :n]
    data = np.exp(-((x - 2.0) ** 2 + (y - 14.0) ** 2 + (z - 20.0) ** 2) / (2 * 5.0 ** 2)).astype(np.float32)
    scene = blob_scene(tmp_path, data, {"renderer.compositing": compositing, "renderer.classification": "pre",
                                        "renderer.filter": filter_, "renderer.converged_tolerance": 1e-6,
                                        "transfer_function.points": [[0, 1, 0.5, 0.2, 0], [1, 0.2, 0.5, 1, 3.0]]},
                       size=24)
    truth = ConvergedReference(scene).render_float64()
    rms = lambda image: float(np.sqrt(np.mean((image - truth) ** 2)))  # noqa: E731
    exact = rms(same_slices(scene))
    monkeypatch.setattr(projection, "clips_exactly", lambda scene: False)
    monkeypatch.setattr(oracle, "clips_exactly", lambda scene: False)
    assert exact < bound and rms(same_slices(scene)) > 4 * exact


def test_the_shell_pass_is_skipped_where_nothing_lies_beyond_the_box(monkeypatch, shared_gl_context):
    """The Shepp-Logan phantom is zero near its faces: the ghosted field is zero beyond the box, the pass
    is skipped, and running it anyway changes nothing (measured 0; asserted 1e-7)."""
    from dvr_gl.renderers.fourier.projection import Shell, channels

    scene = small_scene({**ORTHO, "renderer.compositing": "xray", "renderer.classification": "pre", "volume.size": 16,
                         "image.width": 20, "image.height": 20, "renderer.shading.enabled": False})
    ghosted, _, border = channels(scene)
    assert Shell(scene, border).empty(ghosted)
    skipped = FourierRenderer(ctx=shared_gl_context)
    forced = FourierRenderer(ctx=shared_gl_context)
    try:
        image = skipped.render(scene)
        monkeypatch.setattr(Shell, "empty", lambda self, ghosted: False)
        assert np.abs(forced.render(scene) - image).max() < 1e-7
    finally:
        skipped.close()
        forced.close()


def test_premultiplication_divides_by_the_kernels_transform(tmp_path, monkeypatch):
    """Dividing the volume by the slice kernel's transform corrects its roll-off; multiplying by it (the
    sign slip) doubles it: against the blob's closed form, trilinear at padding 2, measured 2.8e-3 against
    1.6e-2."""
    data, centre, s = blob()
    scene = blob_scene(tmp_path, data, {"renderer.filter": "gaussian", "renderer.slice_interpolation": "trilinear",
                                        "renderer.padding": 2.0})
    var = s * s + 0.7 ** 2
    p, o, d = line_integrals(scene, same_slices(scene))
    along = ((centre - o) * d).sum(axis=1)
    rho2 = ((o + along[:, None] * d - centre) ** 2).sum(axis=1)
    exact = (s / math.sqrt(var)) ** 3 * math.sqrt(2 * math.pi * var) * np.exp(-rho2 / (2 * var))
    right = np.abs(p - exact).max() / exact.max()
    original = spectrum_module.kernel_transform
    # the sign slip: the volume multiplied by k (1 / (1 / k)) instead of divided
    monkeypatch.setattr(spectrum_module, "kernel_transform",
                        lambda kind, xi, padding, taps: 1.0 / original(kind, xi, padding, taps))
    p, _, _ = line_integrals(scene, same_slices(scene))
    slipped = np.abs(p - exact).max() / exact.max()
    assert right < 1e-2 and slipped > 5 * right, (right, slipped)


def test_padding_reduces_ghosting(tmp_path):
    """The replicas of the volume that interpolating the spectrum lets in fall with the padding: the
    trilinear slice's error against the blob's closed form at padding 1.25, 2 and 3 (measured 4.0e-3,
    2.8e-3, 1.0e-3)."""
    data, centre, s = blob()
    var = s * s + 0.7 ** 2
    errors = []
    for padding in (1.25, 2.0, 3.0):
        scene = blob_scene(tmp_path, data, {"renderer.filter": "gaussian", "renderer.slice_interpolation": "trilinear",
                                            "renderer.padding": padding})
        p, o, d = line_integrals(scene, same_slices(scene))
        along = ((centre - o) * d).sum(axis=1)
        rho2 = ((o + along[:, None] * d - centre) ** 2).sum(axis=1)
        exact = (s / math.sqrt(var)) ** 3 * math.sqrt(2 * math.pi * var) * np.exp(-rho2 / (2 * var))
        errors.append(np.abs(p - exact).max() / exact.max())
    assert errors[0] > errors[1] > errors[2], errors


def test_spectrum_is_made_once_per_volume_and_settings(fourier):
    scene = small_scene({**ORTHO, "renderer.compositing": "average", "volume.size": 12, "image.width": 16,
                         "image.height": 16})
    fourier.render(scene)
    assert fourier.stats["preprocess_seconds"] > 0 and fourier.stats["fft"] in ("scipy.fft", "numpy.fft")
    fourier.render(scene)  # another frame of the same volume and settings
    assert fourier.stats["preprocess_seconds"] == 0.0
    fourier.render(scene.with_renderer(padding=3.0))
    assert fourier.stats["preprocess_seconds"] > 0


def test_the_views_frame_is_kept_for_its_view_only(fourier, shared_gl_context):
    """The frame, chords and short chords' rays are kept while the view, image size and volume hold: a view,
    a turned camera, the first view again and another image size (the image's settings changed in place),
    all of one volume, come out as a fresh renderer's."""
    import dataclasses

    scene = small_scene({**ORTHO, "renderer.compositing": "average", "volume.size": 12, "image.width": 16,
                         "image.height": 16})
    turned = dataclasses.replace(scene, camera=scene.camera.orbited(azimuth=75.0, elevation=-20.0))
    first, second, again = fourier.render(scene), fourier.render(turned), fourier.render(scene)
    with FourierRenderer(ctx=shared_gl_context) as fresh:
        assert np.array_equal(second, fresh.render(turned)) and not np.array_equal(first, second)
        assert np.array_equal(first, fresh.render(scene)) and np.array_equal(again, first)
    scene.image.width = 20  # the same ImageSpec, changed in place
    wider = fourier.render(scene)
    with FourierRenderer(ctx=shared_gl_context) as fresh:
        assert wider.shape[1] == 20 and np.array_equal(wider, fresh.render(scene))


@pytest.mark.parametrize("extra, words", [
    ({"camera.projection": "perspective"}, "orthographic"),
    ({"renderer.compositing": "xray", "renderer.classification": "post"}, "pre"),
    ({"renderer.compositing": "emission_absorption"}, "average"),
    ({"camera.distance": 1.0}, "camera.distance"),
])
def test_refusals_in_one_line(extra, words):
    scene = small_scene({**ORTHO, "renderer.compositing": "average", **extra})
    reason = registry.refusal(scene, "fourier")
    assert reason is not None and words in reason and "\n" not in reason, reason


def test_slice_taps_other_than_4_or_6_are_refused_when_read():
    from dvr_gl.errors import SceneError

    with pytest.raises(SceneError, match="renderer.slice_taps: 5 is not one of 4, 6"):
        small_scene({**ORTHO, "renderer.slice_taps": 5})



def test_ghost_moments_in_closed_form_match_the_quadrature():
    """The Gaussian's share beyond a face, in closed form (the quadrature's grid cannot resolve a kernel
    narrower than its step: kernel_width 1e-9 made the ghost layers' system singular)."""
    from dvr_gl.renderers.fourier.projection import with_ghosts

    values = np.random.default_rng(0).random((6, 7, 8, 1))
    for width in (0.5, 0.7, 1.6):
        scene = small_scene({**ORTHO, "renderer.compositing": "average", "renderer.filter": "gaussian",
                             "renderer.kernel_width": width, "volume.size": 8})
        ghosted, border = with_ghosts(scene, values)
        sigma, x = width, np.linspace(0.0, 60.0, 400001)
        share = 0.5 * math.erfc(-1.0 / (sigma * math.sqrt(2.0)))  # beyond the face, of a sample 1 voxel out
        numeric = np.trapezoid(np.exp(-0.5 * ((x - 1.0) / sigma) ** 2), x) / (sigma * math.sqrt(2 * math.pi))
        assert share == pytest.approx(numeric, abs=1e-8) and np.isfinite(ghosted).all()
        assert border == math.ceil(5 * width) - 1 + 1


@pytest.mark.parametrize("width", [1e-9, 1e-3])
def test_a_tiny_gaussian_kernel_renders(fourier, width):
    scene = small_scene({**ORTHO, "renderer.compositing": "average", "renderer.filter": "gaussian",
                         "renderer.kernel_width": width, "volume.size": 16, "image.width": 16, "image.height": 16})
    image = fourier.render(scene)
    assert np.isfinite(image).all() and image[..., 3].max() > 0


def test_a_huge_gaussian_kernel_is_refused_before_any_allocation():
    """kernel_width 1e6 asks for 5e6 ghost layers a face: refused by the memory budget, naming the key."""
    from dvr_gl.errors import DvrError
    from dvr_gl.renderers import registry

    scene = small_scene({**ORTHO, "renderer.compositing": "average", "renderer.filter": "gaussian",
                         "renderer.kernel_width": 1e6, "volume.size": 8})
    with pytest.raises(DvrError, match="renderer.kernel_width") as info:
        registry.check(scene, "fourier")
    assert "\n" not in str(info.value)


def test_the_spectrum_work_is_estimated_and_bounded(fourier):
    """A kernel wide enough to pad a 64^3 volume to 750^3 (113 s measured at 800^3) is refused under 20 s
    with the estimate in fft samples; the default fits."""
    from dvr_gl import limits
    from dvr_gl.errors import DvrError
    from dvr_gl.sandbox import Sandbox, active

    wide = small_scene({**ORTHO, "renderer.compositing": "average", "renderer.filter": "gaussian",
                        "renderer.kernel_width": 30.0, "volume.size": 64, "renderer.padding": 2.0})
    work = fourier.work(wide)
    assert work.unit == "fft samples" and "750x750x750" in work.how and work.count > 1e10
    with active(Sandbox(max_seconds=20)), pytest.raises(DvrError, match="fft samples.*kernel_width"):
        limits.check_work(work, "fourier")
    assert fourier.work(small_scene({**ORTHO, "renderer.compositing": "average"})).count < 1e8


@pytest.mark.parametrize("view_height", [1e9, 1e-9])
def test_a_slice_beyond_any_texture_is_refused_at_once(fourier, view_height):
    """A view height of 1e9 laid out a 59 GiB frequency grid (MemoryError), one of 1e-9 searched minutes for a
    fast transform length of 1e13: the slice's size is now only measured, and refused by the GL limit."""
    import time

    from dvr_gl.errors import DvrError

    scene = small_scene({**ORTHO, "renderer.compositing": "average", "renderer.slice_bandwidth": 8.0,
                         "camera.view_height": view_height, "volume.size": 8})
    start = time.perf_counter()
    with pytest.raises(DvrError, match="fourier's slice of .* texels exceeds") as info:
        fourier.render(scene)
    assert "\n" not in str(info.value) and time.perf_counter() - start < 5


@pytest.mark.parametrize("shape, dims", [((5, 7, 6), (12, 14, 16)), ((9, 4, 7), (18, 8, 16))])
def test_the_pruned_transform_is_the_padded_grids(shape, dims):
    """The spectrum's transform one axis at a time, padding each just before its pass
    (:func:`spectrum.padded_rfftn`), with scipy.fft and numpy.fft, against ``rfftn`` of the whole padded,
    shifted grid: measured 3e-14; and a second block through the x pass's lines the first left (the
    channels of one spectrum share them): the same."""
    import scipy.fft

    start = tuple((m - n) // 2 for m, n in zip(dims, shape))
    line = np.zeros(shape[:2] + dims[2:])
    for seed in (5, 6):
        block = np.random.default_rng(seed).random(shape)
        grid = np.zeros(dims)
        grid[tuple(slice(s, s + n) for s, n in zip(start, shape))] = block
        want = np.fft.rfftn(np.fft.ifftshift(grid))
        for module, threads in ((scipy.fft, True), (np.fft, False)):
            got = spectrum_module.padded_rfftn(block, dims, start, module, threads)
            assert np.abs(got - want).max() < 1e-12
            shared = spectrum_module.padded_rfftn(block, dims, start, module, threads, line)
            assert np.abs(shared - want).max() < 1e-12


@pytest.mark.parametrize("view", [{}, {"camera.azimuth": 90.0, "camera.elevation": 0.0},
                                  {"camera.target": [3.0, -2.0, 1.0], "image.width": 30}])
def test_the_chords_of_parallel_rays_are_the_rays_chords(view):
    """``Frame.chords`` (row and column terms) against the pixels' rays clipped to the box: measured 1e-14
    (a view along an axis has rays parallel to two slabs)."""
    from dvr_gl.rays import RayBatch
    from dvr_gl.renderers.fourier.projection import Frame

    scene = small_scene({**ORTHO, "renderer.compositing": "average", "volume.size": 14, "image.width": 20,
                         "image.height": 20, **view})
    chord, middle = Frame(scene).chords(scene)
    rays = RayBatch.for_camera(scene.camera, scene.image.width, scene.image.height, scene.volume.bounds)
    want = np.maximum(rays.t1 - rays.t0, 0.0).reshape(chord.shape)
    assert (want > 0).any() and (want == 0).any()
    assert np.abs(chord - want).max() < 1e-9
    hit = want > 0
    assert np.abs(middle - 0.5 * (rays.t0 + rays.t1).reshape(chord.shape))[hit].max() < 1e-9


@pytest.mark.parametrize("extra", [{}, {"renderer.slice_interpolation": "cubic_bspline", "renderer.padding": 2.0}],
                         ids=["kaiser-bessel", "cubic-bspline"])
def test_paired_taps_match_the_taps_read_one_by_one(shared_gl_context, extra):
    """The Kaiser-Bessel slice's taps two by two (one linearly filtered read a pair, the default) against
    the same slice read tap by tap and the same-slices reference, on a 48^3 Shepp-Logan X-ray (sharp
    edges: a spectrum far from small at high frequencies; 60^3): measured 9.3e-8 (per tap) and 1.3e-7
    (paired) RMS against the reference; the cubic B-spline slice at padding 2: 4.0e-8 and 7.0e-8.  The
    pairs' own error is the filtered read's position, about its row x 6e-8 texels on llvmpipe, so it
    grows with the spectrum (the blobs' X-ray at 256^3, 512x512: 6.6e-7 against 2.1e-7; CThead's at
    256x256: 3.4e-5 against 7.2e-6; dvr_gl/renderers/fourier/README.md); asserted: both the float32
    check, and the pairs within 3 times the taps' RMS (measured 1.4-1.8)."""
    scene = small_scene({**ORTHO, "renderer.compositing": "xray", "renderer.classification": "pre",
                         "renderer.shading.enabled": False, "volume.size": 48, "image.width": 40,
                         "image.height": 40, **extra})
    oracle = same_slices(scene)
    images = {}
    with FourierRenderer(ctx=shared_gl_context) as fourier:
        for paired in (False, True):
            fourier.paired_taps = paired
            images[paired] = fourier.render(scene).astype(np.float64)
            assert_close(images[paired], oracle)
    rms = {k: float(np.sqrt(np.mean((v - oracle) ** 2))) for k, v in images.items()}
    assert not np.array_equal(images[True], images[False])  # the pairs were read
    assert rms[True] <= 3.0 * rms[False], rms


def test_the_taps_are_read_one_by_one_where_the_filter_is_not_float(shared_gl_context, monkeypatch):
    """llvmpipe's linear filter weighs in float (the probe's reads within 1e-5 of the fractions: exactly
    here); a GL whose filter is not (GPUs' 8-bit weights) gets the per-tap slice."""
    scene = small_scene({**ORTHO, "renderer.compositing": "average", "volume.size": 12, "image.width": 16,
                         "image.height": 16})
    with FourierRenderer(ctx=shared_gl_context) as fourier:
        assert fourier.filters_in_float()
        paired = fourier.render(scene)
        fourier.paired_taps = False
        per_tap = fourier.render(scene)
    monkeypatch.setattr(FourierRenderer, "filters_in_float", lambda self: False)
    with FourierRenderer(ctx=shared_gl_context) as fourier:
        assert np.array_equal(fourier.render(scene), per_tap) and not np.array_equal(paired, per_tap)
