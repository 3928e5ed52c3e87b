"""Particles' X-ray deposited on the host (:mod:`dvr_gl.renderers.splatting.column`), both projections: against the
GL path and the same-slabs reference, the compiled loops against numpy, the flux of particles smaller than a
pixel, extreme particle sets, and the peers' bench without a peer."""

import numpy as np
import pytest

from dvr_gl.fields import sph
from dvr_gl.fields.particles import ParticleSet, plummer_sphere
from dvr_gl.renderers.splatting import column
from dvr_gl.renderers.splatting.bench import peers
from dvr_gl.renderers.splatting.oracle import oracle as same_slabs
from dvr_gl.renderers.splatting.particles import ParticleSplats
from dvr_gl.renderers.splatting.renderer import SplattingRenderer, m4_tables
from dvr_gl.scene.resolve import apply_overrides, parse_scene, resolve_scene

XRAY = {"renderer.name": "splatting", "renderer.classification": "pre", "renderer.compositing": "xray",
        "renderer.shading.enabled": False, "camera.projection": "orthographic", "camera.target": [0.2, -0.1, 0.0],
        "camera.eye": [0.2, -0.1, 40.0], "camera.up": [0, 1, 0], "camera.view_height": 6.0,
        "image.width": 32, "image.height": 24, "transfer_function.opacity_model": "extinction",
        "transfer_function.points": [[0, 1, 0.5, 1, 0.05], [20, 0.2, 1, 1, 1]]}


@pytest.fixture(scope="module")
def splatting(shared_gl_context):
    r = SplattingRenderer(ctx=shared_gl_context)
    yield r
    r.close()


def scene_of(field, **extra):
    return resolve_scene(parse_scene(apply_overrides({}, {**XRAY, **extra}), "test"), field=field)


def both(splatting, scene, host_draws=True):
    """The host's image and the GL path's (``host_draws``: whether the host drew the first)."""
    pytest.importorskip("numba")
    host = splatting.render(scene)
    assert bool(splatting.stats.get("host")) == host_draws
    splatting.host_columns = False
    try:
        gl = splatting.render(scene)
        assert not splatting.stats.get("host")
    finally:
        splatting.host_columns = True
    return host, gl


PERSPECTIVE = {"camera.projection": "perspective", "camera.fov": 30.0}


@pytest.mark.parametrize("projection, height", [("orthographic", 6.0), ("orthographic", 60.0),
                                                ("perspective", 12.0), ("perspective", 120.0)])
def test_the_host_column_is_the_gl_paths_and_the_oracles(splatting, projection, height):
    """200 Plummer particles, their supports 1.5 to 40 pixels (6 world units high; perspective: the eye 12
    units away) or every one under 2 pixels (60; 120 away: averaged over pixel squares); colours differ (four
    channels): the host and the GL path within 1e-6 of each other (measured 1.8e-7 and 1.2e-7 orthographic,
    1.5e-7 and 2.1e-7 perspective: GL's float32) and of the float64 same-slabs reference, 2e-6 where every
    particle is under a pixel: there the host and GL are off the reference by the same 8.9e-7 (orthographic)
    and 1.09e-6 (perspective) in the same pixel, the quadrant table's and the reference's sub-pixel
    quadrature's difference (elsewhere 2e-8 for the host, 1.7e-7 for GL)."""
    extra = ({"camera.view_height": height} if projection == "orthographic"
             else {**PERSPECTIVE, "camera.eye": [0.2, -0.1, height]})
    scene = scene_of(plummer_sphere(200, seed=4), **extra)
    host, gl = both(splatting, scene)
    truth = same_slabs(scene)
    assert np.abs(host - gl).max() < 1e-6
    assert np.abs(host - truth).max() < (2e-6 if height > 50 else 1e-6)
    assert host[..., 3].max() > 0.05


