"""The slab of tests/renderers/test_clipping.py and test_geometry.py and its closed forms: 4 x 4 x 1 (world)
of constant data 0.5, seen orthographically from +z, clipped (Beer-Lambert on the kept chord) or with
opaque meshes in front of or inside it (a square, an icosphere); the tilted meshes through the phantom.
Shared by the generic tests and each renderer's own (``dvr_gl/renderers/NAME/tests/``).
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import array_scene, assert_close
from dvr_gl.fields.mesh import TetMesh
from dvr_gl.fields.mesh_cells import hexahedra_of_grid, tetrahedralize
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene


def _meshio():
    """meshio writes the test meshes (the mesh extra): a test that draws one is skipped without it."""
    return pytest.importorskip("meshio", reason="meshes are read by meshio (the mesh extra)")


COLOUR = np.array([0.9, 0.6, 0.3])


GREY = np.array([0.2, 0.7, 0.4])


SIGMA = 1.3


def square(path, z, half=0.75, centre=(2.0, 2.0), quads=False):
    """A square at height z facing +z, as two triangles (or one quadrilateral)."""
    cx, cy = centre
    points = np.array([[cx - half, cy - half, z], [cx + half, cy - half, z], [cx + half, cy + half, z],
                       [cx - half, cy + half, z]])
    cells = [("quad", np.array([[0, 1, 2, 3]]))] if quads else [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))]
    _meshio().write_points_cells(str(path), points, cells)
    return str(path)


def meshed_slab_scene(tmp_path, renderer, geometry, **extra):
    data = np.full((3, 9, 9), 0.5, np.float32)
    overrides = {"renderer.name": renderer, "transfer_function.points": [[0.0, *COLOUR, SIGMA], [1.0, *COLOUR, SIGMA]],
                 "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 10,
                 "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
                 "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.0, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-7, "renderer.geometry": geometry, **extra}
    return array_scene(tmp_path, data, overrides, spacing=(0.5, 0.5, 0.5))


def square_expected(scene, height):
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


TILTED = {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20, "image.height": 16,
          "renderer.ert_threshold": 1.0}


def tilted(tmp_path):
    """A tilted square through the middle of the centred 16^3 phantom, and a small one in front of it."""
    points = np.array([[-9.0, -9.0, -4.0], [9.0, -9.0, 2.0], [9.0, 9.0, 4.0], [-9.0, 9.0, -2.0],
                       [-2.0, -2.0, 12.0], [3.0, -2.0, 12.0], [3.0, 3.0, 12.0]])
    path = tmp_path / "tilted.ply"
    triangles = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]], np.int32)
    _meshio().write_points_cells(str(path), points, [("triangle", triangles)])
    return [{"path": str(path), "color": [0.3, 0.5, 0.9]}]


SPHERE_RADIUS = 0.5


def sphere(path, z, subdivisions=4):
    from dvr_gl.geometry import icosphere

    points, faces = icosphere((2.0, 2.0, z), SPHERE_RADIUS, subdivisions)
    _meshio().write_points_cells(str(path), points, [("triangle", faces)])
    return str(path)


def sphere_bounds(scene, z):
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


def degenerate(tmp_path):
    path = tmp_path / "flat.stl"
    points = np.array([[0.0, 0, 0], [1, 1, 1], [2, 2, 2], [5, 5, 5]])  # collinear: zero area
    _meshio().write_points_cells(str(path), points, [("triangle", np.array([[0, 1, 2], [1, 2, 3], [0, 0, 3]]))])
    return [{"path": str(path), "color": [0.3, 0.5, 0.9]}]


def sphere_stl(tmp_path, subdivisions=4):
    from dvr_gl.geometry import icosphere

    points, faces = icosphere((0.0, 0.0, 0.0), 6.0, subdivisions)
    path = tmp_path / f"sphere{subdivisions}.stl"
    _meshio().write_points_cells(str(path), points, [("triangle", faces)], binary=True)
    return path


def only_layers(check):
    """limits.check_work for the surface layer's work only (the volume's samples pass)."""
    def checked(work, name):
        if work is not None and "triangles covering" in work.how:
            check(work, name)
    return checked


PLANE = [0.2, 0.0, -1.0, 0.21]  # 0.21: no slice or pixel centre on the plane (float32 would decide it)


def clipped_slab_scene(tmp_path, renderer, clipping):
    """A slab 4 x 4 x 1 (world) of constant data, seen orthographically from +z, x and y in [1, 3]."""
    data = np.full((3, 9, 9), 0.5, np.float32)
    overrides = {"renderer.name": renderer, "transfer_function.points": [[0.0, *COLOUR, SIGMA], [1.0, *COLOUR, SIGMA]],
                 "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 10,
                 "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
                 "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.0, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-7, "renderer.clipping": clipping}
    return array_scene(tmp_path, data, overrides, spacing=(0.5, 0.5, 0.5))


def beer_lambert(scene, chord) -> np.ndarray:
    """The expected image, ``chord(x, y)`` the kept length of each pixel's ray."""
    origins, _ = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    alpha = -np.expm1(-SIGMA * chord(origins[:, 0], origins[:, 1]))
    rgba = np.concatenate([COLOUR * alpha[:, None], alpha[:, None]], axis=1)
    return rgba.reshape(scene.image.height, scene.image.width, 4)


