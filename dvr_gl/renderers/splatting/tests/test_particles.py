"""SPH particles as a field: the cubic-spline kernel and its integrals, the interpolant, the readers, the
Plummer sphere, and splatting them (against its same-slabs reference, the converged reference, and
the flux of particles smaller than a pixel)."""

import functools
import math

import numpy as np
import pytest

from conftest import assert_close, small_scene
from dvr_gl.apps.cli import main
from dvr_gl.errors import DvrError, SceneError
from dvr_gl.fields import sph
from dvr_gl.fields.particles import ParticleSet, plummer_sphere
from dvr_gl.io import load_field
from dvr_gl.io.particles import write_npz
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.renderers import registry
from dvr_gl.renderers.splatting.footprint import M4Footprint
from dvr_gl.renderers.splatting.oracle import oracle as same_slabs
from dvr_gl.renderers.splatting.oracle import subpixel_mask
from dvr_gl.renderers.splatting.particles import SUBPIXEL_RADIUS
from dvr_gl.renderers.splatting.renderer import SplattingRenderer, m4_tables
from dvr_gl.scene.resolve import apply_overrides, parse_scene, resolve_scene
from judges import CONVERGED, DISCRETE

TF = {"transfer_function.points": [[0, 0, 0, 0, 0], [0.05, 0.15, 0.25, 0.8, 0.05], [0.5, 0.9, 0.45, 0.15, 0.3],
                                   [4, 1, 0.85, 0.4, 0.6], [16, 1, 1, 1, 0.9]]}
PLUMMER = {"volume.demo": "plummer", "volume.size": 12, "renderer.name": "splatting", "image.width": 24,
           "image.height": 24, "renderer.ert_threshold": 1.0, "renderer.shading.enabled": False, **TF}


@pytest.fixture(scope="module")
def splatting(shared_gl_context):
    r = SplattingRenderer(ctx=shared_gl_context)
    yield r
    r.close()


def scene_of(field, overrides):
    spec = parse_scene(apply_overrides({}, {"renderer.name": "splatting", **overrides}), "test")
    return resolve_scene(spec, field=field)


# --- the kernel ---------------------------------------------------------------------------------

def test_the_cubic_spline_has_unit_mass_and_its_integrals_agree():
    r = np.linspace(0.0, 2.0, 200001)
    assert np.trapezoid(4.0 * math.pi * r * r * sph.kernel(r * r, 1.0), r) == pytest.approx(1.0, abs=1e-9)
    b = np.linspace(0.0, 2.0, 20001)
    assert np.trapezoid(2.0 * math.pi * b * sph.footprint(b), b) == pytest.approx(1.0, abs=1e-8)
    z = np.linspace(-0.3, 0.7, 200001)  # a part of a chord, against the trapezoid rule
    assert sph.line_integral(np.array([0.5]), np.array([-0.3]), np.array([0.7]))[0] == pytest.approx(
        np.trapezoid(sph.w(np.sqrt(0.25 + z * z)), z), abs=1e-10)
    # the slab mass: 0 and 1 at the support, a half at the centre, and a brute-force sum between
    assert sph.slab_mass(np.array([-2.0, 0.0, 2.0])) == pytest.approx([0.0, 0.5, 1.0], abs=1e-14)
    x = np.linspace(-2, 2, 161)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    W = sph.w(np.sqrt(X * X + Y * Y + Z * Z)) / math.pi * (x[1] - x[0]) ** 3
    assert W[:, :, x < 0.5 - 1e-9].sum() + 0.5 * W[:, :, np.isclose(x, 0.5)].sum() == pytest.approx(
        float(sph.slab_mass(0.5)), abs=2e-4)  # the grid's own error


