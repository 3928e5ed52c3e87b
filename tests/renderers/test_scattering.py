"""Single scattering with shadows (``[renderer.scattering]``): the phase functions, the references
against closed forms, and what a scene without scattering keeps (each GL renderer's own methods are
tested in its folder: ``dvr_gl/renderers/NAME/tests/test_scattering_NAME.py``).

The closed forms (orthographic views along -z, a homogeneous medium of extinction ``S``, colour ``C``,
albedo ``a``, one directional light of irradiance ``E``; ``q = 4 pi p(cos theta)``):

* a slab of thickness ``L`` lit through the face the eye sees, the light tilted by ``theta`` from the
  normal (``mu = cos theta``): a point at depth ``t`` is ``t / mu`` from the light's entry, so the pixel
  is ``C ((1 - a)(1 - e^(-S L)) + a q E (1 - e^(-S L (1 + 1/mu))) / (1 + 1/mu))``;
* the same slab lit through its back face: ``C ((1 - a)(1 - e^(-S L)) + a q E S e^(-S L / mu)
  (1 - e^(-S L k)) / (S k))`` with ``k = 1 - 1/mu``;
* a ball of radius ``R`` lit along the view (the light's path inside it lies on the pixel's chord of
  half-length ``h``): lit from the eye's side ``C ((1 - a)(1 - e^(-2 S h)) + a q E (1 - e^(-4 S h)) / 2)``,
  from behind ``C ((1 - a)(1 - e^(-2 S h)) + a q E 2 S h e^(-2 S h))``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import array_scene
from dvr_gl.errors import SceneError
from dvr_gl.fields import SphereField
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.reference.scattering import FOUR_PI, henyey_greenstein, isotropic, phase_maximum
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from dvr_gl.transfer_function import TransferFunction
from judges import CONVERGED, DISCRETE, renderers
from scattering_scenes import COLUMN_LIT, LIT, SMALL, with_column

COLOUR = np.array([0.9, 0.6, 0.3])
SIGMA, ALBEDO, INTENSITY = 1.3, 0.7, 1.5
# the renderer that turns a tolerance into its settings (it refuses a tolerance with scattering)
TOLERANT = renderers("tolerance")[0]


# --- the phase functions -------------------------------------------------------------------------

def _sphere_integral(f) -> float:
    """``2 pi`` times the integral of ``f(mu)`` over ``mu`` in [-1, 1]: Gauss-Legendre on pieces that
    shrink geometrically toward both ends, where Henyey-Greenstein's peaks are (width ~ (1 - |g|)^2)."""
    edges = np.concatenate([-1.0 + np.logspace(-12, 0, 49), 1.0 - np.logspace(0, -12, 49)[1:]])
    edges = np.unique(np.concatenate([[-1.0, 1.0], edges]))
    x, w = np.polynomial.legendre.leggauss(32)
    a, b = edges[:-1, None], edges[1:, None]
    mu = 0.5 * (a + b) + 0.5 * (b - a) * x
    return float(2.0 * np.pi * np.sum(0.5 * (b - a) * w * f(mu)))


@pytest.mark.parametrize("g", [-0.99, -0.6, 0.0, 0.3, 0.85, 0.99])
def test_henyey_greenstein_is_normalised_with_mean_cosine_g(g):
    assert _sphere_integral(lambda mu: henyey_greenstein(mu, g)) == pytest.approx(1.0, abs=1e-10)
    assert _sphere_integral(lambda mu: mu * henyey_greenstein(mu, g)) == pytest.approx(g, abs=1e-10)
    peak = 1.0 if g >= 0 else -1.0
    assert FOUR_PI * henyey_greenstein(np.array([peak]), g)[0] == pytest.approx(
        phase_maximum(type("S", (), {"phase": "henyey_greenstein", "g": g})()), rel=1e-12)


def test_isotropic_phase_and_henyey_greenstein_at_zero_agree():
    mu = np.linspace(-1.0, 1.0, 7)
    assert np.allclose(isotropic(mu), 1.0 / FOUR_PI)
    assert np.allclose(henyey_greenstein(mu, 0.0), 1.0 / FOUR_PI, rtol=0, atol=1e-15)
    assert _sphere_integral(isotropic) == pytest.approx(1.0, abs=1e-12)


