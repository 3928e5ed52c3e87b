"""Opaque meshes in the scene (``[[renderer.geometry]]``): the readers, the references against closed
forms, the ray caster against its reference, and what a scene without meshes keeps.

The closed forms: a slab ``0 <= z <= 1`` of constant extinction ``S`` and colour ``C`` seen
orthographically along -z, and a square facing the eye (normal +z) of colour ``G``.  Lit by the
default headlight, the square shades to ``G (ambient + diffuse) + specular`` (n . l = n . h = 1).
Inside the slab at height ``h`` it ends the rays: the volume from z = 1 down to h, then the square,
``C (1 - e^(-S (1 - h))) + e^(-S (1 - h)) shaded``; above the slab it hides it: ``shaded``.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import array_scene, assert_close
from dvr_gl.errors import DvrError
from dvr_gl.geometry import first_hits, read_mesh
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene

meshio = pytest.importorskip("meshio", reason="meshes are read by meshio (the mesh extra)")

COLOUR = np.array([0.9, 0.6, 0.3])
GREY = np.array([0.2, 0.7, 0.4])
SIGMA = 1.3


def _square(path, z, half=0.75, centre=(2.0, 2.0), quads=False):
    """A square at height z facing +z, as two triangles (or one quadrilateral)."""
    cx, cy = centre
    points = np.array([[cx - half, cy - half, z], [cx + half, cy - half, z], [cx + half, cy + half, z],
                       [cx - half, cy + half, z]])
    cells = [("quad", np.array([[0, 1, 2, 3]]))] if quads else [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))]
    meshio.write_points_cells(str(path), points, cells)
    return str(path)


def _slab_scene(tmp_path, renderer, geometry, **extra):
    data = np.full((3, 9, 9), 0.5, np.float32)
    overrides = {"renderer.name": renderer, "transfer_function.points": [[0.0, *COLOUR, SIGMA], [1.0, *COLOUR, SIGMA]],
                 "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 10,
                 "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
                 "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.0, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-7, "renderer.geometry": geometry, **extra}
    return array_scene(tmp_path, data, overrides, spacing=(0.5, 0.5, 0.5))


def _expected(scene, height):
    """The closed form per pixel: inside the square (|x - 2|, |y - 2| < 0.75) as in the module doc."""
    sh = scene.renderer.shading
    shaded = GREY * (sh.ambient + sh.diffuse) + sh.specular
    origins, _ = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    inside = (np.abs(origins[:, 0] - 2.0) < 0.75) & (np.abs(origins[:, 1] - 2.0) < 0.75)
    depth = np.where(inside, 1.0 - min(height, 1.0), 1.0)
    alpha = -np.expm1(-SIGMA * depth)
    rgba = np.concatenate([COLOUR * alpha[:, None], alpha[:, None]], axis=1)
    surface = np.where(inside[:, None], np.append(shaded, 1.0), 0.0)
    return (rgba + (1.0 - alpha[:, None]) * surface).reshape(scene.image.height, scene.image.width, 4)


@pytest.mark.parametrize("height", [0.4, 1.5], ids=["inside", "above"])
@pytest.mark.parametrize("name", ["reference", "reference-converged", "raycast"])
def test_square_in_and_above_a_slab(tmp_path, gl_context, name, height):
    """The references to rounding (a constant medium's segments are exact); the ray caster to float32
    (measured 1.9e-7)."""
    scene = _slab_scene(tmp_path, name, [{"path": _square(tmp_path / "square.obj", height), "color": list(GREY)}])
    if name == "raycast":
        with registry.plugin(name).create(ctx=gl_context) as renderer:
            image = renderer.render(scene)
            assert renderer.stats["defines"]["GEOMETRY"]
        tolerance = 2e-6
    else:
        image = (ConvergedReference(scene) if name == "reference-converged"
                 else DiscreteReference(scene)).render_float64()
        tolerance = 1e-9
    expected = _expected(scene, height)
    assert np.abs(image - expected).max() < tolerance


@pytest.mark.parametrize("suffix", ["obj", "ply", "stl", "vtk"])
def test_mesh_formats_read_the_same_triangles(tmp_path, suffix):
    """meshio reads each format; a quadrilateral splits into two triangles (a fan), as a triangle pair."""
    quads = suffix != "stl"  # STL holds triangles only
    mesh = read_mesh(_square(tmp_path / f"square.{suffix}", 0.4, quads=quads))
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


TILTED = {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20, "image.height": 16,
          "renderer.ert_threshold": 1.0}


def _tilted(tmp_path):
    """A tilted square through the middle of the centred 16^3 phantom, and a small one in front of it."""
    points = np.array([[-9.0, -9.0, -4.0], [9.0, -9.0, 2.0], [9.0, 9.0, 4.0], [-9.0, 9.0, -2.0],
                       [-2.0, -2.0, 12.0], [3.0, -2.0, 12.0], [3.0, 3.0, 12.0]])
    path = tmp_path / "tilted.ply"
    meshio.write_points_cells(str(path), points, [("triangle", np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]], np.int32))])
    return [{"path": str(path), "color": [0.3, 0.5, 0.9]}]


@pytest.mark.parametrize("extra", [
    {}, {"camera.projection": "orthographic"}, {"renderer.compositing": "mip"},
    {"renderer.compositing": "isosurface"}, {"renderer.compositing": "average"},
    {"renderer.classification": "preintegrated"}, {"renderer.shading.enabled": True},
    {"renderer.acceleration": "on"}, {"renderer.texture_budget_mb": 0.004}, {"renderer.ert_threshold": 0.95},
    {"renderer.clipping": {"planes": [[1.0, 0.4, -0.3, 1.0]]}},
    {"camera.eye": [0.0, -2.0, 0.5], "camera.target": [0.0, 8.0, 0.5]},  # the eye inside, the meshes around it
    {"camera.near": 20.0},  # the near plane cuts the meshes away with the volume
], ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(v, (list, dict)) else k.split('.')[-1]
                         for k, v in e.items()) or "default")
def test_raycast_ends_rays_at_the_meshes_as_its_reference(tmp_path, gl_context, extra):
    """The ray caster against the reference with the same meshes: GL rasterizes them (the depth test
    keeps the nearest; pixel centres decide coverage, as the reference's rays do) and ends each ray
    at the layer's distance; to the conftest's bound (measured at most 5.1e-7 in every case here, no
    value off by more than 1e-4: no edge pixel fell the other way)."""
    scene = load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": _tilted(tmp_path), **extra})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    reference = DiscreteReference(scene).render_float64()
    plain = DiscreteReference(scene.with_renderer(geometry=[])).render_float64()
    assert np.abs(reference - plain).max() > 0.2  # the meshes show
    assert_close(image, reference)


@pytest.mark.parametrize("name", ["slicing3d", "slicing2d"])
@pytest.mark.parametrize("extra", [{}, {"camera.projection": "orthographic"}, {"renderer.shading.enabled": True},
                                   {"renderer.classification": "preintegrated"}],
                         ids=["default", "orthographic", "shaded", "preintegrated"])
def test_slicers_discard_fragments_behind_the_meshes_as_their_planes(tmp_path, gl_context, name, extra):
    """A slice's fragment behind the layer's surface is discarded, as the reference of the same planes
    drops the planes a ray crosses past its surface (measured at most 5.3e-7, no value off by more than
    1e-4)."""
    from dvr_gl.renderers.grid.slicing import same_planes_2d, same_planes_3d

    scene = load_scene(None, {**TILTED, "renderer.name": name, "renderer.geometry": _tilted(tmp_path), **extra})
    with registry.plugin(name).create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["GEOMETRY"]
    assert_close(image, (same_planes_3d if name == "slicing3d" else same_planes_2d)(scene))


@pytest.mark.parametrize("extra", [{}, {"camera.projection": "orthographic"}, {"renderer.shading.enabled": True},
                                   {"renderer.classification": "pre"}],
                         ids=["default", "orthographic", "shaded", "pre"])
def test_shear_warp_drops_samples_behind_the_meshes_as_its_reference(tmp_path, gl_context, extra):
    """Shear-warp finds each intermediate pixel's surface on the host (the references' float64 test),
    drops the samples behind it and composites the intermediate image over it before the warp; its
    same-slices reference does the same along the same rays: the intermediate image to rounding
    (measured 9e-16; pre-classified 2.5e-9, float32 payload), the frame within the warp's float32
    (measured 2.5e-6).  The image's one-pixel border stays transparent, meshes included: with it
    opaque, GL's clamped taps past the edge and the reference's zeros differed by 0.16 on an edge pixel."""
    from dvr_gl.renderers.shearwarp.factorization import factorize
    from dvr_gl.renderers.shearwarp.renderer import composite, intermediate_reference, reference
    from dvr_gl.renderers.shearwarp.shading import frame_table

    scene = load_scene(None, {**TILTED, "renderer.name": "shearwarp", "renderer.geometry": _tilted(tmp_path), **extra})
    with registry.plugin("shearwarp").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        fact = factorize(scene.camera, scene.volume, scene.image.width, scene.image.height)
        rle = renderer.encoding(scene, fact.axis)
        intermediate, _ = composite(fact, rle, scene, frame_table(scene) if rle.codes is not None else None)
    expected = intermediate_reference(scene)
    tolerance = 5e-8 if scene.renderer.classification == "pre" else 1e-12
    assert np.abs(intermediate - expected).max() <= tolerance
    assert_close(image, reference(scene))


def test_half_angle_slicing_with_a_mesh(tmp_path, gl_context):
    """Scattering's half-angle slicing takes the meshes too (they end the view's samples; the lights'
    rays do not see them: meshes cast no shadows)."""
    from dvr_gl.renderers.grid.slicing import same_planes_3d

    scene = load_scene(None, {**TILTED, "renderer.name": "slicing3d", "renderer.geometry": _tilted(tmp_path),
                              "renderer.scattering": {"enabled": True, "method": "half_angle",
                                                      "light_buffer_size": 32}})
    with registry.plugin("slicing3d").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_close(image, same_planes_3d(scene))


def test_a_scene_without_meshes_compiles_none_and_is_unchanged(gl_context):
    scene = load_scene(None, {**TILTED, "renderer.name": "raycast"})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        a = renderer.render(scene)
        assert "GEOMETRY" not in renderer.stats["defines"]
        b = renderer.render(scene.with_renderer(geometry=[]))
    assert np.array_equal(a, b)


def test_renderers_without_meshes_refuse_them(tmp_path):
    for name in registry.names():
        plugin = registry.plugin(name)
        if (plugin.declared("geometry") is not None
                or (plugin.data_kinds is not None and "grid" not in plugin.data_kinds)):
            continue
        filters = plugin.choices("filter")
        scene = load_scene(None, {**TILTED, "renderer.geometry": _tilted(tmp_path),
                                  "renderer.filter": "linear" if "linear" in filters else filters[0],
                                  "camera.projection": plugin.projections[0],
                                  "renderer.compositing": plugin.choices("compositing")[0]})
        problem = registry.refusal(scene, name)
        assert problem is not None and "geometry" in problem and "reference" in problem, name


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
            load_scene(None, {**TILTED, "renderer.name": "reference", "renderer.geometry": geometry})
        assert words in str(info.value) and "\n" not in str(info.value), words
    assert capsys.readouterr() == ("", "")  # nothing of meshio's own printing reaches the terminal


def test_mesh_paths_are_relative_to_the_scene_file(tmp_path):
    folder = tmp_path / "scenes"
    folder.mkdir()
    _square(folder / "square.stl", 0.4)
    (folder / "scene.toml").write_text('[volume]\ndemo = "shepp-logan"\nsize = 8\n[renderer]\nname = "reference"\n'
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

    square = _square(tmp_path / "square.obj", 0.0, half=5000.0, centre=(0.0, 0.0))  # a floor under every pixel
    out = tmp_path / "out.exr"
    assert main(["render", "--demo", "--size", "24", "--mesh", f"{square}:0.2,0.4,0.9", "-o", str(out)]) == 0
    plain = tmp_path / "plain.exr"
    assert main(["render", "--demo", "--size", "24", "-o", str(plain)]) == 0
    from dvr_gl.image import read_image

    meshed, alone = read_image(out), read_image(plain)
    # the plate, blue, covers every pixel: the corner is the plate's, not the black background
    assert meshed[0, 0, 2] > 0.3 and meshed[0, 0, 2] > meshed[0, 0, 0] and alone[0, 0, :3].max() < 1e-6
    bad = tmp_path / "bad.png"
    for flag, words in ((f"{tmp_path / 'absent.obj'}", "not found"), (f"{square}:red", "--mesh")):
        assert main(["render", "--demo", "--size", "24", "--mesh", flag, "-o", str(bad)]) == 1
        err = capsys.readouterr().err.strip()
        assert words in err and "\n" not in err and not bad.exists()


def test_the_viewer_names_the_meshes(tmp_path):
    """A scene file's meshes render in the viewer as with dvr render (the same renderers); its status line
    counts them."""
    from dvr_gl.viewer import settings

    scene = load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": _tilted(tmp_path)})
    assert "1 mesh |" in settings.describe(scene)
    assert "2 meshes" in settings.describe(scene.with_renderer(geometry=scene.renderer.geometry * 2))



@pytest.mark.parametrize("extra", [{}, {"renderer.sheet_buffer": "axis_aligned"}, {"renderer.classification": "pre"},
                                   {"renderer.compositing": "average"}],
                         ids=["image-aligned", "axis-aligned", "pre", "average"])
def test_splatting_ends_its_parts_at_the_meshes_as_its_oracle(tmp_path, gl_context, extra):
    """Splatting integrates each kernel over the pixel's ray part in front of the layer's surface, and
    composites over the layer; its oracle does the same with the float64 surfaces (measured at most
    7.1e-8)."""
    from dvr_gl.renderers.splatting.oracle import reference

    scene = load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 12, "image.width": 16, "image.height": 12,
                              "renderer.name": "splatting", "renderer.filter": "gaussian",
                              "renderer.ert_threshold": 1.0,
                              "renderer.geometry": _tilted(tmp_path), **extra})
    with registry.plugin("splatting").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_close(image, reference(scene))


SPHERE_RADIUS = 0.5


def _sphere(path, z, subdivisions=4):
    from dvr_gl.geometry import icosphere

    points, faces = icosphere((2.0, 2.0, z), SPHERE_RADIUS, subdivisions)
    meshio.write_points_cells(str(path), points, [("triangle", faces)])
    return str(path)


def _sphere_bounds(scene, z):
    """The closed forms of a sphere of colour ``GREY`` shown flat (no lights) at height ``z`` above or in
    the slab, for the true radius and for the radius of the sphere inside every facet (the
    tessellation's gap, :func:`dvr_gl.geometry.icosphere`): a pixel's ray meets the facets between
    the two spheres, and the pixel is monotone in that depth, so it lies between the two forms.
    Pixels whose ray passes between the two silhouettes are left out (``None`` mask)."""
    gap = SPHERE_RADIUS * 0.3 / 4 ** 4
    origins, _ = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    r2 = (origins[:, 0] - 2.0) ** 2 + (origins[:, 1] - 2.0) ** 2
    forms = []
    for radius in (SPHERE_RADIUS, SPHERE_RADIUS - gap):
        hit = r2 < radius ** 2
        top = np.where(hit, z + np.sqrt(np.maximum(radius ** 2 - r2, 0.0)), -np.inf)
        depth = 1.0 - np.clip(top, 0.0, 1.0)  # the slab's part in front of the surface
        alpha = -np.expm1(-SIGMA * depth)
        rgba = np.concatenate([COLOUR * alpha[:, None], alpha[:, None]], axis=1)
        rgba += (1.0 - alpha[:, None]) * np.where(hit[:, None], np.append(GREY, 1.0), 0.0)
        forms.append(rgba)
    clear = (r2 < (SPHERE_RADIUS - gap) ** 2) | (r2 > SPHERE_RADIUS ** 2)
    shape = (scene.image.height, scene.image.width, 4)
    lo, hi = np.minimum(*forms), np.maximum(*forms)
    return lo.reshape(shape), hi.reshape(shape), clear.reshape(shape[:2])


def test_icosphere_facets_lie_within_the_stated_gap():
    from dvr_gl.geometry import icosphere

    for subdivisions in (2, 3, 4):
        points, faces = icosphere((0.0, 0.0, 0.0), 1.0, subdivisions)
        assert np.allclose(np.linalg.norm(points, axis=1), 1.0)
        centres = np.linalg.norm(points[faces].mean(axis=1), axis=1)
        assert 0.5 * 0.3 / 4 ** subdivisions < 1.0 - centres.min() < 0.3 / 4 ** subdivisions


@pytest.mark.parametrize("height", [1.6, 0.5], ids=["in front", "inside"])
@pytest.mark.parametrize("name", ["reference", "reference-converged", "raycast", "projected-tetrahedra"])
def test_sphere_in_front_of_and_inside_a_slab(tmp_path, gl_context, name, height):
    """The issue's closed form: a sphere (5120 facets, radius 0.5, flat colour) above the slab hides it
    where it covers it; inside it (touching both faces) it ends each ray at the height of its top,
    ``z + sqrt(R^2 - r^2)``.  Every pixel between the forms of the true and the inscribed sphere, to
    rounding (the references) or float32 (2e-6: the GPU renderers); 60 % of the pixels are clear of
    the silhouettes' band."""
    extra = {"renderer.shading.lights": [], "image.width": 24, "image.height": 20}
    geometry = [{"path": _sphere(tmp_path / "sphere.obj", height), "color": list(GREY)}]
    if name == "projected-tetrahedra":  # the slab meshed into tetrahedra (tests/renderers/test_mesh_clipping.py)
        from test_mesh_clipping import slab_keys, slab_mesh
        from test_projected_tetrahedra import mesh_scene

        scene = mesh_scene(slab_mesh(), **slab_keys(name, **{"renderer.geometry": geometry, **extra}))
    else:
        scene = _slab_scene(tmp_path, name, geometry, **extra)
    if name in ("raycast", "projected-tetrahedra"):
        with registry.plugin(name).create(ctx=gl_context) as renderer:
            image, tolerance = renderer.render(scene), 2e-6
    else:
        reference = ConvergedReference(scene) if name == "reference-converged" else DiscreteReference(scene)
        image, tolerance = reference.render_float64(), 1e-9
    lo, hi, clear = _sphere_bounds(scene, height)
    assert clear.mean() > 0.6 and (hi - lo)[clear].max() < 3e-3  # narrow: measured 2.2e-3 at most (a rim pixel)
    assert np.all(image[clear] >= lo[clear] - tolerance) and np.all(image[clear] <= hi[clear] + tolerance)
    assert image[..., 3].min() > 0.7  # the slab everywhere, or the opaque sphere


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


def _degenerate(tmp_path):
    path = tmp_path / "flat.stl"
    points = np.array([[0.0, 0, 0], [1, 1, 1], [2, 2, 2], [5, 5, 5]])  # collinear: zero area
    meshio.write_points_cells(str(path), points, [("triangle", np.array([[0, 1, 2], [1, 2, 3], [0, 0, 3]]))])
    return [{"path": str(path), "color": [0.3, 0.5, 0.9]}]


@pytest.mark.parametrize("name", ["raycast", "slicing3d", "shearwarp", "reference"])
def test_a_mesh_of_only_degenerate_triangles_renders_as_none(tmp_path, gl_context, name):
    """Issue 40: 'the buffer cannot be empty' (exit 3) for a valid mesh that covers nothing."""
    from dvr_gl.renderers.base import create_renderer

    with_mesh = load_scene(None, {**TILTED, "renderer.name": name, "renderer.geometry": _degenerate(tmp_path)})
    without = load_scene(None, {**TILTED, "renderer.name": name})
    with create_renderer(name, ctx=gl_context) as renderer:
        np.testing.assert_array_equal(renderer.render(with_mesh), renderer.render(without))


def _sphere_stl(tmp_path, subdivisions=4):
    from dvr_gl.geometry import icosphere

    points, faces = icosphere((0.0, 0.0, 0.0), 6.0, subdivisions)
    path = tmp_path / f"sphere{subdivisions}.stl"
    meshio.write_points_cells(str(path), points, [("triangle", faces)], binary=True)
    return path


def test_meshes_count_against_the_memory_budget(tmp_path, gl_context):
    """Issue 40: a 327k-triangle STL rendered under a 4 MiB budget at 421 MB.  Reading (10x the file),
    the GL layer and the host test are now checked before they are made."""
    from dvr_gl.renderers.base import create_renderer
    from dvr_gl.sandbox import Sandbox, SandboxError, active

    path = _sphere_stl(tmp_path)  # 5120 triangles, 256 kB
    geometry = [{"path": str(path), "color": [0.3, 0.5, 0.9]}]
    with active(Sandbox(max_bytes=2 << 20)), pytest.raises(SandboxError, match="reading the mesh sphere4.stl"):
        load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": geometry})
    for name, words in (("raycast", "drawing 5120 triangles"), ("reference", "testing 320 rays against 5120")):
        scene = load_scene(None, {**TILTED, "renderer.name": name, "renderer.geometry": geometry})
        with active(Sandbox(max_bytes=3 << 20)), create_renderer(name, ctx=gl_context) as renderer, \
                pytest.raises(SandboxError, match=words):
            renderer.render(scene)


def test_the_host_test_is_bounded_and_fast(tmp_path, monkeypatch):
    """Issue 40: a 327k-triangle STL ran over 60 s in shearwarp and reference (every ray against every
    triangle).  The plan tests a few pairs a ray; its count is checked against the bound (lowered by
    --max-seconds) before any test, and the refusal names the count and what to change."""
    import dvr_gl.geometry as geometry
    from dvr_gl import limits
    from dvr_gl.sandbox import Sandbox, active

    path = _sphere_stl(tmp_path, 5)  # 20480 triangles
    scene = load_scene(None, {**TILTED, "image.width": 64, "image.height": 64, "renderer.name": "reference",
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


def test_the_gl_surface_layer_counts_its_fragments_against_the_work_bound(tmp_path, gl_context, monkeypatch):
    """Every renderer that takes geometry estimates it: the host test its ray-triangle pairs, the GL layer
    the pixels of its triangles' boxes (huge or countless triangles refused in one line, naming them)."""
    from dvr_gl import limits
    from dvr_gl.renderers.base import create_renderer

    scene = load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": _tilted(tmp_path)})
    monkeypatch.setitem(limits.BOUNDS, "gpu samples", 100.0)  # the layer: 3 triangles, boxes of 190 pixels
    monkeypatch.setattr(limits, "check_work", _only_layers(limits.check_work))
    with create_renderer("raycast", ctx=gl_context) as renderer, \
            pytest.raises(DvrError, match=r"raycast would take .* gpu samples \(3 triangles covering about"):
        renderer.render(scene)


def _only_layers(check):
    """limits.check_work for the surface layer's work only (the volume's samples pass)."""
    def checked(work, name):
        if work is not None and "triangles covering" in work.how:
            check(work, name)
    return checked