def test_the_footprint_as_three_polynomials():
    """The study benchmarks/footprint_polynomial.py (the footprint without a table): fitted again, within
    1.3e-9 of its peak at 100001 values of q (measured 1.24e-9 at 400001, the middle piece's, next to q = 1/4; the
    core's 1.2e-14 with its q^2 log q exact), continuous across the pieces' ends to that error, 0 beyond the rim."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parents[1] / "benchmarks" / "footprint_polynomial.py"
    spec = importlib.util.spec_from_file_location("footprint_polynomial", path)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    pieces = study.fit()
    assert max(study.errors(pieces, samples=100001).values()) < 1.3e-9
    ends = np.array([study.CORE_END, study.MIDDLE_END])
    near = np.concatenate([ends * (1 - 1e-12), ends * (1 + 1e-12)])
    assert np.abs(study.evaluate(near, pieces) - study.footprint(near)).max() < 1.3e-9 * sph.footprint(0.0)
    assert (study.evaluate(np.array([1.0, 1.5, 1e30]), pieces) == 0.0).all()


def test_m4_tables_are_interpolated_closely():
    """Bilinear lookups (as m4.glsl) against float64 at random points: footprint within 2e-7 of its peak
    (16384 entries), chord shares within 1e-5 (256 x 1024; measured 7e-6, near the centre, where r^3 bends within
    b of the nearest approach), the quadrant table within 2e-5 (513 x 513,
    the midpoint sums' own error measured 5e-6) and the slab mass within 1e-7."""
    t = m4_tables()
    rng = np.random.default_rng(0)
    q = rng.random(2000)
    f = q * (len(t.footprint_table) - 1)
    i = np.minimum(f.astype(int), len(t.footprint_table) - 2)
    looked = t.footprint_table[i] * (i + 1 - f) + t.footprint_table[i + 1] * (f - i)
    assert np.abs(looked - sph.footprint(2.0 * np.sqrt(q))).max() < 2e-7 * t.footprint_table[0]

    def bilinear(table, u, v):  # u: columns, v: rows, in [0, 1]
        n, m = table.shape
        fu, fv = u * (m - 1), v * (n - 1)
        i, j = np.minimum(fu.astype(int), m - 2), np.minimum(fv.astype(int), n - 2)
        a, b = fu - i, fv - j
        return ((1 - a) * (1 - b) * table[j, i] + a * (1 - b) * table[j, i + 1] + (1 - a) * b * table[j + 1, i]
                + a * b * table[j + 1, i + 1])

    q, xi = rng.random(300), rng.uniform(-1, 1, 300)
    b = 2.0 * np.sqrt(q)
    c = np.sqrt(4.0 - b * b)
    exact = sph.line_integral(b, -c, xi * c) / sph.line_integral(b)
    assert np.abs(bilinear(t.chord_table, xi * 0.5 + 0.5, q) - exact).max() < 1e-5
    x, y = rng.uniform(-1, 1, 20), rng.uniform(-1, 1, 20)
    exact = sph.box_integral(np.full(20, -2.0), 2 * x, np.full(20, -2.0), 2 * y)
    assert np.abs(bilinear(t.box_table.T, x * 0.5 + 0.5, y * 0.5 + 0.5) - exact).max() < 2e-5
    z = rng.uniform(-1, 1, 2000)
    f = (z * 0.5 + 0.5) * (len(t.slab_table) - 1)
    i = np.minimum(f.astype(int), len(t.slab_table) - 2)
    looked = t.slab_table[i] * (i + 1 - f) + t.slab_table[i + 1] * (f - i)
    assert np.abs(looked - sph.slab_mass(2.0 * z)).max() < 1e-7
    assert isinstance(t, M4Footprint) and t.box_table[-1, -1] == 1.0


# --- the field ----------------------------------------------------------------------------------

def test_the_interpolant_is_the_sum_of_kernels_and_its_gradient_is_exact():
    p = plummer_sphere(500, scale=2.0, seed=1)
    rec = p.reconstruct("m4")
    pts = np.random.default_rng(2).uniform(-6, 6, (800, 3))
    d2 = ((pts[:, None, :] - p.positions[None]) ** 2).sum(-1)
    brute = (sph.kernel(d2, p.smoothing_lengths[None]) * p.masses[None]).sum(axis=1)  # A = rho: sum m W
    assert np.abs(rec.sample(pts) - brute).max() <= 1e-12 * brute.max()
    e = 1e-5
    numeric = np.stack([(rec.sample(pts[:20] + e * np.eye(3)[a]) - rec.sample(pts[:20] - e * np.eye(3)[a])) / (2 * e)
                        for a in range(3)], axis=1)
    assert np.abs(rec.gradient(pts[:20]) - numeric).max() <= 1e-6 * np.abs(numeric).max()
    lo, hi = p.bounds
    assert (p.positions - 2 * p.smoothing_lengths[:, None] >= lo - 1e-12).all()
    assert p.value_range[0] == 0.0 and p.value_range[1] == pytest.approx(rec.sample(p.positions).max())


def test_knots_are_where_rays_enter_and_leave_each_support():
    """One particle at the origin (h = 1, support 2): rays at distance 0.5 and 1.5 enter and leave its
    support; one at 2.5 misses it."""
    p = ParticleSet([[0.0, 0.0, 0.0]], 1.0, 1.0, 1.0)
    o = np.array([[0.5, 0.0, -10.0], [1.5, 0.0, -10.0], [2.5, 0.0, -10.0]])
    d = np.tile([0.0, 0.0, 1.0], (3, 1))
    ray, t = p.reconstruct().knots(o, d, np.zeros(3), np.full(3, 20.0))
    assert np.bincount(ray, minlength=3).tolist() == [2, 2, 0]
    assert sorted(t[ray == 0]) == pytest.approx([10 - math.sqrt(3.75), 10 + math.sqrt(3.75)])
    assert sorted(t[ray == 1]) == pytest.approx([10 - math.sqrt(1.75), 10 + math.sqrt(1.75)])


@pytest.mark.parametrize("bad, message", [
    ({"smoothing_lengths": [1.0, 0.0]}, "smoothing length <= 0"),
    ({"densities": [1.0, -1.0]}, "density <= 0"),
    ({"masses": [1.0, 2.0, 3.0]}, "3 masses for 2 particles"),
    ({"positions": [[0, 0, np.nan], [1, 1, 1]]}, "NaN or Inf"),
])
def test_bad_particles_are_refused_in_one_line(bad, message):
    args = {"positions": [[0, 0, 0], [1, 1, 1]], "smoothing_lengths": [1.0, 1.0], "masses": [1.0, 1.0],
            "densities": [1.0, 1.0], **bad}
    with pytest.raises(DvrError, match=message):
        ParticleSet(**args)


def test_plummer_sphere_holds_its_mass_and_density():
    """Total mass as asked, every particle within the cut, and the SPH density at the particles near the
    exact profile times the self-contribution's bias of randomly placed particles, 1 + 1 / (pi eta^3)
    (1.184 at eta = 1.2; a uniform random cube measures 1.188): the median ratio within 5 % of it
    (measured 1.145)."""
    p = plummer_sphere(4000, scale=1.0, total_mass=2.0, seed=4)
    assert p.masses.sum() == pytest.approx(2.0)
    assert np.linalg.norm(p.positions, axis=1).max() <= 4.0 + 1e-12
    ratio = p.reconstruct().sample(p.positions) / p.densities
    assert np.median(ratio) == pytest.approx(1.0 + 1.0 / (math.pi * 1.2 ** 3), rel=0.05)


# --- readers ------------------------------------------------------------------------------------

def test_csv_and_npz_tables_read_back(tmp_path):
    p = plummer_sphere(50, seed=5)
    path = tmp_path / "p.csv"
    rows = ["X,y,z,h,mass,rho,temperature"] + [",".join(repr(float(v)) for v in (*x, hh, m, r, 3.0 * r))
                                               for x, hh, m, r in
                                               zip(p.positions, p.smoothing_lengths, p.masses, p.densities)]
    path.write_text("\n".join(rows) + "\n")
    q = load_field(path, array="temperature")
    assert q.kind == "particles" and len(q) == 50 and q.array == "temperature"
    np.testing.assert_array_equal(q.positions, p.positions)
    np.testing.assert_array_equal(q.values, 3.0 * p.densities)
    write_npz(tmp_path / "p.npz", p)
    r = load_field(tmp_path / "p.npz")
    np.testing.assert_array_equal(r.smoothing_lengths, p.smoothing_lengths)
    np.testing.assert_array_equal(r.values, p.densities)  # no array: the density


def test_missing_density_is_the_sph_sum(tmp_path):
    p = plummer_sphere(200, seed=6)
    np.savez(tmp_path / "p.npz", positions=p.positions, h=p.smoothing_lengths, m=p.masses)
    q = load_field(tmp_path / "p.npz")
    np.testing.assert_allclose(q.densities, p.reconstruct().sample(p.positions), rtol=1e-12)


@pytest.mark.parametrize("text, message", [
    ("x,y,z,h,m\n0,0,0,1,oops\n", "not a number"),
    ("x,y,z,h,m\n0,0,0,1\n", "has 4 fields"),
    ("x,y,h,m\n0,0,1,1\n", "no particle positions"),
    ("x,y,z,m\n0,0,0,1\n", "smoothing length"),
    ("x,y,z,h,m\n", "no particles"),
    ("x,y,z,h,m\n0,0,0,1,1\n\n1,0,0,-1,1\n", "column 'h' holds -1 at line 4"),
    ("x,y,z,h,m\n0,0,0,1,1\n1,0,0,1,0\n", "column 'm' holds 0 at line 3"),
    ("x,y,z,h,m,rho\n0,0,0,1,1,nan\n", "column 'rho' holds nan at line 2"),
    ("x,y,z,h,m\n0,inf,0,1,1\n", "column 'y' holds inf at line 2"),
    ("x,y,z,h,m\n1e300,0,0,1,1\n", "beyond 1e\\+18 of the origin"),
    ("x,y,z,h,m\n0,0,0,1,1\n0,0,0,1,1,\n", "line 3 has 6 fields"),
    ('x,y,z,h,m\n0,0,0,1,1\n"0",0,0,1,"x"\n', "line 3 holds a value that is not a number"),
])
def test_malformed_tables_are_refused_in_one_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DvrError, match=message):
        load_field(path)