CASES = {
    "plane": ({"planes": [PLANE]}, lambda x, y: 0.21 + 0.2 * x),
    "box": ({"box": [[1.5, 1.4, 0.2], [2.5, 2.6, 0.7]]},
            lambda x, y: np.where((abs(x - 2.0) <= 0.5) & (abs(y - 2.0) <= 0.6), 0.5, 0.0)),
    "both": ({"planes": [PLANE], "box": [[0.0, 0.0, 0.3], [4.0, 4.0, 1.0]]},
             lambda x, y: np.maximum(0.21 + 0.2 * x - 0.3, 0.0)),
}


CLIPPED_PHANTOM = {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20, "image.height": 16,
         "renderer.clipping": {"planes": [[1.0, 0.4, -0.3, 1.0]], "box": [[-9.0, -4.0, -9.0], [9.0, 5.0, 6.0]]}}


def clip_slab_as_its_planes(ctx, tmp_path, name, case, spacing=None):
    """A renderer that samples planes (slices, shear-warp's voxel planes) on the clipped slab: its image
    against its oracle (the same planes) to the conftest's bound, and within ``S s`` of Beer-Lambert on
    the kept chord (a plane spacing ``s``, the scene's sample distance when None, errs by up to ``S s``
    on a chord).  Returns the defines it compiled (``None``: it compiles none)."""
    clipping, chord = CASES[case]
    scene = clipped_slab_scene(tmp_path, name, clipping)
    with registry.plugin(name).create(ctx=ctx) as renderer:
        image = renderer.render(scene)
        defines = dict(renderer.stats["defines"]) if "defines" in renderer.stats else None
    assert_close(image, registry.plugin(name).oracle_image(scene))
    spacing = scene.renderer.sample_distance if spacing is None else spacing
    assert np.abs(image - beer_lambert(scene, chord)).max() < SIGMA * spacing
    return defines


#: the cases of a renderer that samples planes against its oracle on the clipped phantom
PLANE_EXTRAS = {"default": {}, "preintegrated": {"renderer.classification": "preintegrated"},
                "shaded": {"renderer.shading.enabled": True}, "orthographic": {"camera.projection": "orthographic"}}


def clip_phantom_as_its_planes(ctx, name, extra):
    """The slicers' fragments and shear-warp's samples outside the region are dropped, as their
    oracles' plane crossings outside each ray's interval are (measured: slicers 2.7e-7, shear-warp
    1.4e-7, no value off by more than 1e-4)."""
    scene = load_scene(None, {**CLIPPED_PHANTOM, "renderer.name": name, **extra})
    with registry.plugin(name).create(ctx=ctx) as renderer:
        image = renderer.render(scene)
    assert_close(image, registry.plugin(name).oracle_image(scene))


def assert_square_in_or_above(image, scene, height, tolerance):
    """The square in or above the slab against its closed form (:func:`square_expected`)."""
    assert np.abs(image - square_expected(scene, height)).max() < tolerance


#: the sphere cases: a sphere in front of the slab, or inside it (touching both faces)
SPHERE_HEIGHTS = {"in front": 1.6, "inside": 0.5}
SPHERE_KEYS = {"renderer.shading.lights": [], "image.width": 24, "image.height": 20}


def sphere_geometry(tmp_path, height):
    return [{"path": sphere(tmp_path / "sphere.obj", height), "color": list(GREY)}]


def assert_within_sphere_bounds(image, scene, height, tolerance):
    """The issue's closed form: a sphere (5120 facets, radius 0.5, flat colour) above the slab hides it
    where it covers it; inside it (touching both faces) it ends each ray at the height of its top,
    ``z + sqrt(R^2 - r^2)``.  Every pixel between the forms of the true and the inscribed sphere, to
    ``tolerance`` (rounding for the references, float32 for the GPU renderers); 60 % of the pixels are
    clear of the silhouettes' band."""
    lo, hi, clear = sphere_bounds(scene, height)
    assert clear.mean() > 0.6 and (hi - lo)[clear].max() < 3e-3  # narrow: measured 2.2e-3 at most (a rim pixel)
    assert np.all(image[clear] >= lo[clear] - tolerance) and np.all(image[clear] <= hi[clear] + tolerance)
    assert image[..., 3].min() > 0.7  # the slab everywhere, or the opaque sphere


def degenerate_mesh_renders_as_none(ctx, tmp_path, name):
    """Issue 40: 'the buffer cannot be empty' (exit 3) for a valid mesh that covers nothing: a mesh of only
    degenerate triangles renders as no mesh."""
    from dvr_gl.renderers.base import create_renderer

    with_mesh = load_scene(None, {**TILTED, "renderer.name": name, "renderer.geometry": degenerate(tmp_path)})
    without = load_scene(None, {**TILTED, "renderer.name": name})
    with create_renderer(name, ctx=ctx) as renderer:
        np.testing.assert_array_equal(renderer.render(with_mesh), renderer.render(without))


def slab_mesh(n=(5, 5, 3)):
    """The slab 0 <= x, y <= 4, 0 <= z <= 1 as hexahedra (split into tetrahedra), the value 0.5."""
    axes = [np.linspace(0.0, 4.0, n[0]), np.linspace(0.0, 4.0, n[1]), np.linspace(0.0, 1.0, n[2])]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    points, tets, _, values = tetrahedralize(p, [("hexahedron", hexahedra_of_grid(*n))], np.full(len(p), 0.5))
    return TetMesh(points, tets, values, name="slab")


def slab_keys(name, **extra):
    """tests/renderers/test_clipping.py's view of the slab: orthographic along -z, x in [0.8, 3.2]."""
    return {"renderer.name": name, "transfer_function.points": [[0.0, *COLOUR, SIGMA], [1.0, *COLOUR, SIGMA]],
            "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 10,
            "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
            "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.0, "renderer.ert_threshold": 1.0, **extra}