@pytest.mark.parametrize("perspective", [False, True], ids=["orthographic", "perspective"])
def test_the_compiled_deposit_is_numpys(perspective):
    """Random particles inside, across and outside the image, smaller than a pixel and wider than it, one and
    three channels, both projections (perspective: centres 2 to 60 supports in front of the eye, up to 40
    degrees off the axis): numba's sums equal numpy's to rounding (1e-12)."""
    pytest.importorskip("numba")
    rng = np.random.default_rng(2)
    n = 60
    cx, cy = rng.uniform(-20, 60, n), rng.uniform(-20, 50, n)
    radius = np.exp(rng.uniform(np.log(0.01), np.log(80), n))
    radius[:3] = (1e-12, 1e9, 1.9)
    cx[:3] = (3.2, 1e12, 0.05)  # the huge one's centre far beyond the image
    subpixel = radius < 2.0
    rays, half = np.empty((n, 0)), np.array([0.4, 0.3])
    if perspective:
        support = rng.uniform(0.1, 1.0, n)
        depth = support * np.exp(rng.uniform(np.log(1.05), np.log(60), n))
        rays = np.stack([rng.uniform(-0.7, 0.7, n) * depth, rng.uniform(-0.5, 0.5, n) * depth, depth, support], 1)
    t = m4_tables()
    compiled = column.compiled()
    for channels in (1, 3):
        weights = rng.uniform(0.1, 2.0, (n, channels))
        args = (cx, cy, radius, weights, subpixel, rays, half, t.footprint_table, t.box_table, 30, 40)
        expected = column.deposit_numpy(*args)
        assert expected.max() > 0.1
        for got in (compiled.deposit_serial(*args), compiled.deposit(*args, 2)):
            assert np.abs(got - expected).max() <= 1e-12 * np.abs(expected).max()


def test_subpixel_particles_keep_their_mass_on_the_host(splatting):
    """30 particles 1e-4 of a pixel wide, inside the view: the optical depth summed over the image times a
    pixel's area is sigma sum(m / rho) to 1e-6 (the box table telescopes; float32 output)."""
    pytest.importorskip("numba")
    rng = np.random.default_rng(5)
    p = ParticleSet(rng.uniform(-2.5, 2.5, (30, 3)), 1e-5, rng.uniform(0.5, 2, 30), rng.uniform(0.5, 2, 30),
                    np.ones(30), array="q")
    scene = scene_of(p, **{"transfer_function.points": [[0, 1, 1, 1, 0.005], [3, 1, 1, 1, 0.005]]})
    tau = -np.log1p(-splatting.render(scene)[..., 3].astype(np.float64))
    assert splatting.stats.get("host")
    pixel = 6.0 / 24
    assert tau.sum() * pixel * pixel == pytest.approx(0.005 * p.weights.sum(), rel=1e-6)


FAR = {"camera.eye": [0.2, -0.1, 2000.0]}
EXTREMES = {
    "one particle": ([[0.3, 0.2, 0.0]], 0.4, {}, True),
    "outside the view": ([[0.0, 0.0, 0.0], [40.0, 0.0, 0.0]], 0.3, {}, True),
    "a huge support": ([[0.0, 0.0, 0.0], [0.5, 0.5, 1.0]], [0.3, 300.0], FAR, True),
    "a tiny support": ([[0.0, 0.0, 0.0], [0.51, 0.5, 1.0]], [0.3, 1e-9], {}, True),
    "a support through the eye's plane": ([[0.0, 0.0, 0.0], [0.5, 0.5, 1.0]], [0.3, 300.0], {}, False),
}


@pytest.mark.parametrize("name", EXTREMES)
def test_extreme_particles_on_the_host(splatting, name):
    """One particle; one far outside the view; a support a thousand times the view's; one 1e-8 of a pixel: the
    host equals the GL path and the same-slabs reference within 1e-6.  A support that reaches the eye's plane
    is left to the GL path (which clips the rays there; the reference errs beside it as beside the huge one)."""
    positions, h, extra, host_draws = EXTREMES[name]
    n = len(positions)
    p = ParticleSet(positions, h, np.full(n, 0.4), np.full(n, 0.8), np.linspace(1.0, 15.0, n), array="q")
    scene = scene_of(p, **extra)
    host, gl = both(splatting, scene, host_draws)
    assert np.abs(host - gl).max() < 1e-6
    # the same-slabs reference errs by 3.8e-4 beside the support of 600 (its slab quadrature; the host and
    # GL agree with the float64 footprint at pixel centres to 1e-7): there that closed form judges
    if host_draws:
        truth = point_sampled_alpha(scene, p) if extra is FAR else same_slabs(scene)[..., 3]
        assert np.abs(host[..., 3] - truth).max() < 1e-6


