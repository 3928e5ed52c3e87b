"""The Gaussian reconstruction filter (the splatting kernel) in the model and both CPU references."""

import math

import numpy as np
import pytest

from conftest import array_scene, small_scene
from dvr_gl.fields.reconstruction import GAUSSIAN_DEGREE, GaussianKernel, SampledField
from dvr_gl.rays import intersect_box
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.model import GAUSSIAN_RADIUS
from judges import DISCRETE, judges, renderers


def brute_force(values, spacing, origin, sigma, point):
    """``sum_i v_i K(u - i)`` over the grid's samples and, beyond it, its border samples repeated."""
    kernel = GaussianKernel(sigma)
    pad = int(np.ceil(kernel.radius)) + 1
    padded = np.pad(values, pad, mode="edge")
    nz, ny, nx = padded.shape
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    u = (np.asarray(point) - origin) / spacing + pad
    return (kernel((x - u[0]) ** 2 + (y - u[1]) ** 2 + (z - u[2]) ** 2) * padded).sum()


def test_kernel_has_unit_integral_and_its_footprint_is_its_line_integral():
    kernel = GaussianKernel(0.7)
    assert kernel.radius == pytest.approx(GAUSSIAN_RADIUS * 0.7)
    h = 0.02
    x = np.arange(-3.6, 3.6 + h / 2, h)
    xx, yy, zz = np.meshgrid(x, x, x, indexing="ij", sparse=True)
    # the midpoint rule on a grid of 0.02: within 1e-5 of the integral (the truncation's jump at the rim)
    assert abs(kernel(xx ** 2 + yy ** 2 + zz ** 2).sum() * h ** 3 - 1.0) < 1e-5
    t = np.linspace(-3.6, 3.6, 72001)
    for rho in (0.0, 0.5, 1.5, 3.0, 3.45):
        numeric = kernel(rho ** 2 + t ** 2).sum() * (t[1] - t[0])
        assert kernel.footprint(rho ** 2) == pytest.approx(numeric, rel=1e-6, abs=1e-9)  # the rim's jump: abs
    assert kernel.footprint(3.6 ** 2) == 0.0  # beyond the radius
    # the footprint is a 2D Gaussian within 2e-5 of its peak (model.GAUSSIAN_RADIUS)
    rho2 = np.linspace(0.0, kernel.radius ** 2, 200)
    gauss2d = np.exp(-0.5 * rho2 / 0.49) / (2 * math.pi * 0.49)
    assert np.abs(kernel.footprint(rho2) - gauss2d).max() < 2e-5 * gauss2d[0]


@pytest.mark.parametrize("a", [3.0, 4.0, 6.0])
def test_a_kernel_cut_elsewhere_keeps_unit_mass(a):
    """``renderer.kernel_radius``: the kernel cut at ``a`` standard deviations, scaled back to unit mass (the
    3D normal's mass inside radius ``a``: 0.971, 0.9989, 1 - 7.5e-8); its footprint integrates to one over
    the disc it covers (the trapezoid rule over 200,001 radii: within 1e-8; the rim's square root)."""
    kernel = GaussianKernel(0.7, a)
    assert kernel.radius == pytest.approx(a * 0.7)
    rho2 = np.linspace(0.0, kernel.radius ** 2, 200001)
    assert np.trapezoid(kernel.footprint(rho2), rho2) * math.pi == pytest.approx(1.0, abs=1e-8)  # d(pi rho^2)
    assert kernel.footprint(kernel.radius ** 2 * 1.0001) == 0.0
    # the peak rises by the mass cut away: 1 / (1 - mass beyond a)
    inside = math.erf(a / math.sqrt(2.0)) - math.sqrt(2.0 / math.pi) * a * math.exp(-0.5 * a * a)
    assert kernel(np.zeros(1))[0] * (2 * math.pi) ** 1.5 * 0.7 ** 3 == pytest.approx(1.0 / inside, rel=1e-12)
    with pytest.raises(ValueError, match="kernel_radius"):
        GaussianKernel(0.7, 0.0)


def test_the_references_read_the_scenes_kernel_radius(tmp_path):
    """Both references reconstruct with the scene's cut: a spike's X-ray is its kernel's footprint, so the
    pixel at the footprint's rim is zero when cut at 3 standard deviations and not at 5."""
    data = np.zeros((15, 15, 15))
    data[7, 7, 7] = 1.0
    keys = {"renderer.filter": "gaussian", "renderer.kernel_width": 1.0, "renderer.compositing": "xray",
            "camera.projection": "orthographic", "image.width": 31, "image.height": 31}
    cut = {a: array_scene(tmp_path, data, {**keys, "renderer.kernel_radius": a}) for a in (3.0, 5.0)}
    for judge in (DiscreteReference, ConvergedReference):
        images = {a: np.asarray(judge(sc).render(), float)[..., 0] for a, sc in cut.items()}
        centre = images[5.0][15, 15]
        assert centre > 0 and images[3.0][15, 15] > centre  # unit mass inside a smaller sphere: a higher peak
        ring = images[5.0] > 0
        assert (images[3.0] > 0).sum() < ring.sum()  # the footprint's disc: radius 3 voxels against 5