def test_henyey_greenstein_keeps_its_digits_at_the_extremes():
    """Near g = -1 the textbook denominator 1 + g^2 - 2 g mu cancels at mu = -1; the written-out form
    keeps the peak (1 + |g|) / (1 - |g|)^2 / (4 pi) to rounding."""
    for g in (-0.999999, 0.999999):
        peak = np.array([math.copysign(1.0, g)])
        exact = (1.0 + abs(g)) / (1.0 - abs(g)) ** 2 / FOUR_PI
        assert henyey_greenstein(peak, g)[0] == pytest.approx(exact, rel=1e-9)


# --- closed forms ---------------------------------------------------------------------------------

def _medium_points():
    return [[0.0, *COLOUR, SIGMA], [1.0, *COLOUR, SIGMA]]


def _light(direction, **extra):
    return {"type": "directional", "direction": list(direction), "intensity": INTENSITY, **extra}


def _scattering(lights, **extra):
    return {"enabled": True, "albedo": ALBEDO, "lights": lights, **extra}


def _slab_scene(tmp_path, renderer, lights, **extra):
    """A slab 4 x 4 x 1 (world) of constant data, seen orthographically from +z."""
    data = np.full((3, 9, 9), 0.5, np.float32)
    overrides = {"renderer.name": renderer, "transfer_function.points": _medium_points(),
                 "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 12,
                 "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
                 "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.0, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-7, "renderer.scattering": _scattering(lights, **extra)}
    return array_scene(tmp_path, data, overrides, spacing=(0.5, 0.5, 0.5))


def _slab_expected(front: bool, theta: float, q: float, albedo: float = ALBEDO):
    mu, s_l = math.cos(theta), SIGMA * 1.0
    emitted = (1.0 - albedo) * -math.expm1(-s_l)
    if front:
        k = 1.0 + 1.0 / mu
        scattered = q * INTENSITY * -math.expm1(-s_l * k) / k
    else:
        k = 1.0 - 1.0 / mu
        scattered = q * INTENSITY * math.exp(-s_l / mu) * -math.expm1(-s_l * k) / k
    return COLOUR * (emitted + albedo * scattered), -math.expm1(-s_l)


@pytest.mark.parametrize("front", [True, False])
@pytest.mark.parametrize("phase", [{}, {"phase": "henyey_greenstein", "g": 0.6}])
def test_slab_lit_by_a_directional_light(tmp_path, front, phase):
    theta = math.radians(40.0)
    direction = (math.sin(theta), 0.0, -math.cos(theta) if front else math.cos(theta))
    # cos of the angle between the light's travel and the direction toward the eye (+z)
    cos_scatter = direction[2]
    q = 1.0 if not phase else FOUR_PI * henyey_greenstein(np.array([cos_scatter]), 0.6)[0]
    colour, alpha = _slab_expected(front, theta, q)
    scene = _slab_scene(tmp_path, CONVERGED, [_light(direction)], **phase)
    assert scene.field.bounds[1][2] - scene.field.bounds[0][2] == pytest.approx(1.0)
    image = ConvergedReference(scene).render_float64()
    # every pixel's shadow rays leave through the lit face: the image is within 1 of the slab's middle
    assert np.abs(image[..., :3] - colour).max() < 1e-6
    assert np.abs(image[..., 3] - alpha).max() < 1e-12
    # the same discretization at a fine step: midpoint sampling of e^(-S t / mu) errs by about
    # (S d / mu)^2 / 24 relatively (2.8e-7 at d = 0.002); the shadow march of a constant medium is exact.
    # Every pixel is the same, so 6 x 6 of them over the same view (a quarter of the float64 cost)
    # measure what 12 x 12 do: at most 4.7e-7, the same to every digit at both sizes
    fine = scene.with_renderer(name=DISCRETE, sample_distance=0.002)
    fine = DiscreteReference(fine.replace(image=dataclasses.replace(fine.image, width=6, height=6))).render_float64()
    assert fine.shape == (6, 6, 4)
    assert np.abs(fine[..., :3] - colour).max() < 1e-6


def _ball_scene(renderer, lights, **extra):
    radius = 1.0
    box = load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 4, "renderer.name": renderer,
                            "image.width": 11, "image.height": 11, "camera.projection": "orthographic",
                            "camera.eye": [0.0, 0.0, 8.0], "camera.target": [0.0, 0.0, 0.0],
                            "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.4, "renderer.ert_threshold": 1.0,
                            "renderer.converged_tolerance": 1e-7,
                            "renderer.scattering": _scattering(lights, **extra)})
    field = SphereField((0.0, 0.0, 0.0), radius, bounds=((-1.2, -1.2, -1.2), (1.2, 1.2, 1.2)), sample_spacing=0.05)
    tf = TransferFunction(np.array([[0.0, *COLOUR, 0.0], [1.0, *COLOUR, SIGMA]]), opacity_model="extinction")
    return box.replace(field=field, camera=box.camera, transfer_function=tf), radius