def test_a_csv_table_with_a_byte_order_mark_and_crlf_reads(tmp_path):
    (tmp_path / "p.csv").write_bytes("\ufeffx,y,z,h,m\r\n0,0,0,1,1\r\n1,0,0,1,1\r\n".encode())
    assert len(load_field(tmp_path / "p.csv")) == 2


def test_a_large_csv_table_is_read_by_numpy(tmp_path):
    """A regular table goes through numpy's parser (the csv module took 8 s for 400k particles; checked here
    as the same particles from both paths), a quoted one through the csv module."""
    p = plummer_sphere(2000, seed=3)
    table = np.column_stack([p.positions, p.smoothing_lengths, p.masses, p.densities])
    np.savetxt(tmp_path / "p.csv", table, delimiter=",", header="x,y,z,h,m,rho", comments="", fmt="%.17g")
    quoted = (tmp_path / "p.csv").read_text().replace("\n", ',"1"\n').replace('rho,"1"', "rho,u", 1)
    (tmp_path / "q.csv").write_text(quoted)
    fast, slow = load_field(tmp_path / "p.csv"), load_field(tmp_path / "q.csv")
    np.testing.assert_array_equal(fast.positions, p.positions)
    np.testing.assert_array_equal(slow.positions, p.positions)


@pytest.mark.parametrize("columns, message", [
    ({"x": [0.0, 1.0], "y": [0.0], "z": [0.0, 1.0]}, "unequal length: 'x' has 2 values, 'y' 1"),
    ({"positions": np.zeros((2, 3)), "h": [1.0, 1.0, 1.0]}, "unequal length"),
    ({"positions": np.zeros((0, 3)), "h": np.zeros(0), "m": np.zeros(0)}, "no particles"),
    ({"positions": np.zeros((2, 2))}, r"shape \(2, 2\)"),
    ({"positions": [[0, 0, 0], [1, 1, np.nan]]}, "column 'positions' holds 1, 1, nan at row 2"),
    ({"m": [1.0, -2.0]}, "column 'm' holds -2 at row 2"),
    ({"h": [[1.0], [1.0]]}, "give one number per particle"),
    ({"X": [0.0, 1.0]}, "differ only in case"),
])
def test_npz_columns_are_checked(tmp_path, columns, message):
    base = {"x": [0.0, 1.0], "y": [0.0, 1.0], "z": [0.0, 1.0], "h": [1.0, 1.0], "m": [1.0, 1.0]}
    if "positions" in columns:
        base = {k: v for k, v in base.items() if k not in "xyz"}
    np.savez(tmp_path / "p.npz", **{**base, **columns})
    with pytest.raises(DvrError, match=message) as caught:
        load_field(tmp_path / "p.npz")
    assert "\n" not in str(caught.value)


