"""Opaque meshes in the scene (``[[renderer.geometry]]``): the readers, the references against closed
forms, and what a scene without meshes keeps (each GL renderer against its oracle in its folder:
``dvr_gl/renderers/NAME/tests/test_geometry_NAME.py``).

The closed forms: a slab ``0 <= z <= 1`` of constant extinction ``S`` and colour ``C`` seen
orthographically along -z, and a square facing the eye (normal +z) of colour ``G``.  Lit by the
default headlight, the square shades to ``G (ambient + diffuse) + specular`` (n . l = n . h = 1).
Inside the slab at height ``h`` it ends the rays: the volume from z = 1 down to h, then the square,
``C (1 - e^(-S (1 - h))) + e^(-S (1 - h)) shaded``; above the slab it hides it: ``shaded``.
"""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.errors import DvrError
from dvr_gl.geometry import first_hits, read_mesh
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from judges import CONVERGED, DISCRETE, judges, renderers
from slab_scenes import (
    GREY,
    SPHERE_HEIGHTS,
    SPHERE_KEYS,
    TILTED,
    assert_square_in_or_above,
    assert_within_sphere_bounds,
    degenerate_mesh_renders_as_none,
    meshed_slab_scene,
    sphere_geometry,
    sphere_stl,
    square,
    tilted,
)

meshio = pytest.importorskip("meshio", reason="meshes are read by meshio (the mesh extra)")


@pytest.mark.parametrize("suffix", ["obj", "ply", "stl", "vtk"])
def test_mesh_formats_read_the_same_triangles(tmp_path, suffix):
    """meshio reads each format; a quadrilateral splits into two triangles (a fan), as a triangle pair."""
    quads = suffix != "stl"  # STL holds triangles only
    mesh = read_mesh(square(tmp_path / f"square.{suffix}", 0.4, quads=quads))
    assert mesh.triangles.shape == (2, 3)
    origins = np.array([[2.0, 2.0, 5.0], [2.7, 1.3, 5.0], [3.0, 2.0, 5.0]])
    t, normal, _ = first_hits([(mesh, GREY)], origins, np.tile([0.0, 0.0, -1.0], (3, 1)))
    assert np.allclose(t[:2], 4.6) and np.isinf(t[2]) and np.allclose(normal[:2], [0.0, 0.0, 1.0])


def test_first_hits_take_the_nearest_surface_and_turn_normals_to_the_eye():
    rng = np.random.default_rng(3)
    two = []
    for z in (0.2, 0.7):
        points = np.array([[-1.0, -1.0, z], [1.0, -1.0, z], [0.0, 1.0, z]])
        from dvr_gl.geometry import TriangleMesh

        two.append((TriangleMesh(points, np.array([[0, 1, 2]]), f"z={z}"), np.full(3, z)))
    origins = np.column_stack([rng.uniform(-0.3, 0.3, 50), rng.uniform(-0.3, 0.3, 50), np.full(50, 3.0)])
    down = np.tile([0.0, 0.0, -1.0], (50, 1))
    t, normal, colour = first_hits(two, origins, down)
    assert np.allclose(t, 2.3) and np.allclose(colour, 0.7) and np.allclose(normal, [0, 0, 1])
    t, normal, colour = first_hits(two, origins * [1, 1, -1], -down)  # from below: the other one, normal down
    assert np.allclose(t, 3.2) and np.allclose(colour, 0.2) and np.allclose(normal, [0, 0, -1])


def test_renderers_without_meshes_refuse_them(tmp_path):
    for name in registry.names():
        plugin = registry.plugin(name)
        if (plugin.declared("geometry") is not None
                or (plugin.data_kinds is not None and "grid" not in plugin.data_kinds)):
            continue
        filters = plugin.choices("filter")
        scene = load_scene(None, {**TILTED, "renderer.geometry": tilted(tmp_path),
                                  "renderer.filter": "linear" if "linear" in filters else filters[0],
                                  "camera.projection": plugin.projections[0],
                                  "renderer.compositing": plugin.choices("compositing")[0]})
        problem = registry.refusal(scene, name)
        assert problem is not None and "geometry" in problem and DISCRETE in problem, name