@pytest.mark.parametrize("sigma", [0.5, 0.7, 1.3])
def test_field_is_the_sum_of_the_samples_kernels(sigma):
    rng = np.random.default_rng(3)
    values = rng.random((7, 9, 11))
    spacing, origin = np.array([0.5, 1.0, 2.0]), np.array([-1.0, 2.0, 0.5])
    field = SampledField(values, spacing, origin, "gaussian", sigma)
    hi = origin + (np.array([11, 9, 7]) - 1) * spacing
    points = np.concatenate([origin + rng.random((20, 3)) * (hi - origin), [origin, hi, 0.5 * (origin + hi)]])
    got = field.sample(points)
    want = [brute_force(values, spacing, origin, sigma, p) for p in points]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)
    # other channels alike (pre-classification)
    both = SampledField(np.stack([values, 2.0 * values], axis=-1), spacing, origin, "gaussian", sigma)
    np.testing.assert_allclose(both.sample(points), np.stack([got, 2.0 * got], axis=1), atol=1e-13)
    # a constant, to the lattice's ripple (1 + 2 exp(-2 pi^2 sigma^2))^3 - 1 (and 2e-5, the truncation's)
    flat = SampledField(np.full((5, 4, 3), 2.5), spacing, origin, "gaussian", sigma)
    ripple = (1 + 2 * math.exp(-2 * math.pi ** 2 * sigma ** 2)) ** 3 - 1 + 2e-5
    off = np.abs(flat.sample(points) / 2.5 - 1.0).max()
    assert off < ripple
    if sigma == 0.5:
        assert off > 0.3 * ripple  # the ripple is there: the model keeps it


def test_a_piece_is_its_polynomial_within_the_truncations_floor():
    """The converged reference stands a polynomial of degree ``GAUSSIAN_DEGREE`` for each piece (at most a
    voxel long) for its exact extremum, first hit and breakpoints: measured at most 1.5e-5 of the value
    range at sigma 0.7, the floor the truncation's jumps set (asserted 3e-5)."""
    rng = np.random.default_rng(1)
    field = SampledField(rng.random((24, 24, 24)), (1, 1, 1), (0, 0, 0), "gaussian", 0.7)
    nodes = np.cos(np.pi * (np.arange(GAUSSIAN_DEGREE + 1) + 0.5) / (GAUSSIAN_DEGREE + 1))
    x = np.linspace(-1.0, 1.0, 201)
    worst = 0.0
    for _ in range(60):
        o = rng.random(3) * 10 + 6
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        length = rng.random()
        coeffs = np.polynomial.chebyshev.chebfit(nodes, field.sample(o + ((nodes + 1) / 2 * length)[:, None] * d),
                                                 GAUSSIAN_DEGREE)
        exact = field.sample(o + ((x + 1) / 2 * length)[:, None] * d)
        worst = max(worst, np.abs(np.polynomial.chebyshev.chebval(x, coeffs) - exact).max())
    assert worst < 3e-5