def test_far_away_particles_are_sampled(tmp_path):
    """A particle 1e17 away: the cell index stays small (it once asked for 1.25 EiB), and the density at
    each particle is its SPH sum, its own kernel included (at the box's far edge too)."""
    positions = np.array([[0.0, 0, 0], [0.5, 0, 0], [1e17, 0, 0]])
    np.savez(tmp_path / "p.npz", positions=positions, h=[1.0, 1.0, 1.0], m=[1.0, 1.0, 1.0])
    p = load_field(tmp_path / "p.npz")
    w0, w1 = sph.kernel(0.0, 1.0), sph.kernel(0.25, 1.0)
    np.testing.assert_allclose(p.densities, [w0 + w1, w0 + w1, w0], rtol=1e-12)
    assert p.index.entries < 100


@pytest.mark.parametrize("far", [[1e17, 0.0, 0.0], [1e17, 1e17, 1e17]], ids=["one-axis", "every-axis"])
def test_the_cell_index_matches_the_brute_force_sum(far):
    """Mixed sizes (levels), a cluster and particles far away along one axis (the keys a box's index) or
    every axis (a box of 1e50 cells: the keys ranked axis by axis): the interpolant at the particles and
    at points between them is the brute-force sum."""
    p = plummer_sphere(300, seed=9)
    positions = np.r_[p.positions, [far, [-s for s in far]]]
    q = ParticleSet(positions, np.r_[p.smoothing_lengths, 0.5, 3.0], np.r_[p.masses, 1.0, 2.0],
                    np.r_[p.densities, 1.0, 1.0])
    points = np.r_[q.positions, q.positions[:50] + 0.01, [[f + 0.3 for f in far]]]
    d2 = ((points[:, None, :] - q.positions[None]) ** 2).sum(axis=2)
    brute = (sph.kernel(d2, q.smoothing_lengths[None]) * q.masses[None]).sum(axis=1)
    np.testing.assert_allclose(q.reconstruct().sample(points), brute, rtol=1e-12, atol=1e-300)
    assert q.index.levels[0].ranked == (far[1] != 0.0)


def _snapshot(path, p, swift: bool, kernel: str = "Cubic spline (M4)"):
    h5py = pytest.importorskip("h5py", reason="HDF5 snapshots are read with h5py (pip install 'dvr-gl[particles]')")
    with h5py.File(path, "w") as f:
        gas = f.create_group("PartType0")
        gas["Coordinates"] = p.positions
        gas["Masses"] = p.masses
        if swift:
            gas["SmoothingLengths"] = p.smoothing_lengths * sph.SUPPORT / sph.SWIFT_CUBIC_GAMMA
            gas["Densities"] = p.densities
            f.create_group("HydroScheme").attrs["Kernel function"] = kernel.encode()
        else:
            gas["SmoothingLength"] = p.smoothing_lengths * sph.SUPPORT  # GADGET: the support
            gas["Density"] = p.densities
        gas["InternalEnergy"] = np.arange(len(p), dtype=np.float32)


@pytest.mark.parametrize("swift", [False, True], ids=["gadget", "swift"])
def test_hdf5_snapshots_convert_smoothing_lengths(tmp_path, swift):
    """GADGET's SmoothingLength is the support (2h here); SWIFT's is Dehnen and Aly's h (support 1.825742 h)."""
    p = plummer_sphere(30, seed=7)
    _snapshot(tmp_path / "snap.hdf5", p, swift)
    q = load_field(tmp_path / "snap.hdf5", array="InternalEnergy")
    np.testing.assert_allclose(q.smoothing_lengths, p.smoothing_lengths, rtol=1e-12)
    np.testing.assert_array_equal(q.values, np.arange(30))