def test_bad_meshes_are_one_line(tmp_path, capsys):
    garbage = tmp_path / "garbage.obj"
    garbage.write_bytes(b"\x00\x01 not a mesh \xff" * 20)
    damaged = tmp_path / "damaged.ply"  # meshio prints and calls sys.exit on this one
    damaged.write_bytes(b"garbage\x00\x01")
    points_only = tmp_path / "points.vtk"
    meshio.write_points_cells(str(points_only), np.zeros((3, 3)), [("vertex", np.array([[0], [1], [2]]))])
    nan = tmp_path / "nan.obj"
    meshio.write_points_cells(str(nan), np.array([[0.0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]),
                              [("triangle", np.array([[0, 1, 2]]))])
    for geometry, words in (([{"path": str(tmp_path / "absent.obj")}], "mesh file (renderer.geometry) not found"),
                            ([{"path": str(tmp_path)}], "is a folder"),
                            ([{"path": str(garbage)}], "garbage.obj"),
                            ([{"path": str(damaged)}], "cannot read damaged.ply as a mesh"),
                            ([{"path": str(points_only)}], "has no triangles"),
                            ([{"path": str(nan)}], "not finite"),
                            ([{"color": [0.5, 0.5, 0.5]}], "has no path"),
                            ([{"path": str(nan), "color": [2.0, 0.0, 0.0]}], "color must be in [0, 1]")):
        with pytest.raises(DvrError) as info:  # SceneError, or the sandbox's error for the file itself
            load_scene(None, {**TILTED, "renderer.name": DISCRETE, "renderer.geometry": geometry})
        assert words in str(info.value) and "\n" not in str(info.value), words
    assert capsys.readouterr() == ("", "")  # nothing of meshio's own printing reaches the terminal


def test_mesh_paths_are_relative_to_the_scene_file(tmp_path):
    folder = tmp_path / "scenes"
    folder.mkdir()
    square(folder / "square.stl", 0.4)
    (folder / "scene.toml").write_text('[volume]\ndemo = "shepp-logan"\nsize = 8\n[renderer]\n'
                                       f'name = "{DISCRETE}"\n'
                                       '[[renderer.geometry]]\npath = "square.stl"\ncolor = [0.1, 0.2, 0.3]\n')
    scene = load_scene(folder / "scene.toml")
    assert scene.renderer.geometry[0].path == str((folder / "square.stl").resolve())
    saved = scene.to_toml(relative_to=folder)
    assert 'path = "square.stl"' in saved
    (folder / "again.toml").write_text(saved)
    assert load_scene(folder / "again.toml").renderer.geometry == scene.renderer.geometry


def test_dvr_render_takes_meshes(tmp_path, capsys):
    """--mesh FILE[:R,G,B] adds a mesh (paths relative to where dvr runs); a bad one is one line, no file."""
    from dvr_gl.apps.cli import main

    floor = square(tmp_path / "square.obj", 0.0, half=5000.0, centre=(0.0, 0.0))  # a floor under every pixel
    out = tmp_path / "out.exr"
    assert main(["render", "--demo", "--size", "24", "--mesh", f"{floor}:0.2,0.4,0.9", "-o", str(out)]) == 0
    plain = tmp_path / "plain.exr"
    assert main(["render", "--demo", "--size", "24", "-o", str(plain)]) == 0
    from dvr_gl.image import read_image

    meshed, alone = read_image(out), read_image(plain)
    # the plate, blue, covers every pixel: the corner is the plate's, not the black background
    assert meshed[0, 0, 2] > 0.3 and meshed[0, 0, 2] > meshed[0, 0, 0] and alone[0, 0, :3].max() < 1e-6
    bad = tmp_path / "bad.png"
    for flag, words in ((f"{tmp_path / 'absent.obj'}", "not found"), (f"{floor}:red", "--mesh")):
        assert main(["render", "--demo", "--size", "24", "--mesh", flag, "-o", str(bad)]) == 1
        err = capsys.readouterr().err.strip()
        assert words in err and "\n" not in err and not bad.exists()


def test_the_viewer_names_the_meshes(tmp_path):
    """A scene file's meshes render in the viewer as with dvr render (the same renderers); its status line
    counts them."""
    from dvr_gl.viewer import settings

    scene = load_scene(None, {**TILTED, "renderer.name": renderers("geometry", gl=True)[0],
                              "renderer.geometry": tilted(tmp_path)})
    assert "1 mesh |" in settings.describe(scene)
    assert "2 meshes" in settings.describe(scene.with_renderer(geometry=scene.renderer.geometry * 2))


def test_icosphere_facets_lie_within_the_stated_gap():
    from dvr_gl.geometry import icosphere

    for subdivisions in (2, 3, 4):
        points, faces = icosphere((0.0, 0.0, 0.0), 1.0, subdivisions)
        assert np.allclose(np.linalg.norm(points, axis=1), 1.0)
        centres = np.linalg.norm(points[faces].mean(axis=1), axis=1)
        assert 0.5 * 0.3 / 4 ** subdivisions < 1.0 - centres.min() < 0.3 / 4 ** subdivisions


# --- issue 40: the host test's plan, degenerate meshes, memory and work bounds ------------------------

def _brute(corners, o, d):
    """Every ray against every triangle (the pre-issue-40 test), the nearest hit parameter per ray."""
    a, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    p = np.cross(d[:, None, :], e2[None])
    det = np.einsum("tk,rtk->rt", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = o[:, None, :] - a[None]
        u = np.einsum("rtk,rtk->rt", s, p) / det
        q = np.cross(s, e1[None])
        v = np.einsum("rk,rtk->rt", d, q) / det
        t = np.einsum("tk,rtk->rt", e2, q) / det
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(hit, t, np.inf).min(axis=1)


@pytest.mark.parametrize("rays", ["perspective", "orthographic", "scattered", "eye among the triangles"])
def test_the_hit_plan_finds_what_testing_every_pair_finds(rays):
    """The plan (rays binned in 2D, each triangle tested against the cells its box covers) misses no hit
    of the brute-force test, rays through vertices and along edges included, and tests fewer pairs."""
    from dvr_gl.geometry import HitPlan, TriangleMesh

    rng = np.random.default_rng(11)
    points = rng.uniform(-1, 1, (300, 3))
    triangles = rng.integers(0, 300, (400, 3))
    small = points[triangles[:200]]
    points[triangles[:200, 1]] = small[:, 0] + 0.05 * (small[:, 1] - small[:, 0])  # small ones too
    n = 24
    ys, xs = np.meshgrid(np.linspace(-0.6, 0.6, n), np.linspace(-0.6, 0.6, n), indexing="ij")
    if rays == "orthographic":
        o = np.column_stack([xs.ravel(), ys.ravel(), np.full(n * n, 3.0)])
        d = np.tile([0.0, 0.0, -1.0], (n * n, 1))
    else:
        eye = [0.0, 0.0, 0.0] if rays == "eye among the triangles" else [0.1, -0.2, 3.0]
        o = np.tile(eye, (n * n, 1))
        d = np.column_stack([xs.ravel(), ys.ravel(), -np.ones(n * n)])
        if rays == "scattered":
            o = o + rng.normal(0, 0.01, o.shape)
    mesh = TriangleMesh(points, triangles, "random")
    corner_rays = points[triangles[:40, 0]] - o[:40]  # 40 rays straight through a vertex each
    d[:40] = corner_rays if rays != "orthographic" else d[:40]
    if rays == "orthographic":
        o[:40] = points[triangles[:40, 0]] + [0.0, 0.0, 3.0]
    t, _, _ = first_hits([(mesh, GREY)], o, d)
    expected = _brute(mesh.corners, o, d)
    np.testing.assert_array_equal(np.isfinite(t), np.isfinite(expected))
    np.testing.assert_allclose(t[np.isfinite(t)], expected[np.isfinite(t)], rtol=1e-12)
    plan = HitPlan(o, d, mesh.corners)
    assert plan.pairs <= len(o) * len(triangles)
    if rays in ("perspective", "orthographic"):
        assert plan.pairs < 0.5 * len(o) * len(triangles)


def test_the_host_test_is_bounded_and_fast(tmp_path, monkeypatch):
    """Issue 40: a 327k-triangle STL ran over 60 s in shearwarp and reference (every ray against every
    triangle).  The plan tests a few pairs a ray; its count is checked against the bound (lowered by
    --max-seconds) before any test, and the refusal names the count and what to change."""
    import dvr_gl.geometry as geometry
    from dvr_gl import limits
    from dvr_gl.sandbox import Sandbox, active

    path = sphere_stl(tmp_path, 5)  # 20480 triangles
    scene = load_scene(None, {**TILTED, "image.width": 64, "image.height": 64, "renderer.name": DISCRETE,
                              "renderer.geometry": [{"path": str(path), "color": [0.3, 0.5, 0.9]}]})
    rays = scene.camera.pixel_rays(64, 64)
    plan = geometry.HitPlan(*rays, read_mesh(path).corners)
    assert plan.pairs < 50 * len(rays[0])  # about 21 a ray; brute force: 20480 a ray
    monkeypatch.setitem(limits.BOUNDS, geometry.SURFACE_WORK, plan.pairs / 2)
    with pytest.raises(DvrError, match=r"the surfaces would take .* ray-triangle tests \(4096 rays against the 20480 "
                                       r"triangles .*over the bound.*lower --size"):
        geometry.first_hits([(read_mesh(path), GREY)], *rays)
    monkeypatch.setitem(limits.BOUNDS, geometry.SURFACE_WORK, 3e10)
    monkeypatch.setitem(limits.RATES, geometry.SURFACE_WORK, plan.pairs / 20)  # --max-seconds 10: half the tests
    with active(Sandbox(max_seconds=10)), pytest.raises(DvrError, match="over the bound of"):
        geometry.first_hits([(read_mesh(path), GREY)], *rays)


@pytest.mark.parametrize("case, text, words", [
    ("header cut", b"ply\nformat ascii 1.0\n", "no 'end_header' line"),
    ("comment end", b"ply\nformat ascii 1.0\ncomment end_header\n", "no 'end_header' line"),
    ("face count", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                   b"element face 99999999999\nend_header\n0 0 0\n1 0 0\n0 1 0\n", "'element face 9+' does not"),
])
def test_ply_headers_that_hung_meshio_are_refused_at_once(tmp_path, case, text, words):
    """Issue 40's campaign, again: meshio reads a PLY header line by line until 'end_header', forever at the
    end of a file cut short, and loops over every face an 'element face' line counts."""
    import time

    path = tmp_path / "bad.ply"
    path.write_bytes(text)
    start = time.perf_counter()
    with pytest.raises(DvrError, match=words) as info:
        read_mesh(path)
    assert time.perf_counter() - start < 5 and "\n" not in str(info.value)


def test_vtk_surfaces_are_read_strictly_polydata_included(tmp_path):
    """.vtk and .vtu surfaces go through the strict VTK readers: POLYDATA (which meshio does not read,
    though the docs named it) with polygons and a triangle strip, and damaged offsets refused."""
    import mesh_inputs as mi

    poly = tmp_path / "poly.vtk"
    poly.write_text("# vtk DataFile Version 3.0\np\nASCII\nDATASET POLYDATA\nPOINTS 5 float\n"
                    "0 0 0 1 0 0 1 1 0 0 1 0 2 0 0\nPOLYGONS 1 5\n4 0 1 2 3\nTRIANGLE_STRIPS 1 4\n3 1 4 2\n")
    mesh = read_mesh(poly)
    assert sorted(map(tuple, mesh.triangles.tolist())) == [(0, 1, 2), (0, 2, 3), (1, 4, 2)]
    damaged = tmp_path / "surface.vtu"
    tri = [(5, [0, 1, 2]), (9, [0, 1, 2, 3])]
    damaged.write_bytes(mi.vtu(cells=tri, offsets=[0, 0], cell_values=[1.0, 2.0]))
    with pytest.raises(DvrError, match="offsets run from 0 to 0"):
        read_mesh(damaged)
    good = tmp_path / "surface2.vtu"
    good.write_bytes(mi.vtu("zlib", cells=tri, cell_values=[1.0, 2.0]))
    assert read_mesh(good).triangles.tolist() == [[0, 1, 2], [0, 1, 2], [0, 2, 3]]


def test_obj_relative_indices_and_far_points(tmp_path):
    """OBJ's negative indices count back from the last vertex (meshio made them 'missing points', a
    valid file refused); points beyond the world range (1e18) are refused, as the volume's are: the
    float64 test's products overflow there."""
    rel = tmp_path / "rel.obj"
    rel.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 0\nf 2/1/1 -1//2 3\n")
    assert read_mesh(rel).triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    for text, words in (("v 1e300 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n", r"1e\+300 world units from the origin"),
                        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4: 'f 1 2 0' is not a vertex or face"),
                        ("v 0 0\nf 1 1 1\n", "line 1: 'v 0 0' is not a vertex")):
        bad = tmp_path / "bad.obj"
        bad.write_text(text)
        geometry_cache_clear()
        with pytest.raises(DvrError, match=words):
            read_mesh(bad)


def geometry_cache_clear():
    from dvr_gl import geometry

    geometry._read.cache_clear()




@pytest.mark.parametrize("height", [0.4, 1.5], ids=["inside", "above"])
@pytest.mark.parametrize("name", judges())
def test_square_in_and_above_a_slab(tmp_path, name, height):
    """The references to rounding (a constant medium's segments are exact); each GL renderer's own in
    its folder (``test_geometry_NAME.py``)."""
    scene = meshed_slab_scene(tmp_path, name, [{"path": square(tmp_path / "square.obj", height), "color": list(GREY)}])
    image = (ConvergedReference(scene) if name == CONVERGED else DiscreteReference(scene)).render_float64()
    assert_square_in_or_above(image, scene, height, 1e-9)


@pytest.mark.parametrize("height", list(SPHERE_HEIGHTS.values()), ids=list(SPHERE_HEIGHTS))
@pytest.mark.parametrize("name", judges())
def test_sphere_in_front_of_and_inside_a_slab(tmp_path, name, height):
    """The references to rounding (:func:`slab_scenes.assert_within_sphere_bounds`)."""
    scene = meshed_slab_scene(tmp_path, name, sphere_geometry(tmp_path, height), **SPHERE_KEYS)
    reference = ConvergedReference(scene) if name == CONVERGED else DiscreteReference(scene)
    assert_within_sphere_bounds(reference.render_float64(), scene, height, 1e-9)


def test_a_mesh_of_only_degenerate_triangles_renders_as_none(tmp_path):
    degenerate_mesh_renders_as_none(None, tmp_path, DISCRETE)