def spike_scene(tmp_path, mode_extra, spacing=(1.0, 1.0, 1.0), sigma=1.0, view=None):
    """A zero volume of SPIKE^3 with one sample of 1 at its centre, seen by the average (X-ray) compositing
    with extinction ``K_SIGMA * value``, so the alpha of a pixel gives the average back exactly."""
    data = np.zeros((SPIKE, SPIKE, SPIKE), np.float32)
    data[SPIKE // 2, SPIKE // 2, SPIKE // 2] = 1.0
    overrides = {"transfer_function.points": [[0, 1, 1, 1, 0], [1, 1, 1, 1, K_SIGMA]],
                 "transfer_function.opacity_model": "extinction", "renderer.compositing": "average",
                 "transfer_function.unit_distance": 1.0,   # the closed form's extinction is per world unit
                 "renderer.filter": "gaussian", "renderer.kernel_width": sigma, "renderer.ert_threshold": 1.0,
                 "camera.projection": "orthographic", "camera.view_height": 8.0 * sigma * max(spacing),
                 "image.width": 24, "image.height": 24, **(view or {}), **mode_extra}
    return array_scene(tmp_path, data, overrides, spacing=spacing)


K_SIGMA = 0.5
#: the spike's volume, samples per axis: the kernel (model.GAUSSIAN_RADIUS = 5 voxels) inside it with 3 voxels to
#: spare, and every pixel's ray through the box (the view, 8 sigma max(spacing) = 14.4 wide, within x's 16); 21
#: measured the same errors (below) and cost 1.3x the time; at 13 rays of the anisotropic view miss the box
SPIKE = 17


@pytest.mark.parametrize("spacing,view", [((1.0, 1.0, 1.0), {"camera.azimuth": 31.0, "camera.elevation": 22.0}),
                                          ((1.0, 0.6, 1.8), {"camera.azimuth": 0.0, "camera.elevation": 0.0})])
@pytest.mark.parametrize("judge", ["converged", "discrete"])
def test_xray_of_one_kernel_is_its_closed_form_footprint(tmp_path, spacing, view, judge):
    """The line integral of one sample's kernel is its footprint: a 2D Gaussian in the plane across the
    view (an ellipse in world units where the spacing is anisotropic).  Against the truncated kernel's
    footprint the converged reference (Gauss-Legendre on pieces of at most a voxel) measured 3.2e-7 and
    3.8e-7 of the peak (isotropic, anisotropic), the discrete one at 0.05 voxel 7.0e-8 and 8.2e-8; against
    the plain 2D Gaussian all 1.5e-5 (the mass the truncation drops, model.GAUSSIAN_RADIUS).  Asserted:
    1e-4, the splatting tests' bound."""
    extra = ({"renderer.converged_tolerance": 1e-8} if judge == "converged"
             else {"renderer.sample_distance_voxels": 0.05, "renderer.lut_size": 1 << 16})
    scene = spike_scene(tmp_path, extra, spacing=spacing, view=view)
    renderer = ConvergedReference if judge == "converged" else DiscreteReference
    alpha = renderer(scene).render_float64()[..., 3].ravel()
    o, d = scene.camera.pixel_rays(24, 24)
    t0, t1 = intersect_box(o, d, *scene.field.bounds)
    # Per pixel: the ray's nearest approach to the sample in voxel units (the kernel is a sphere there).
    centre = np.full(3, SPIKE // 2, float) * spacing
    inv = 1.0 / np.asarray(spacing)
    u_o, u_d = (o - centre) * inv, d * inv
    along = -(u_o * u_d).sum(axis=1) / (u_d * u_d).sum(axis=1)
    rho2 = ((u_o + along[:, None] * u_d) ** 2).sum(axis=1)
    # d t (world) = |u_d|^-1 du along the ray: the integral in world units is the footprint over |u_d|
    integral = GaussianKernel(1.0).footprint(rho2) / np.linalg.norm(u_d, axis=1)
    average = -np.log1p(-alpha) / K_SIGMA
    peak = integral.max()
    assert peak > 0.05 and (integral > 1e-3 * peak).sum() > 100  # the footprint covers many pixels
    err = np.abs(average * (t1 - t0) - integral).max() / peak
    assert err < 1e-4, err
    # the 2D Gaussian itself, as the splatting tests take it
    gauss2d = np.exp(-0.5 * rho2) / (2 * math.pi) / np.linalg.norm(u_d, axis=1)
    assert np.abs(average * (t1 - t0) - gauss2d).max() / peak < 1e-4


@pytest.mark.parametrize("mode", ["emission_absorption", "average", "mip"])
def test_discrete_reference_approaches_the_converged_one(mode):
    """Both references sample the same field: the discrete one's error falls with the step like d^2
    (measured mean errors per 5x smaller step fall 27x and 22x for emission-absorption, 26x and 20x for
    the average, 19x and 18x for MIP; asserted 8x)."""
    base = {"renderer.compositing": mode, "renderer.filter": "gaussian", "renderer.lut_size": 1 << 16,
            "renderer.ert_threshold": 1.0, "volume.size": 16, "image.width": 16, "image.height": 16,
            "transfer_function.preset": "grayscale"}
    converged = ConvergedReference(small_scene(base)).render_float64()
    errors = [np.abs(DiscreteReference(small_scene({**base, "renderer.sample_distance_voxels": d})).render_float64()
                     - converged).mean() for d in (0.5, 0.1, 0.02)]
    assert converged[..., 3].max() > 0.04
    assert errors[0] > 8 * errors[1] > 64 * errors[2], errors


def test_renderers_without_the_gaussian_refuse_it():
    scene = small_scene({"renderer.filter": "gaussian"})
    without = [n for n in renderers("filter", kind="grid") if "gaussian" not in registry.plugin(n).choices("filter")]
    assert without
    for name in without:
        reason = registry.refusal(scene, name)
        assert reason is not None and "gaussian" in reason and DISCRETE in reason, reason
    for name in judges():
        assert registry.refusal(scene, name) is None


def test_kernel_width_must_be_positive():
    from dvr_gl.errors import SceneError

    with pytest.raises(SceneError, match="kernel_width"):
        small_scene({"renderer.filter": "gaussian", "renderer.kernel_width": 0.0})