@pytest.mark.parametrize("toward_eye", [False, True])
def test_ball_lit_along_the_view(toward_eye):
    """Light travelling along the view (lit from the eye's side, backscattering) or toward the eye
    (lit from behind, forward scattering through Henyey-Greenstein)."""
    g = 0.5
    direction = (0.0, 0.0, 1.0 if toward_eye else -1.0)
    scene, radius = _ball_scene(CONVERGED, [_light(direction)], phase="henyey_greenstein", g=g)
    q = FOUR_PI * henyey_greenstein(np.array([direction[2]]), g)[0]
    o, d = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    b2 = np.sum(o[:, :2] ** 2, axis=1)
    h = np.sqrt(np.maximum(radius ** 2 - b2, 0.0))
    emitted = (1.0 - ALBEDO) * -np.expm1(-2.0 * SIGMA * h)
    if toward_eye:
        scattered = q * INTENSITY * 2.0 * SIGMA * h * np.exp(-2.0 * SIGMA * h)
    else:
        scattered = q * INTENSITY * -np.expm1(-4.0 * SIGMA * h) / 2.0
    expected = (emitted + ALBEDO * scattered)[:, None] * COLOUR
    image = ConvergedReference(scene).render_float64().reshape(-1, 4)
    away = np.abs(np.sqrt(b2) - radius) > 0.02  # the silhouette, where a pixel's chord is all edge
    assert away.sum() > 60
    assert np.abs(image[away, :3] - expected[away]).max() < 1e-6
    assert np.abs(image[away, 3] - -np.expm1(-2.0 * SIGMA * h[away])).max() < 1e-9