def point_sampled_alpha(scene, p) -> np.ndarray:
    """The X-ray's opacity at the pixel centres from the float64 footprint (supports above a pixel)."""
    cam, img = scene.camera, scene.image
    hx, hy = cam.half_extent(img.width / img.height)
    x = cam.target[0] - hx + (np.arange(img.width) + 0.5) * 2 * hx / img.width
    y = cam.target[1] + hy - (np.arange(img.height) + 0.5) * 2 * hy / img.height
    sigma = scene.transfer_function.evaluate(p.values)[1]
    tau = sum(w * s * sph.footprint(np.hypot(x[None, :] - c[0], y[:, None] - c[1]) / h) / h ** 2
              for w, s, c, h in zip(p.weights, sigma, p.positions, p.smoothing_lengths))
    return -np.expm1(-tau)


def test_without_numba_the_gl_path_draws(splatting, monkeypatch):
    monkeypatch.setattr(column, "compiled", lambda: None)
    splatting.render(scene_of(plummer_sphere(50)))
    assert not splatting.stats.get("host")


def test_the_peers_bench_without_a_peer():
    """dvr-gl alone (no peers' interpreter): its column within 1e-6 of the exact one over the peak (float32
    alpha read back; measured 3e-9 at 512x512)."""
    (row,) = peers.run([300], 48, 1, None, progress=None)
    assert row["subpixel"] == 0  # every support above 2 pixels: both conventions sample pixel centres
    assert row["dvrgl_error"] < 1e-6 and "sarracen_ms" not in row


@pytest.mark.parametrize("one", [True, False], ids=["one-colour", "colours"])
def test_the_radiograph_is_xray_rgba_to_the_last_bit(one):
    """The host's image, a channel at a time into float32, holds xray_rgba's numbers (float64, cast) exactly,
    empty pixels (zero optical depth) included, rows flipped to the top."""
    from dvr_gl.transfer_function import xray_rgba

    rng = np.random.default_rng(4)
    sums = rng.random((1 if one else 4, 7, 5)) * 3.0
    sums[:, :2] = 0.0
    colour = np.array([0.3, 0.7, 0.11])
    tau = sums[-1][::-1].reshape(-1)
    emitted = tau[:, None] * colour if one else np.moveaxis(sums[:3], 0, -1)[::-1].reshape(-1, 3)
    expected = xray_rgba(emitted, tau).reshape(7, 5, 4).astype(np.float32)
    assert np.array_equal(column.radiograph(sums, colour if one else None), expected)


def test_a_kept_view_serves_only_its_own_view(splatting):
    """The host keeps the last view's projection on the splats: frames of views A, B, A and B again with it
    dropped are each the view's own (bit for bit), and B's differs from A's."""
    pytest.importorskip("numba")
    field = plummer_sphere(200, seed=4)
    a, b = scene_of(field, **PERSPECTIVE), scene_of(field, **PERSPECTIVE, **{"camera.eye": [0.5, -0.1, 39.0]})
    first, other, again = splatting.render(a), splatting.render(b), splatting.render(a)
    assert splatting.stats.get("host") and np.array_equal(first, again) and not np.array_equal(first, other)
    peers.forget_views(splatting)
    assert np.array_equal(splatting.render(b), other)


def test_the_numpy_deposit_draws_the_hosts_perspective_frame(splatting):
    """The numpy loops (:func:`column.deposit_numpy`, the reference of the compiled ones) through the whole
    perspective frame: the compiled frame's image to float32 rounding (the sums agree to 1e-12); and a
    support reaching the eye's plane leaves the frame to GL (None from the host)."""
    pytest.importorskip("numba")
    scene = scene_of(plummer_sphere(60, seed=1), **PERSPECTIVE, **{"camera.eye": [0.2, -0.1, 12.0]})
    compiled = splatting.render(scene)
    assert splatting.stats.get("host")
    field, cam = scene.field, scene.camera
    centre = 0.5 * (np.asarray(field.bounds[0]) + np.asarray(field.bounds[1]))
    splats = ParticleSplats(field, centre, scene.transfer_function.classify_voxels(field.samples, True))
    eye = np.asarray(cam.eye, float) - centre
    image = column.host_xray(scene, splats, eye, cam.basis(), m4_tables(), use_numpy=True)
    assert np.abs(image - compiled).max() <= 1e-7 and image[..., 3].max() > 0.05
    near = scene_of(plummer_sphere(60, seed=1), **PERSPECTIVE, **{"camera.eye": [0.2, -0.1, 1.0]})
    assert column.host_xray(near, splats, np.asarray(near.camera.eye, float) - centre, near.camera.basis(),
                            m4_tables(), use_numpy=True) is None