def test_a_swift_snapshot_of_another_kernel_is_refused(tmp_path):
    _snapshot(tmp_path / "snap.hdf5", plummer_sphere(10), True, "Wendland C2")
    with pytest.raises(DvrError, match="Wendland C2 kernel"):
        load_field(tmp_path / "snap.hdf5")


def test_cli_renders_a_particle_table_and_refuses_a_broken_one(tmp_path, capsys):
    p = plummer_sphere(300, scale=2.0, seed=8)
    write_npz(tmp_path / "p.npz", p)
    out = tmp_path / "p.png"
    assert main(["render", "--volume", str(tmp_path / "p.npz"), "-o", str(out), "--size", "32", "--no-shading"]) == 0
    assert out.exists()  # the default renderer for particles: splatting
    (tmp_path / "bad.csv").write_text("x,y,z,h,m\n0,0,0,1,1,1\n")
    bad = tmp_path / "bad.png"
    assert main(["render", "--volume", str(tmp_path / "bad.csv"), "-o", str(bad), "--size", "32"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "6 fields" in err[0] and not bad.exists()


# --- splatting particles -----------------------------------------------------------------------

CASES = [{}, {"camera.projection": "orthographic"}, {"renderer.classification": "pre"},
         {"renderer.classification": "pre", "renderer.sheet_buffer": "none"}, {"renderer.compositing": "average"},
         {"renderer.compositing": "xray"}, {"renderer.compositing": "xray", "renderer.classification": "pre"},
         {"renderer.slab_width": 0.4, "camera.elevation": 70.0}]


def smallest_support_pixels(scene) -> float:
    """The smallest support radius of the scene's particles on screen, pixels."""
    cam, img, p = scene.camera, scene.image, scene.field
    hx, hy = cam.half_extent(img.width / img.height)
    z = (p.positions - cam.eye) @ cam.basis()[0] if cam.projection == "perspective" else 1.0
    return float(np.min(2.0 * p.smoothing_lengths / (2.0 * hy * z / img.height)))


@functools.lru_cache(maxsize=1)
def blob() -> ParticleSet:
    """200 particles whose supports are all at least SUBPIXEL_RADIUS pixels wide at 52 x 52 pixels (the
    widest smoothing length about 3x the smallest), densities up to 15."""
    return plummer_sphere(200, scale=2.0, cut=2.5, eta=2.0, total_mass=600.0)


BLOB = {"image.width": 52, "image.height": 52, "renderer.ert_threshold": 1.0, "renderer.shading.enabled": False,
        **TF}


@pytest.mark.parametrize("extra", CASES, ids=lambda e: "-".join(f"{k.split('.')[-1]}={v}" for k, v in e.items())
                         or "default")
def test_particles_against_the_same_slabs_reference(splatting, extra):
    """Each particle's own kernel from the tables against float64 quadrature cut at the kernels' knots:
    measured at most 2e-6 in every mode (the float32 assertion of every GPU renderer).  Every particle's
    support spans at least SUBPIXEL_RADIUS pixels, so the pixels' own rays serve for all."""
    scene = scene_of(blob(), {**BLOB, **extra})
    assert smallest_support_pixels(scene) >= SUBPIXEL_RADIUS
    image = splatting.render(scene)
    oracle = same_slabs(scene)
    assert oracle[..., 3].max() > (0.05 if extra.get("renderer.compositing") == "average" else 0.5)
    assert_close(image, oracle)


@pytest.mark.parametrize("extra", [{}, {"renderer.classification": "pre", "renderer.sheet_buffer": "none"},
                                   {"renderer.compositing": "average", "camera.projection": "orthographic"}],
                         ids=["default", "pre-none", "average-orthographic"])
def test_mixed_sizes_against_the_same_slabs_reference(splatting, extra):
    """The Plummer demo at 24 x 24 pixels: about half its particles are smaller than SUBPIXEL_RADIUS
    pixels, which the oracle averages over pixel squares in float64 (dvr_gl.fields.sph.quadrant) as the
    renderer does from its table: measured at most 3.9e-6 (the float32 assertion)."""
    scene = small_scene({**PLUMMER, **extra})
    small = subpixel_mask(scene, scene.field.positions, scene.field.smoothing_lengths)
    assert 0.2 < small.mean() < 0.9
    assert_close(splatting.render(scene), same_slabs(scene))


def test_the_quadrant_integral_is_float64():
    # 10 corners (inside and beyond the support on both axes): box_integral's rule costs 0.2 s a corner
    rng = np.random.default_rng(9)
    x, y = rng.uniform(-2.2, 2.2, 10), rng.uniform(-2.2, 2.2, 10)
    exact = sph.box_integral(np.full(10, -2.0), x, np.full(10, -2.0), y)
    assert np.abs(sph.quadrant(x, y) - exact).max() < 2e-7  # measured 4.3e-8 (5.0e-8 at 30 corners)
    assert sph.quadrant(2.0, 2.0) == pytest.approx(1.0, abs=1e-7)  # measured 2.3e-8


# a GL renderer of grids only
GRID_ONLY = next(n for n, p in registry.plugins().items()
                 if p.needs_gl and p.data_kinds and "particles" not in p.data_kinds)


@pytest.mark.parametrize("name, extra, words", [
    ("splatting", {"renderer.sheet_buffer": "axis_aligned"}, "voxel planes"),
    ("splatting", {"renderer.filter": "gaussian"}, "renderer.filter = m4"),
    (GRID_ONLY, {}, "particles"),
])
def test_refusals_in_one_line(name, extra, words):
    scene = small_scene({**PLUMMER, "renderer.name": DISCRETE, **extra})
    reason = registry.refusal(scene, name)
    assert reason is not None and words in reason and "\n" not in reason


def test_a_grid_refuses_the_particles_kernel():
    with pytest.raises(SceneError, match="m4 is the SPH kernel of particle sets"):
        small_scene({"renderer.name": DISCRETE, "renderer.filter": "m4"}).field.reconstruct("m4")


def test_average_matches_the_converged_reference(splatting):
    """The average has no slabs: the splatted sums are the integral of the same interpolant, which the
    converged reference cuts at the knots and integrates; measured 3e-6 (asserted 2e-5: float32 sums)."""
    scene = scene_of(blob(), {**BLOB, "renderer.compositing": "average", "renderer.name": CONVERGED})
    converged = ConvergedReference(scene).render_float64()
    scene = scene_of(blob(), {**BLOB, "renderer.compositing": "average"})
    assert np.abs(splatting.render(scene) - converged).max() < 2e-5


# --- particles smaller than a pixel -------------------------------------------------------------

def tiny_particles(count, seed, h=0.01):
    rng = np.random.default_rng(seed)
    return ParticleSet(rng.uniform(-10, 10, (count, 3)), np.full(count, h), rng.uniform(0.5, 2, count),
                       rng.uniform(0.5, 2, count), np.ones(count), array="q")


XRAY_PRE = {"renderer.classification": "pre", "renderer.compositing": "xray", "image.width": 64,
            "image.height": 64, "transfer_function.points": [[0, 1, 1, 1, 0.5], [3, 1, 1, 1, 0.5]],
            "transfer_function.opacity_model": "extinction"}


def test_subpixel_particles_keep_their_flux(splatting):
    """Orthographic X-ray of 40 particles 2000 times smaller than a pixel: the optical depth summed over
    the image times a pixel's area is sigma sum(m / rho) to 1e-6 (measured 2e-8): each particle's
    pixels share its integral exactly, where pixel centres would miss them all."""
    p = tiny_particles(40, 3)
    scene = scene_of(p, {**XRAY_PRE, "camera.projection": "orthographic"})
    tau = -np.log1p(-splatting.render(scene)[..., 3].astype(np.float64))
    hx, hy = scene.camera.half_extent(1.0)
    flux = tau.sum() * (2 * hx / 64) * (2 * hy / 64)
    assert flux == pytest.approx(0.5 * p.weights.sum(), rel=1e-6)


def test_a_subpixel_particle_in_perspective_keeps_its_flux(splatting):
    """Under perspective each pixel's square at the particle's depth, over the cosine of its ray's angle:
    one particle off the axis, its pixels' optical depth times their area there times the cosine is
    sigma m / rho to 1e-5 (measured 4e-7)."""
    p = ParticleSet([[3.0, -2.0, 1.0]], 0.01, 0.0015, 0.75, 1.0, array="q")
    scene = scene_of(p, {**XRAY_PRE, "camera.projection": "perspective", "camera.target": [0, 0, 0],
                         "camera.distance": 30.0})
    tau = -np.log1p(-splatting.render(scene)[..., 3].astype(np.float64))
    cam = scene.camera
    forward = cam.basis()[0]
    offset = p.positions[0] - cam.eye
    z = offset @ forward
    hx, hy = cam.half_extent(1.0)
    area = (2 * hx * z / 64) * (2 * hy * z / 64)
    cosine = z / np.linalg.norm(offset)
    assert (tau > 0).sum() >= 1
    assert tau.sum() * area * cosine == pytest.approx(0.5 * 0.002, rel=1e-5)


def test_a_subpixel_footprint_is_its_integral_over_each_pixel(splatting):
    """One particle (support radius 1.5 pixels) whose centre sits near a pixel corner: each pixel holds
    the footprint's integral over its square (float64 quadrature), to 2e-5 of the total (the quadrant
    table's bilinear error)."""
    h = 0.75 * 0.5  # support 0.75 world units; the view is 32 world units over 64 pixels: 1.5 pixels
    p = ParticleSet([[0.1, -0.15, 0.0]], h, 1.0, 1.0, 1.0, array="q")
    scene = scene_of(p, {**XRAY_PRE, "camera.projection": "orthographic", "camera.view_height": 32.0,
                         "camera.target": [0, 0, 0]})
    tau = -np.log1p(-splatting.render(scene)[..., 3].astype(np.float64))
    cam = scene.camera
    _, right, up = cam.basis()
    cx, cy = (p.positions[0] - cam.eye) @ right, (p.positions[0] - cam.eye) @ up
    pixel = 32.0 / 64
    rows, cols = np.nonzero(tau > 0)
    x0 = (cols - 32) * pixel - cx
    y0 = (31 - rows) * pixel - cy
    exact = sph.box_integral(x0 / h, (x0 + pixel) / h, y0 / h, (y0 + pixel) / h)  # shares of the mass
    measured = tau[rows, cols] * pixel * pixel / (0.5 * 1.0)
    assert len(rows) >= 4 and exact.sum() == pytest.approx(1.0, abs=1e-6)
    assert np.abs(measured - exact).max() < 2e-5


# --- extremes ----------------------------------------------------------------------------------

EXTREMES = {
    "one particle": (ParticleSet([[0.0, 0.0, 0.0]], 1.0, 1.0, 1.0, 5.0, array="q"), {}),
    "coincident particles": (ParticleSet([[0.0, 0.0, 0.0]] * 3 + [[0.5, 0, 0]], [1.0, 0.5, 2.0, 1.0], 1.0, 1.0,
                                         [1.0, 2.0, 3.0, 4.0], array="q"), {}),
    "smoothing lengths 1e4 apart": (ParticleSet([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]], [1e-4, 2.0], 1.0, 1.0,
                                                [1e4, 1.0], array="q"), {}),
    "camera inside a support": (ParticleSet([[0.0, 0.0, 0.0], [1.0, 0.5, 0.0]], [4.0, 1.0], 1.0, 1.0, [1.0, 3.0],
                                            array="q"), {"camera.eye": [0.5, 0.2, 1.0], "camera.target": [0, 0, -5]}),
    "grazing, far off axis": (ParticleSet([[30.0, 0.0, 0.0]], 0.8, 1.0, 1.0, 2.0, array="q"),
                              {"camera.eye": [0.0, 0.0, 40.0], "camera.target": [0.0, 0.0, 0.0], "camera.fov": 80.0}),
}


@pytest.mark.parametrize("name", list(EXTREMES))
@pytest.mark.parametrize("classification", ["post", "pre"])
def test_extreme_particle_sets_against_the_same_slabs_reference(splatting, name, classification):
    """One particle; coincident ones; smoothing lengths 1e4 apart (one far below a pixel); the eye inside a
    support (the near plane cuts it: every pixel's ray starts there); a particle at the edge of an 80-degree
    view: all within the float32 assertion of the oracle (measured at most 6.3e-6, coincident kernels), finite, alpha in
    [0, 1]."""
    particles, view = EXTREMES[name]
    tf = [[0.0, 0.1, 0.3, 0.9, 0.0], [0.05, 0.9, 0.6, 0.2, 0.4], [1.0, 1.0, 1.0, 1.0, 0.9]]
    scene = scene_of(particles, {"image.width": 32, "image.height": 32, "renderer.ert_threshold": 1.0,
                                 "renderer.shading.enabled": False, "transfer_function.points": tf,
                                 "transfer_function.opacity_model": "extinction",
                                 "renderer.classification": classification, **view})
    image = splatting.render(scene)
    oracle = same_slabs(scene)
    assert np.isfinite(image).all() and image.min() >= 0 and image[..., 3].max() <= 1
    assert oracle[..., 3].max() > 0.01
    assert_close(image, oracle)


# --- HDF5 under a sandbox ----------------------------------------------------------------------------

def _escapes(tmp_path):
    """A snapshot outside the sandbox's root and, inside it, one file per way HDF5 reaches another file."""
    h5py = pytest.importorskip("h5py")
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    p = plummer_sphere(20, seed=2)
    _snapshot(outside / "secret.hdf5", p, False)
    p.positions.astype("<f8").tofile(outside / "raw.bin")
    secret = str(outside / "secret.hdf5")

    def snapshot(name, coordinates):
        with h5py.File(root / name, "w") as f:
            gas = f.create_group("PartType0")
            coordinates(f, gas)
            gas["SmoothingLength"], gas["Masses"], gas["Density"] = 2 * p.smoothing_lengths, p.masses, p.densities
        return root / name

    def virtual(f, gas):
        layout = h5py.VirtualLayout(shape=(len(p), 3), dtype="f8")
        layout[:] = h5py.VirtualSource(secret, "PartType0/Coordinates", shape=(len(p), 3))
        gas.create_virtual_dataset("Coordinates", layout)

    def soft_to_external(f, gas):
        f["elsewhere"] = h5py.ExternalLink(secret, "/PartType0")
        gas["Coordinates"] = h5py.SoftLink("/elsewhere/Coordinates")

    with h5py.File(root / "group.hdf5", "w") as f:
        f["PartType0"] = h5py.ExternalLink(secret, "/PartType0")
    return root, p, {
        "external link (group)": (root / "group.hdf5", "external link"),
        "external link (dataset)": (snapshot("dataset.hdf5", lambda f, gas: gas.__setitem__(
            "Coordinates", h5py.ExternalLink(secret, "/PartType0/Coordinates"))), "external link"),
        "soft link to an external link": (snapshot("soft.hdf5", soft_to_external), "external link"),
        "virtual dataset": (snapshot("virtual.hdf5", virtual), "virtual dataset"),
        "external storage": (snapshot("storage.hdf5", lambda f, gas: gas.create_dataset(
            "Coordinates", shape=(len(p), 3), dtype="<f8",
            external=[(str(outside / "raw.bin"), 0, len(p) * 24)])), "external raw files"),
        "soft links inside the file": (snapshot("inside.hdf5", lambda f, gas: (
            gas.__setitem__("C", p.positions), gas.__setitem__("Coordinates", h5py.SoftLink("/PartType0/C")))),
            None),
    }


def test_hdf5_links_out_of_the_sandbox_are_refused(tmp_path, capfd):
    """Every way an HDF5 file reads another (external links, also behind a soft link; virtual datasets;
    external raw storage) is refused under --sandbox in one line naming it; without a sandbox they are
    followed; soft links inside the file are followed in both."""
    from dvr_gl.sandbox import Sandbox, active

    root, p, cases = _escapes(tmp_path)
    for name, (path, words) in cases.items():
        with active(Sandbox(roots=(root,))):
            if words is None:
                np.testing.assert_array_equal(load_field(path).positions, p.positions)
                continue
            with pytest.raises(DvrError, match=words) as caught:
                load_field(path)
        assert "\n" not in str(caught.value) and "--sandbox" in str(caught.value), name
        np.testing.assert_array_equal(load_field(path).positions, p.positions)  # no sandbox: read
    assert not capfd.readouterr().err  # no HDF5-DIAG stack on stderr


def test_cli_refuses_an_hdf5_escape_under_the_sandbox(tmp_path, capsys):
    root, _, cases = _escapes(tmp_path)
    out = root / "out.png"
    assert main(["render", str(cases["virtual dataset"][0]), "--sandbox", str(root), "-o", str(out),
                 "--size", "16"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "virtual dataset" in err[0] and not out.exists()


@pytest.mark.parametrize("classification", ["post", "pre"])
def test_slabs_no_particle_reaches_are_merged(splatting, classification):
    """Two clusters far apart along the view: the slabs between them are one (the field is zero all along),
    and the image is the same-slabs reference's, whose slabs are all cut (a homogeneous stretch composites
    the same cut or whole; the transfer function is opaque at zero, so the stretch counts)."""
    from dvr_gl.renderers.splatting.sheets import occupied_slabs, slab_bounds

    a = plummer_sphere(60, scale=1.0, cut=2.0, eta=2.0, total_mass=100.0, seed=1)
    positions = np.r_[a.positions, a.positions + [0.0, 0.0, 60.0]]
    twice = ParticleSet(positions, np.tile(a.smoothing_lengths, 2), np.tile(a.masses, 2), np.tile(a.densities, 2))
    tf = [[0.0, 0.2, 0.2, 0.2, 0.02], [0.5, 0.9, 0.6, 0.2, 0.4], [1.0, 1.0, 1.0, 1.0, 0.9]]
    scene = scene_of(twice, {"image.width": 24, "image.height": 24, "renderer.ert_threshold": 1.0,
                             "renderer.shading.enabled": False, "transfer_function.points": tf,
                             "transfer_function.opacity_model": "extinction", "camera.elevation": 80.0,
                             "renderer.classification": classification})
    cam = scene.camera
    forward = cam.basis()[0]
    depth = (twice.positions - cam.eye) @ forward
    merged = occupied_slabs(scene, depth, float(2 * twice.smoothing_lengths.max()))
    assert len(merged) < len(slab_bounds(scene, np.asarray(cam.eye, float), forward)) - 20
    assert_close(splatting.render(scene), same_slabs(scene))


def test_a_particle_far_away_renders(splatting, tmp_path):
    """A particle 1e17 from the rest: a few slabs (not 1e17 of them), a finite image."""
    p = plummer_sphere(50, seed=5)
    positions = np.r_[p.positions, [[1e17, 0.0, 0.0]]]
    far = ParticleSet(positions, np.r_[p.smoothing_lengths, 1.0], np.r_[p.masses, 1.0], np.r_[p.densities, 1.0])
    scene = scene_of(far, {"image.width": 16, "image.height": 16, "renderer.shading.enabled": False})
    image = splatting.render(scene)
    assert np.isfinite(image).all() and splatting.stats["sheets"] < 1000


def test_the_converged_reference_counts_a_particle_sets_knots():
    """Its pieces a ray are at most two knots a particle (with particles 1e17 apart it counted 3e17 voxel
    planes across the box and refused)."""
    from dvr_gl import limits

    p = plummer_sphere(50, seed=5)
    far = ParticleSet(np.r_[p.positions, [[1e17, 0.0, 0.0]]], np.r_[p.smoothing_lengths, 1.0], np.r_[p.masses, 1.0],
                      np.r_[p.densities, 1.0])
    scene = scene_of(far, {"image.width": 16, "image.height": 16, "renderer.name": CONVERGED})
    assert limits.converged_pieces(scene).count <= 16 * 16 * (2 * 51 + 1) * 2