def test_point_light_on_the_axis_against_a_direct_quadrature():
    """A point light above the ball on the view axis: along the central pixel's chord (z from R down to
    -R) the light is ``Z - z`` away and its path inside the ball ``R - z``, so the scattered light is
    ``a q I S int e^(-2 S (R - z)) / (Z - z)^2 dz`` (q for backscattering, isotropic: 1)."""
    z_light = 3.0
    scene, radius = _ball_scene(CONVERGED, [{"type": "point", "position": [0.0, 0.0, z_light],
                                                          "intensity": INTENSITY}])
    x, w = np.polynomial.legendre.leggauss(200)
    z = radius * x
    scattered = radius * np.sum(w * SIGMA * INTENSITY * np.exp(-2.0 * SIGMA * (radius - z)) / (z_light - z) ** 2)
    emitted = (1.0 - ALBEDO) * -math.expm1(-2.0 * SIGMA * radius)
    image = ConvergedReference(scene).render_float64()
    centre = image[scene.image.height // 2, scene.image.width // 2]
    assert np.abs(centre[:3] - COLOUR * (emitted + ALBEDO * scattered)).max() < 1e-6


# --- identities and what a scene without scattering keeps -----------------------------------------


@pytest.mark.parametrize("name", [DISCRETE, CONVERGED])
def test_unshadowed_isotropic_unit_light_is_emission_absorption(name):
    """With no shadows, isotropic phase and one light of intensity 1, ``F = 1`` everywhere: the image is
    emission-absorption's, whatever the albedo; albedo 0 is emission-absorption with any light."""
    plain = registry.plugin(name).create().render(load_scene(None, {**SMALL, "renderer.name": name}))
    for scattering in ({"enabled": True, "albedo": 1.0, "shadows": False, "lights": [{"intensity": 1.0}]},
                       {"enabled": True, "albedo": 0.0, "lights": [{"intensity": 7.0}]}):
        scene = load_scene(None, {**SMALL, "renderer.name": name, "renderer.scattering": scattering})
        image = registry.plugin(name).create().render(scene)
        assert np.abs(image - plain).max() < 1e-6


def test_shadows_darken_and_the_discrete_reference_converges():
    """Shepp-Logan lit from the side: shadows take light away, and the same-discretization reference
    approaches the converged one as its step (view and shadow rays) shrinks."""
    scattering = {"enabled": True, "albedo": 1.0, "lights": [{"direction": [1.0, 0.3, -0.2], "intensity": 3.0}]}
    over = {**SMALL, "renderer.scattering": scattering, "renderer.ert_threshold": 1.0,
            "transfer_function.points": [[0.0, 1.0, 1.0, 1.0, 0.0], [0.3, 1.0, 1.0, 1.0, 0.6],
                                         [1.0, 1.0, 1.0, 1.0, 0.9]]}
    truth = ConvergedReference(load_scene(None, {**over, "renderer.converged_tolerance": 1e-6})).render_float64()
    unshadowed = ConvergedReference(load_scene(None, {**over, "renderer.scattering.shadows": False})).render_float64()
    assert truth[..., 3].max() > 0.3
    assert (truth[..., :3] <= unshadowed[..., :3] + 1e-6).all()
    assert (unshadowed[..., :3] - truth[..., :3]).max() > 0.05
    errors = []
    for voxels in (1.0, 0.5, 0.25):
        scene = load_scene(None, {**over, "renderer.name": DISCRETE, "renderer.sample_distance_voxels": voxels})
        errors.append(float(np.sqrt(np.mean((DiscreteReference(scene).render_float64() - truth) ** 2))))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.35 * errors[0]  # second order: a quarter per halving, with rounding of knots


def test_scene_file_round_trip_and_defaults(tmp_path):
    scene = load_scene(None, {**SMALL, "renderer.name": DISCRETE,
                              "renderer.scattering": {"enabled": True, "phase": "henyey_greenstein", "g": 0.4,
                                                      "lights": [{"type": "point", "position": [1.0, 2.0, 3.0]}]}})
    path = tmp_path / "scene.toml"
    path.write_text(scene.to_toml())
    again = load_scene(path)
    assert again.renderer.scattering == scene.renderer.scattering
    assert again.renderer.scattering.lights[0].position == (1.0, 2.0, 3.0)
    default = load_scene(None, SMALL).renderer.scattering
    assert not default.enabled and default.lights[0].type == "directional"


@pytest.mark.parametrize("overrides, words", [
    ({"renderer.scattering.albedo": 1.5}, "albedo must be in [0, 1]"),
    ({"renderer.scattering.g": 1.0, "renderer.scattering.phase": "henyey_greenstein"}, "g must be in (-1, 1)"),
    ({"renderer.scattering.g": 0.5}, "applies to phase = 'henyey_greenstein'"),
    ({"renderer.scattering.lights": []}, "lights is empty"),
    ({"renderer.scattering.lights": [{"direction": [0.0, 0.0, 0.0]}]}, "direction must be a non-zero vector"),
    ({"renderer.scattering.lights": [{"intensity": -1.0}]}, "intensity must be >= 0"),
    ({"renderer.scattering.phase": "rayleigh"}, "is not one of isotropic, henyey_greenstein"),
    ({"renderer.compositing": "mip"}, "emission-absorption only, not compositing = 'mip'"),
    ({"renderer.shading.enabled": True}, "turn one off"),
    ({"renderer.name": TOLERANT, "renderer.tolerance": 0.01}, "modelled without shading, scattering"),
])
def test_bad_scattering_is_one_line(overrides, words):
    with pytest.raises(SceneError) as info:
        load_scene(None, {**SMALL, "renderer.name": DISCRETE, "renderer.scattering.enabled": True, **overrides})
    assert words in str(info.value) and "\n" not in str(info.value)


def test_renderers_without_scattering_refuse_it():
    """Every grid renderer that does not declare the setting refuses a scene that asks for it, naming the
    ones that render it (those without emission-absorption refuse the mode first: tested above)."""
    for name in registry.names():
        plugin = registry.plugin(name)
        if (plugin.declared("scattering") is not None or "emission_absorption" not in plugin.choices("compositing")
                or (plugin.data_kinds is not None and "grid" not in plugin.data_kinds)):
            continue
        filters = plugin.choices("filter")
        scene = load_scene(None, {**SMALL, "renderer.scattering.enabled": True,
                                  "renderer.filter": "linear" if "linear" in filters else filters[0]})
        problem = registry.refusal(scene, name)
        assert problem is not None and "scattering" in problem and DISCRETE in problem, name


# --- the light volume, in the reference -------------------------------------------------------------------------


def test_light_volume_converges_to_the_shadow_rays():
    """The light volume's error against reference-converged falls with its resolution, at second
    order (trilinear interpolation of a smooth optical depth), toward the shadow rays' own."""
    over = {**LIT, "volume.size": 20, "image.width": 24, "image.height": 24}
    truth = ConvergedReference(load_scene(None, {**over, "renderer.converged_tolerance": 1e-5})).render_float64()

    def rms(extra):
        scene = load_scene(None, {**over, "renderer.name": DISCRETE, **extra})
        return float(np.sqrt(np.mean((DiscreteReference(scene).render_float64() - truth) ** 2)))
    rays = rms({})
    errors = [rms({"renderer.scattering.method": "light_volume", "renderer.scattering.light_volume_size": n})
              for n in (8, 16, 32)]
    assert errors[0] > 2.5 * errors[1] > 2.5 ** 2 * errors[2]
    assert errors[2] < 10 * rays


# --- the Monte Carlo reference ---------------------------------------------------------------------

MC_SCENE = {**SMALL, "image.width": 10, "image.height": 8, "renderer.converged_tolerance": 1e-5,
            "renderer.scattering": {"enabled": True, "albedo": 0.9, "phase": "henyey_greenstein", "g": 0.4,
                                    "lights": [{"direction": [1.0, 0.3, -0.2], "intensity": 3.0}]},
            "transfer_function.points": [[0.0, 1.0, 0.8, 0.6, 0.0], [0.3, 1.0, 0.8, 0.6, 0.6],
                                         [1.0, 0.6, 0.8, 1.0, 0.9]]}


def test_monte_carlo_single_scattering_agrees_with_the_converged_reference():
    """Paths of one collision estimate what reference-converged integrates: the differences over their
    standard errors are standard normal (measured: RMS 0.80, largest 2.6 over 24 pixels x 4 channels
    at 2000 paths, seed 1); a pixel the reference sees material in has collisions."""
    from dvr_gl.reference.monte_carlo import MonteCarloReference

    scene = load_scene(None, MC_SCENE)
    truth = ConvergedReference(scene).render_float64()
    image, error = MonteCarloReference(scene, paths=2000, seed=1, max_collisions=1).render()
    seen = error[..., 3] > 0
    assert seen.sum() >= 20 and truth[~seen].max() < 2e-3
    z = ((image - truth) / np.where(error > 0, error, 1.0))[seen]
    assert 0.5 < np.sqrt(np.mean(z ** 2)) < 1.5 and np.abs(z).max() < 5.0


def test_monte_carlo_multiple_scattering_adds_light_and_is_seeded():
    from dvr_gl.reference.monte_carlo import MonteCarloReference

    scene = load_scene(None, MC_SCENE)
    single, single_error = MonteCarloReference(scene, paths=300, seed=3, max_collisions=1).render()
    full, full_error = MonteCarloReference(scene, paths=300, seed=3).render()
    again, _ = MonteCarloReference(scene, paths=300, seed=3).render()
    assert np.array_equal(full, again)
    # albedo 0.9: light scattered twice and more brightens the picture well beyond the noise
    gain = full[..., :3].sum() - single[..., :3].sum()
    noise = np.sqrt((full_error[..., :3] ** 2).sum() + (single_error[..., :3] ** 2).sum())
    assert gain > 5 * noise
    # albedo 0: nothing scatters, so paths end at their first collision either way
    dark = scene.with_renderer(scattering=dataclasses.replace(scene.renderer.scattering, albedo=0.0))
    a, _ = MonteCarloReference(dark, paths=50, seed=5).render()
    b, _ = MonteCarloReference(dark, paths=50, seed=5, max_collisions=1).render()
    assert np.array_equal(a, b)


def test_henyey_greenstein_sampling_has_mean_cosine_g():
    from dvr_gl.reference.monte_carlo import sample_henyey_greenstein

    rng = np.random.default_rng(0)
    d = np.tile([[0.0, 0.6, 0.8]], (200_000, 1))
    for g in (-0.7, 0.0, 0.5, 0.95):
        new = sample_henyey_greenstein(d, g, rng)
        assert np.allclose(np.linalg.norm(new, axis=1), 1.0)
        # the sample mean of cos within 4 standard errors (its variance is below 1 / 3 + g^2)
        assert abs(np.mean(np.sum(new * d, axis=1)) - g) < 4.0 * np.sqrt(0.5 / len(d))


# --- half-angle slicing's geometry ---------------------------------------------------------------


def test_half_angle_geometry():
    """The half vector lies between the eye and the light (or the light and away from the eye), the
    slices go from the light, and the light buffer covers the box."""
    from dvr_gl.gl.geometry import box_corners
    from dvr_gl.half_angle import half_angle

    scene = load_scene(None, {**SMALL, "camera.projection": "orthographic"})
    box = scene.volume.box
    toward_eye = -np.asarray(scene.camera.basis()[0])
    for direction, front_to_back in (((0.3, -0.2, -1.0), True), (tuple(toward_eye), False)):
        ha = half_angle(scene.camera, box, direction, 0.5, 64)
        toward_light = -np.asarray(direction) / np.linalg.norm(direction)
        assert np.isclose(np.linalg.norm(ha.normal), 1.0) and ha.normal @ toward_light > 0
        assert ha.eye_front_to_back == front_to_back
        offsets = ha.offsets(ha.order())
        assert np.all(np.diff(offsets) < 0)  # from the light: largest offsets along h first
        uv = ha.light_uv(box_corners(*box))
        assert uv.min() > 0.0 and uv.max() < 1.0
        assert ha.light_length == pytest.approx(0.5 / abs(toward_light @ ha.normal))


# --- the albedo as the transfer function's sixth column ---------------------------------------------

def test_slab_with_the_albedo_column_against_its_closed_form(tmp_path):
    """The slab's data is 0.5 everywhere, so a column rising from 0.3 at 0 to 1.0 at 1 gives it albedo
    0.65: the closed form with that albedo, to 1e-6 as with a number."""
    theta = math.radians(40.0)
    direction = (math.sin(theta), 0.0, -math.cos(theta))
    colour, alpha = _slab_expected(True, theta, 1.0, albedo=0.65)
    scene = _slab_scene(tmp_path, CONVERGED, [_light(direction)])
    column = scene.replace(transfer_function=TransferFunction(
        [[0.0, *COLOUR, SIGMA, 0.3], [1.0, *COLOUR, SIGMA, 1.0]], opacity_model="extinction"))
    column = column.with_renderer(scattering=dataclasses.replace(column.renderer.scattering, albedo=None))
    image = ConvergedReference(column).render_float64()
    assert np.abs(image[..., :3] - colour).max() < 1e-6
    assert np.abs(image[..., 3] - alpha).max() < 1e-12


@pytest.mark.parametrize("name", [DISCRETE, CONVERGED])
def test_a_constant_albedo_column_is_the_number(name):
    """A column holding 0.9 at every point renders as ``albedo = 0.9``; a number given overrides the
    column (the default reads it)."""
    plain = load_scene(None, {**LIT, "renderer.name": name})
    column = load_scene(None, {**with_column(LIT, [0.9] * 3), "renderer.name": name,
                               "renderer.scattering.albedo": "transfer_function"})
    renderer = registry.plugin(name).create()
    expected = renderer.render(plain)
    assert np.abs(renderer.render(column) - expected).max() < 1e-12
    overridden = load_scene(None, {**with_column(LIT, [0.1] * 3), "renderer.name": name,
                                   "renderer.scattering.albedo": 0.9})
    assert np.abs(renderer.render(overridden) - expected).max() < 1e-12


def test_monte_carlo_reads_the_albedo_column():
    """The same seed draws the same paths: a constant column is the number exactly, and a column of 0
    ends every path at its first collision."""
    from dvr_gl.reference.monte_carlo import MonteCarloReference

    scene = load_scene(None, MC_SCENE)
    column = load_scene(None, {**with_column(MC_SCENE, [0.9] * 3), "renderer.scattering.albedo": "transfer_function"})
    assert np.array_equal(MonteCarloReference(scene, paths=40, seed=2).render()[0],
                          MonteCarloReference(column, paths=40, seed=2).render()[0])
    dark = load_scene(None, {**with_column(MC_SCENE, [0.0] * 3), "renderer.scattering.albedo": "transfer_function"})
    a, _ = MonteCarloReference(dark, paths=30, seed=5).render()
    b, _ = MonteCarloReference(dark, paths=30, seed=5, max_collisions=1).render()
    assert np.array_equal(a, b) and a[..., :3].max() > 0


def test_monte_carlo_with_a_varying_albedo_column_agrees_with_the_converged_reference():
    """One collision per path against reference-converged with the column (as with a number above):
    the differences over their standard errors are standard normal."""
    from dvr_gl.reference.monte_carlo import MonteCarloReference

    scene = load_scene(None, {**with_column(MC_SCENE, [0.1, 1.0, 0.4]), "image.width": 8, "image.height": 6,
                              "renderer.scattering.albedo": "transfer_function"})
    truth = ConvergedReference(scene).render_float64()
    image, error = MonteCarloReference(scene, paths=1500, seed=1, max_collisions=1).render()
    seen = error[..., 3] > 0
    z = ((image - truth) / np.where(error > 0, error, 1.0))[seen]
    assert seen.sum() >= 12 and 0.5 < np.sqrt(np.mean(z ** 2)) < 1.5 and np.abs(z).max() < 5.0


@pytest.mark.parametrize("overrides, words", [
    ({"renderer.scattering.albedo": "transfer_function"}, "these have five"),
    ({"renderer.scattering.albedo": "column"}, "or 'transfer_function'"),
    ({"renderer.scattering.albedo": True}, "expected a number or a string"),
    ({"transfer_function.points": [[0.0, 1, 1, 1, 0.5, 0.2], [1.0, 1, 1, 1, 0.5, 1.5]]},
     "albedo [1.5] outside [0, 1]"),
    ({"transfer_function.points": [[0.0, 1, 1, 1, 0.5, 0.2], [1.0, 1, 1, 1, 0.5, 0.3]],
      "renderer.classification": "pre"}, "classification = 'pre' classifies the voxels"),
    ({"transfer_function.points": [[0.0, 1, 1, 1, 0.5, 0.2, 0.1]]}, "[value, r, g, b, opacity, albedo]"),
])
def test_bad_albedo_column_is_one_line(overrides, words):
    with pytest.raises(SceneError) as info:
        load_scene(None, {**SMALL, "renderer.name": DISCRETE, "renderer.scattering.enabled": True, **overrides})
    assert words in str(info.value) and "\n" not in str(info.value)


def test_albedo_column_round_trips_and_survives_edits(tmp_path):
    from dvr_gl.viewer.tf_editor import TransferFunctionEditor

    scene = load_scene(None, {**COLUMN_LIT, "renderer.name": DISCRETE})
    path = tmp_path / "scene.toml"
    path.write_text(scene.to_toml())
    again = load_scene(path)
    assert np.array_equal(again.transfer_function.points, scene.transfer_function.points)
    assert again.transfer_function.has_albedo and again.renderer.scattering.albedo == 0.9
    editor = TransferFunctionEditor(scene.transfer_function)
    i = editor.add(0.65, 0.2)  # halfway between the points at 0.3 (albedo 1.0) and 1.0 (0.4)
    edited = editor.transfer_function()
    assert edited.points[i, 5] == pytest.approx(0.7) and edited.albedo([0.65])[0] == pytest.approx(0.7)
    cut = scene.transfer_function.transparent_below(-0.5, 0.0)
    assert cut.has_albedo and cut.albedo([0.0, 1.0]).tolist() == [0.1, 0.4]
