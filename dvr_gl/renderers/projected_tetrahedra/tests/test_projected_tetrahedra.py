"""Projected tetrahedra against the float64 mesh reference: transfer-function features inside a cell,
views along an axis (edge-on faces), the camera inside the mesh, and the visibility order where the
centroid order visibly fails.  (The closed forms on meshes run in tests/renderers/test_conformance.py.)"""

from __future__ import annotations

import functools
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import SHARED_DATA
from dvr_gl.camera import Camera
from dvr_gl.errors import SceneError
from dvr_gl.fields.mesh import TetMesh
from dvr_gl.fields.mesh_rays import boundary_faces, face_neighbours
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.renderers.projected_tetrahedra import INTEGRATIONS, fan
from dvr_gl.renderers.projected_tetrahedra.order import (
    NEAR_CELLS,
    REACH_MARGIN,
    VisibilityOrder,
    adjacency,
    boundary_relations,
    compiled,
    locality_order,
    o_d_t,
    reaching,
    scattered,
    topological,
)
from dvr_gl.renderers.projected_tetrahedra.renderer import ProjectedTetrahedraRenderer
from dvr_gl.scene.resolve import load_scene
from judges import CONVERGED, renderers
from mesh_inputs import BAND_TF, REFERENCE_VIEWS, jittered_mesh, mesh_scene, rms
from slab_scenes import SPHERE_HEIGHTS, SPHERE_KEYS, assert_within_sphere_bounds, slab_keys, slab_mesh, sphere_geometry

# the other GL renderer of meshes (it walks the cells), and the grid renderer a resampled mesh gets
WALKER = next(n for n in renderers(kind="mesh", gl=True) if n != "projected-tetrahedra")
GRID = registry.default_for("grid")


@pytest.fixture(scope="module")
def pt():
    r = create_renderer("projected-tetrahedra")
    yield r
    r.close()












@pytest.mark.parametrize("view", REFERENCE_VIEWS)
def test_emission_absorption_matches_the_mesh_reference(pt, converged, view):
    """Every fragment integrates the exact transfer function along its own piece: the band inside the
    cells is there, in perspective and orthographic, from oblique and axis-aligned views.  Measured
    RMS about 2e-5 (float32 planes and values against float64: the band's slope turns a 1e-7 error
    in the scalar into 1e-6 in opacity, largest 1.6e-4 in a pixel); bound 1e-4."""
    mesh = jittered_mesh()
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", **view})
    image = pt.render(scene)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert truth[..., 3].max() > 0.3
    assert rms(image, truth) < 1e-4, rms(image, truth)
    assert pt.stats["cycles_broken"] == 0 and pt.stats["order"] == "exact"


@pytest.mark.parametrize("view", [
    {"camera.azimuth": 30.0, "camera.elevation": 20.0},
    {"camera.azimuth": 0.0, "camera.elevation": 0.0},
    {"camera.azimuth": 120.0, "camera.elevation": -10.0, "camera.fov": 60.0},
    {"camera.projection": "orthographic", "camera.azimuth": -50.0, "camera.elevation": 35.0},
])
def test_one_fragment_per_cell_a_ray_crosses(pt, view):
    """The footprints (convex hulls, grown, as triangle strips) give every pixel exactly one fragment
    for each cell its ray crosses: none lost at a silhouette by the rasterizer's snapping, none twice
    where a strip's thin triangles meet (an earlier bevelled outline turned slivers over in fixed
    point and covered a blunt-fin pixel three times).  Pieces shorter than 1e-6 of the mesh (rays
    grazing an edge) may go either way in float32."""
    mesh = jittered_mesh(n=(6, 5, 5), seed=3)
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "image.width": 96, "image.height": 80,
                                **view})
    counts = pt.fragment_counts(scene)
    o, d = scene.camera.pixel_rays(96, 80)
    ray, a, b, _ = mesh.reconstruct().pieces(o, d, scene.camera.near_distance(d), np.full(len(d), np.inf))
    solid = np.bincount(ray[(b - a) > 1e-6], minlength=len(d)).reshape(80, 96)
    grazing = np.bincount(ray[(b - a) <= 1e-6], minlength=len(d)).reshape(80, 96)
    assert solid.sum() > 20000
    assert np.all(counts >= solid) and np.all(counts <= solid + grazing), \
        (np.argwhere(counts < solid)[:5], np.argwhere(counts > solid + grazing)[:5])


@pytest.mark.parametrize("lens", [{"camera.fov": 70.0},
                                  {"camera.projection": "orthographic", "camera.view_height": 0.6}])
def test_camera_inside_the_mesh(pt, converged, lens):
    """The eye inside a cell: cells reaching behind the eye's plane cover the whole image and clip
    their rays at the eye (perspective) or at the plane through it (orthographic); the picture is the
    reference's."""
    mesh = jittered_mesh()
    keys = {"camera.eye": [0.45, 0.35, 0.4], "camera.target": [1.0, 0.8, 0.9], "camera.up": [0, 0, 1], **lens}
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", **keys})
    image = pt.render(scene)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert truth[..., 3].min() > 0.05, "every ray starts inside"
    assert rms(image, truth) < 1e-4, rms(image, truth)


def test_too_many_transfer_function_points_are_refused(pt):
    """The control points live in the fragment shader's uniforms: more than this GL holds is one line
    naming the key, not a failed compile."""
    mesh = jittered_mesh()
    n = pt.max_tf_points() + 1
    values = np.linspace(-1.0, 2.0, n)
    points = [[float(v), 0.5, 0.5, 0.5, 0.3] for v in values]
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "transfer_function.points": points})
    with pytest.raises(SceneError, match=r"transfer_function.points: .* at most \d+"):
        pt.render(scene)
    assert pt.max_tf_points() >= 96  # what the 1024 fragment uniform components GL 4.3 guarantees hold


def overlapping_cells():
    """A large flat cell A over a small cell B (seen from above), A's apex far below and aside, so
    A's centroid is deeper than B's although A is in front of B where they overlap."""
    a = [[-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [0.0, 1.0, 1.0], [6.0, 0.0, -5.0]]
    b = [[-0.15, -0.3, 0.1], [0.15, -0.3, 0.1], [0.0, -0.05, 0.1], [0.0, -0.2, 0.35]]
    points = np.array(a + b)
    return TetMesh(points, np.array([[0, 1, 2, 3], [4, 5, 6, 7]]), np.array([0.0, 1.0]), association="cell",
                   name="overlap")


def test_exact_order_where_the_centroid_order_fails(pt, converged):
    mesh = overlapping_cells()
    # B lies wholly below A (no overlap in space): points throughout B are outside A
    a, b = mesh.points[mesh.tets[0]], mesh.points[mesh.tets[1]]
    weights = np.random.default_rng(0).dirichlet(np.ones(4), 2000)
    inside_b = weights @ b
    lam = np.linalg.solve((a[1:] - a[0]).T, (inside_b - a[0]).T).T
    assert np.all((lam.min(axis=1) < 0) | (lam.sum(axis=1) > 1))
    tf = [[0.0, 1.0, 0.1, 0.1, 0.5], [1.0, 0.1, 0.2, 1.0, 0.9]]
    keys = {"renderer.name": "projected-tetrahedra", "camera.projection": "orthographic", "camera.eye": [0, 0, 5],
            "camera.target": [0, 0, 0], "camera.up": [0, 1, 0], "camera.view_height": 0.8,
            "transfer_function.points": tf, "transfer_function.opacity_model": "extinction",
            "image.width": 24, "image.height": 24}
    scene = mesh_scene(mesh, **keys)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    exact = pt.render(scene)
    assert np.abs(exact - truth).max() < 1e-5, np.abs(exact - truth).max()  # measured 7e-7
    # only the rays crossing the boundary three times or more (A then B), and their neighbours, are cast
    assert 0 < pt.stats["rays_cast"] < 24 * 24 // 2, pt.stats["rays_cast"]
    centroid = pt.render(scene.with_renderer(cell_order="centroid"))
    wrong = np.abs(centroid - truth).max(axis=2) > 0.01  # B over A: measured 0.039 on 19 pixels
    assert wrong.sum() >= 10, "the centroid order draws B over A where they overlap"


def test_transparent_cells_are_not_drawn(pt, converged):
    """Cells whose whole scalar range maps to zero opacity add nothing and are left out of the draw
    (not of the order: its relations run through them); the picture is the reference's.  Here the
    transfer function is transparent up to 0.9 and between 1.2 and 1.4 (a zero-opacity control point
    inside a cell's range does not make it transparent: the ramps on either side do)."""
    mesh = jittered_mesh()
    tf = [[-1.0, 0.2, 0.3, 0.9, 0.0], [0.9, 0.2, 0.3, 0.9, 0.0], [1.0, 1.0, 0.5, 0.2, 0.6],
          [1.2, 0.3, 0.9, 0.2, 0.0], [1.4, 0.3, 0.9, 0.2, 0.0], [2.0, 0.9, 0.2, 0.2, 0.5]]
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "transfer_function.points": tf})
    image = pt.render(scene)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    # measured 1.0e-7; the bound is the band test's (float32 planes and values against float64)
    assert rms(image, truth) < 1e-4, rms(image, truth)
    values = mesh.values[mesh.tets]
    lo, hi = values.min(axis=1), values.max(axis=1)
    transparent = (hi <= 0.9) | ((lo >= 1.2) & (hi <= 1.4))
    textures, orders = pt._mesh_resources(scene.field)
    unreached = ~pt._reaching(scene, textures, orders)[0]  # nor those that reach no pixel centre (below)
    assert transparent.sum() >= 10
    assert pt.stats["cells_drawn"] == len(mesh.tets) - (transparent | unreached).sum()


@pytest.mark.parametrize("integration", INTEGRATIONS)
def test_cells_that_reach_no_pixel_centre_are_not_drawn(pt, monkeypatch, integration):
    """At 5x4 pixels most cells of a finer jittered mesh hold no pixel centre in their projected box: they
    are left out of the draw (``cull_unreached``), and the picture is, to the bit, the one every cell
    drawn gives (the rasterizer keeps pixel centres only, so the others drew no fragment)."""
    mesh = jittered_mesh(n=(7, 6, 5))
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "renderer.integration": integration,
                                "image.width": 5, "image.height": 4})
    kept = pt.render(scene)
    drawn = pt.stats["cells_drawn"]
    monkeypatch.setattr(pt, "cull_unreached", False)
    every = pt.render(scene)
    assert pt.stats["cells_drawn"] == len(mesh.tets)
    assert 0 < drawn < 0.5 * len(mesh.tets), drawn  # measured 525 of 1440
    assert kept[..., 3].max() > 0.1
    np.testing.assert_array_equal(kept, every)


@pytest.mark.parametrize("fast", [False, True])
def test_reaching_a_pixel_centre_by_the_grown_box(fast):
    """:func:`reaching` in closed form: the identity view projection puts a point at pixel
    ``(x + 1) / 2 * width``; of a 4x4 image's centres (0.5 to 3.5), a box from 1.65 to 2.35 holds none
    (0.15 from the nearest, beyond the 0.1 margin), one to 2.45 reaches 2.5 within the margin, one
    outside the image reaches none; the compiled loop agrees with numpy's."""
    module = compiled() if fast else None
    if fast and module is None:
        pytest.skip("numba is not installed")
    assert REACH_MARGIN == 0.1
    corners = [(1.65, 1.65), (2.35, 1.65), (1.65, 2.35), (2.35, 2.35)]
    cells = [[(x, y) for x, y in corners],
             [(x + 0.1 * (x > 2), y + 0.1 * (y > 2)) for x, y in corners],  # to 2.45 on both axes
             [(x + 0.1 * (x > 2), y) for x, y in corners],  # to 2.45 along x only
             [(x + 3.0, y + 0.9) for x, y in corners]]  # beyond the image's last centre, 3.5
    pixels = np.array([p for cell in cells for p in cell], float)
    points = np.c_[pixels / 4.0 * 2.0 - 1.0, np.zeros(len(pixels))]
    tets = np.arange(len(points), dtype=np.int64).reshape(-1, 4)
    assert reaching(points, tets, np.eye(4), 4, 4, module).tolist() == [False, True, False, False]
    # and on a mesh, in perspective and orthographic, the two loops cell for cell
    mesh = jittered_mesh(n=(7, 6, 5))
    for view in (REFERENCE_VIEWS[0], REFERENCE_VIEWS[3]):
        scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "image.width": 23,
                                    "image.height": 17, **view})
        vp = ProjectedTetrahedraRenderer.view_projection(scene, np.zeros(3))
        tets = mesh.tets.astype(np.int64)
        tiles, again = np.empty(len(tets), np.uint32), np.empty(len(tets), np.uint32)
        some = reaching(mesh.points, tets, vp, 23, 17, None, 4, tiles)
        assert 0 < some.sum() < len(tets)
        np.testing.assert_array_equal(reaching(mesh.points, tets, vp, 23, 17, module, 4, again), some)
        np.testing.assert_array_equal(again, tiles)  # the screen tiles (4 pixels) too
        assert len(np.unique(tiles[some])) > 10



@pytest.mark.parametrize("integration", INTEGRATIONS)
def test_the_order_grouped_by_screen_tile_draws_the_same_picture(pt, monkeypatch, integration):
    """The drawn order grouped by tiles of 8 pixels (``tile_pixels``; 6 x 5 of them at 48x40) is another
    order, and the picture is, to the bit, the visibility order's: every pixel meets the same fragments in
    the same order (the cells touching a tile keep their order)."""
    from dvr_gl.renderers.projected_tetrahedra import renderer

    if compiled() is None:
        pytest.skip("numba is not installed (without it the order is drawn as it is)")
    mesh = jittered_mesh(n=(7, 6, 5))
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "renderer.integration": integration,
                                "image.width": 48, "image.height": 40})
    orders, group = [], renderer.tile_coherent

    def recorded(order, *args):
        orders.append((order, group(order, *args)))
        return orders[-1][1]

    monkeypatch.setattr(renderer, "tile_coherent", recorded)
    monkeypatch.setattr(pt, "tile_pixels", 8)
    grouped = pt.render(scene)
    assert pt.stats["tiles"] == 8
    before, after = orders[-1]
    assert np.array_equal(np.sort(before), np.sort(after)) and not np.array_equal(before, after)
    monkeypatch.setattr(pt, "tile_pixels", 0)
    visibility = pt.render(scene)
    assert pt.stats["tiles"] == 0
    np.testing.assert_array_equal(grouped, visibility)


def test_a_convex_boundary_casts_no_rays(pt):
    """A convex boundary (within CONVEX_SLACK of the mesh's size) has no gaps: no boundary count in GL
    and no rays cast, and the picture is the one the count and the rays give (0 of them cast there
    too).  A dent deeper than the slack, a notch cut out and two separate cells are not convex."""
    mesh = jittered_mesh()  # its boundary points lie on the box's faces
    assert VisibilityOrder(mesh).adjacency.convex
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra"})
    image = pt.render(scene)
    assert pt.stats["rays_cast"] == 0
    adj = pt._mesh_resources(scene.field)[1].adjacency
    try:
        adj.__dict__["convex"] = False  # the count in GL and the rays it picks, as for any mesh
        counted = pt.render(scene)
    finally:
        del adj.__dict__["convex"]
    np.testing.assert_array_equal(image, counted)
    face = np.nonzero((mesh.points[:, 2] == 0.0) & (mesh.points[:, 0] > 0) & (mesh.points[:, 0] < 1.0)
                      & (mesh.points[:, 1] > 0) & (mesh.points[:, 1] < 0.8))[0][0]  # inside the box's bottom face
    for dent, convex in ((1e-8, True), (1e-3, False)):
        points = mesh.points.copy()
        points[face, 2] += dent  # into the mesh
        assert adjacency(points, mesh.tets).convex == convex, dent
    centroids = mesh.points[mesh.tets].mean(axis=1)
    kept = ~((centroids[:, 0] > 0.5) & (centroids[:, 1] > 0.4))
    assert not adjacency(mesh.points, mesh.tets[kept]).convex
    assert not VisibilityOrder(overlapping_cells()).adjacency.convex

def test_cells_touching_without_shared_points_are_ordered():
    """Two cells meeting at a face with its points duplicated, not shared (a multi-block grid's block
    interface, as in the oxygen post): no interior face relates them, and the boundary crossings at
    the interface come from two triangles whose t's differ by rounding; here the second cell's face
    is 1e-13 nearer the eye than the first's, so its entry comes a hair before the exit it meets.
    The exit must still relate to it."""
    a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    b = [[0.0, 0.0, 1e-13], [1.0, 0.0, 1e-13], [0.0, 1.0, 1e-13], [0.3, 0.3, -1.0]]
    mesh = TetMesh(np.array(a + b), np.array([[0, 1, 2, 3], [4, 5, 6, 7]]), np.array([0.0, 1.0]),
                   association="cell", name="touching")
    camera = Camera(eye=(0.25, 0.25, 5.0), target=(0.25, 0.25, 0.0), up=(0.0, 1.0, 0.0), projection="orthographic",
                    view_height=0.2)
    order, stats = VisibilityOrder(mesh)(camera, 8, 8, "exact")
    assert stats["boundary_relations"] >= 1
    assert list(order) == [0, 1], "the upper cell (nearer the eye) first"


def test_topological_order_respects_relations_and_breaks_cycles():
    depth = np.array([3.0, 1.0, 2.0, 0.5])
    order, broken = topological(4, np.array([0, 2]), np.array([2, 1]), depth)
    assert broken == 0
    assert list(order).index(0) < list(order).index(2) < list(order).index(1)
    order, broken = topological(3, np.array([0, 1, 2]), np.array([1, 2, 0]), np.array([1.0, 0.0, 2.0]))
    assert broken == 1 and sorted(order) == [0, 1, 2] and order[0] == 1  # the nearest goes first


def test_topological_order_places_loosely_related_cells_by_depth():
    """A cell with no relation in front of it goes where its depth puts it, as in the centroid order,
    not into the first level of Kahn's sort (the jaw seen from above: a cell beside a face seen edge
    on, related to nothing across a gap, went out 657th of 454,288 cells, in front of the whole
    mesh, and float32 clipping gave it a piece 0.013 long far behind); and a cell behind a far one by a
    relation goes behind it whatever its own depth."""
    order, _ = topological(3, np.array([0]), np.array([1]), np.array([0.0, 1.0, 5.0]))
    assert list(order) == [0, 1, 2]  # was [0, 2, 1]: cell 2 in the first level
    order, _ = topological(3, np.array([0]), np.array([1]), np.array([5.0, 1.0, 3.0]))
    assert list(order) == [2, 0, 1]  # cell 1 takes cell 0's depth: behind the unrelated cell 2


RAMP_TF = [[-1.0, 0.2, 0.3, 0.9, 0.0], [2.0, 0.9, 0.3, 0.2, 0.6]]


@pytest.mark.parametrize("view", REFERENCE_VIEWS)
def test_shirley_tuchman_against_the_mesh_reference(pt, converged, view):
    """integration = "shirley-tuchman": colour and optical depth at the thick vertex (exact there),
    interpolated across the footprint's triangles.  On the jittered mesh (6x5x5 points) with a
    smooth ramp, measured RMS 5.3e-4 to 3.7e-3 against the reference (largest pixel 0.059: the
    interpolation of a colour and an optical depth that are not linear across the cell), where the
    exact integral is at 1e-7; bound 1e-2.  The band (a feature narrower than the cells) is what
    it cannot follow: 1.1e-2 to 3.5e-2 RMS, measured, not bounded here."""
    mesh = jittered_mesh(n=(6, 5, 5))
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "transfer_function.points": RAMP_TF,
                                "image.width": 64, "image.height": 48, **view})
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    image = pt.render(scene.with_renderer(integration="shirley-tuchman"))
    assert pt.stats["integration"] == "shirley-tuchman"
    assert truth[..., 3].max() > 0.3
    assert rms(image, truth) < 1e-2, rms(image, truth)


def test_shirley_tuchman_with_degenerate_cells(pt, converged):
    """Cells of no volume (four points in a plane: one seen face on, one edge on) and a cell with two
    vertices on one line of sight (an edge along the view, so two corners project to one point) draw
    nothing wrong: the flat ones nothing at all, the other its thickness along the edge; both
    variants against the reference (measured RMS 1.5e-8 exact, 3.3e-3 Shirley-Tuchman, whose
    interpolation is the whole of it; bound 1e-2)."""
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1],          # a regular cell
                       [0.2, 0.2, 0.5], [0.8, 0.2, 0.5], [0.2, 0.8, 0.5], [0.5, 0.5, 0.5],  # flat, face on
                       [0.1, 0.5, 0.1], [0.9, 0.5, 0.1], [0.1, 0.5, 0.9], [0.5, 0.5, 0.5],  # flat, edge on
                       ], float)
    tets = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]])
    mesh = TetMesh(points, tets, np.array([0.0, 1.0, 0.5, 0.8, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]),
                   name="degenerate")
    keys = {"renderer.name": "projected-tetrahedra", "transfer_function.points": RAMP_TF,
            "camera.projection": "orthographic", "camera.azimuth": 0.0, "camera.elevation": 90.0}
    scene = mesh_scene(mesh, **keys)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    for integration in ("exact", "shirley-tuchman"):
        image = pt.render(scene.with_renderer(integration=integration))
        assert np.all(np.isfinite(image))
        assert rms(image, truth) < 1e-2, (integration, rms(image, truth))


@pytest.mark.parametrize("tf, view", [
    (RAMP_TF, {"camera.azimuth": 30.0, "camera.elevation": 20.0}),
    (BAND_TF, {"camera.projection": "orthographic", "camera.azimuth": -50.0, "camera.elevation": 35.0}),
])
def test_the_host_fan_equals_the_geometry_shaders_fan(pt, tf, view, monkeypatch):
    """Shirley-Tuchman's fan built on the host in numba (fan_compiled.py, float64; ``host_fan = True``)
    and in pt.geom (float32; the default, and without numba) give the same picture: the same
    classes, thick vertices and integral, up to float32 rounding of the thick piece's ends and of the
    integral.  Measured on the ramp RMS 2e-7 to 3e-7, largest pixel 9e-6, against the picture's
    alpha up to 0.98 (its error against the reference, test above, is 5e-4 and more); bound RMS
    2e-6, largest 1e-4."""
    pytest.importorskip("numba")
    scene = mesh_scene(jittered_mesh(n=(6, 5, 5)), **{
        "renderer.name": "projected-tetrahedra", "renderer.integration": "shirley-tuchman",
        "transfer_function.points": tf, "image.width": 64, "image.height": 48, **view})
    monkeypatch.setattr(pt, "compute_fan", False)
    shader = pt.render(scene)
    assert pt.stats["fan"] == "geometry shader"
    pt.host_fan = True
    try:
        host = pt.render(scene)
        assert pt.stats["fan"] == "host"
    finally:
        pt.host_fan = False
    assert host[..., 3].max() > 0.3
    assert rms(host, shader) < 2e-6 and np.abs(host - shader).max() < 1e-4, (rms(host, shader),
                                                                                np.abs(host - shader).max())


@pytest.mark.parametrize("tf, view", [
    (RAMP_TF, {"camera.azimuth": 30.0, "camera.elevation": 20.0}),
    (BAND_TF, {"camera.projection": "orthographic", "camera.azimuth": -50.0, "camera.elevation": 35.0}),
])
def test_the_compute_shaders_fan_equals_the_geometry_shaders_fan(pt, tf, view, monkeypatch):
    """Shirley-Tuchman's fan built by pt_fan.comp (the default where GL 4.3 has compute shaders) and by
    pt.geom (the fallback) give the same picture: the same GLSL (pt_silhouette.glsl) for the classes and
    the thick vertex, and the same triangles vertex for vertex; the two stages are compiled apart, so
    float32 rounding may differ.  Measured on llvmpipe: RMS 2.3e-8 and 8.6e-8, largest pixel 1.1e-6 and
    3.5e-6 (equal to the bit on comb and the blunt fin at 256x256), against the reference error of 5e-4
    and more; bound RMS 5e-7, largest 2e-5.  Batched draws (the progress's) give the one draw's picture."""
    scene = mesh_scene(jittered_mesh(n=(6, 5, 5)), **{
        "renderer.name": "projected-tetrahedra", "renderer.integration": "shirley-tuchman",
        "transfer_function.points": tf, "image.width": 64, "image.height": 48, **view})
    computed = pt.render(scene)
    assert pt.stats["fan"] == "compute shader"  # the default
    monkeypatch.setattr(pt, "progress", lambda done, total: None)  # drawn in BATCHES calls
    batched = pt.render(scene)
    monkeypatch.setattr(pt, "progress", None)
    monkeypatch.setattr(pt, "compute_fan", False)
    shader = pt.render(scene)
    assert pt.stats["fan"] == "geometry shader"
    assert shader[..., 3].max() > 0.3
    assert np.array_equal(batched, computed)
    assert rms(computed, shader) < 5e-7 and np.abs(computed - shader).max() < 2e-5, (
        rms(computed, shader), np.abs(computed - shader).max())


def test_the_host_fan_falls_back_to_the_geometry_shader_without_numba(pt, monkeypatch):
    fan_compiled = "dvr_gl.renderers.projected_tetrahedra.fan_compiled"
    with monkeypatch.context() as m:  # without numba the compiled fan does not import ...
        m.setitem(sys.modules, "numba", None)
        m.delitem(sys.modules, fan_compiled, raising=False)
        assert fan.compiled() is None
    # ... and the frame draws the fan in pt.geom.  numba stays importable for the frame: the compiled
    # order (imported by an earlier test, never called) loads its cache through numba on its first call
    monkeypatch.setitem(sys.modules, fan_compiled, None)  # the import fails as it does without numba
    monkeypatch.setattr(pt, "host_fan", True)
    monkeypatch.setattr(pt, "compute_fan", False)
    scene = mesh_scene(jittered_mesh(), **{"renderer.name": "projected-tetrahedra",
                                           "renderer.integration": "shirley-tuchman", "image.width": 16,
                                           "image.height": 12})
    assert pt.render(scene)[..., 3].max() > 0.1
    assert pt.stats["fan"] == "geometry shader"


def test_shirley_tuchman_falls_back_to_the_exact_integral_inside_the_mesh(pt):
    mesh = jittered_mesh()
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "renderer.integration": "shirley-tuchman",
                                "camera.eye": [0.5, 0.4, 0.45], "camera.target": [1.5, 0.4, 0.45]})
    pt.render(scene)
    assert pt.stats["integration"] == "exact"


@pytest.mark.parametrize("camera", [
    Camera(eye=(2.5, 1.9, 2.2), target=(0.5, 0.4, 0.45), up=(0.0, 0.0, 1.0), fov=40.0),
    Camera(eye=(0.5, 0.4, 0.45), target=(1.5, 0.4, 0.45), up=(0.0, 0.0, 1.0), fov=60.0),  # inside the mesh
    Camera(eye=(0.5, 0.4, 5.0), target=(0.5, 0.4, 0.0), up=(0.0, 1.0, 0.0), projection="orthographic",
           view_height=1.2),  # along an axis: faces seen edge on
])
def test_the_compiled_order_equals_the_numpy_order(camera):
    """The numba loops (order_compiled.py) give the numpy code's order, cell for cell, with the same
    relations counted; a non-convex mesh (a block cut out) so that boundary relations count too, the
    compiled boundary hits giving numpy's relations in numpy's order."""
    pytest.importorskip("numba")
    mesh = jittered_mesh(n=(7, 6, 5))
    centroids = mesh.points[mesh.tets].mean(axis=1)
    keep = ~((centroids[:, 0] > 0.3) & (centroids[:, 0] < 0.7) & (centroids[:, 2] > 0.4))
    mesh = TetMesh(mesh.points, mesh.tets[keep], mesh.values, name="notched")
    fast, slow = VisibilityOrder(mesh), VisibilityOrder(mesh, compiled_loops=False)
    (a, sa), (b, sb) = fast(camera, 24, 20), slow(camera, 24, 20)
    assert sa["compiled"] and not sb["compiled"]
    assert np.array_equal(a, b)
    for key in ("face_relations", "boundary_relations", "edge_on_faces", "rays_cast", "cycles_broken"):
        assert sa[key] == sb[key], key
    assert sa["boundary_relations"] > 0
    (a, sa), (b, sb) = fast(camera, 24, 20, "centroid"), slow(camera, 24, 20, "centroid")
    assert sa["compiled"] and not sb["compiled"] and np.array_equal(a, b)  # the radix sort: numpy's stable order
    rays = o_d_t(camera, 24, 20, None)
    for got, want in zip(boundary_relations(fast.adjacency, *rays, fast=fast.fast),
                         boundary_relations(slow.adjacency, *rays)):
        assert np.array_equal(got, want)


def test_the_compiled_sort_equals_the_numpy_sort_with_cycles_and_repeats():
    """Random relations (cycles, repeated relations, ties of depth): the compiled Kahn's sort gives
    the numpy sort's order and cycle count; its radix sort is numpy's stable argsort, its centroid
    distances numpy's norms."""
    pytest.importorskip("numba")
    fast = compiled()
    rng = np.random.default_rng(3)
    n = 300
    front, back = rng.integers(0, n, 900), rng.integers(0, n, 900)
    keep = front != back
    front, back = np.r_[front[keep], front[:50]], np.r_[back[keep], back[:50]]
    depth = rng.integers(0, 40, n).astype(float) - 20.0  # ties, negatives, both zeros
    depth[:3] = -0.0
    none = np.zeros((0, 2), np.int64)
    order, broken = fast.exact_order(n, none, np.zeros(0, np.int64), front, back, depth)
    expected, expected_broken = topological(n, front, back, depth)
    assert broken == expected_broken > 0
    assert np.array_equal(order, expected)
    values = rng.normal(size=1000) * 10.0 ** rng.integers(-300, 300, 1000)
    assert np.array_equal(fast.stable_argsort(values), np.argsort(values, kind="stable"))
    points, eye = rng.normal(size=(1000, 3)) * 1e3, np.array([0.3, -7.0, 2e3])
    assert np.array_equal(fast.distances(points, eye), np.linalg.norm(points - eye, axis=1))  # bit for bit


@pytest.mark.parametrize("loops", ["compiled", "numpy"])
def test_the_renumbered_sort_gives_the_order_of_the_mesh_numbering(loops):
    """Random relations (cycles, repeats, ties of depth) on cells renumbered at random: the sort on the
    new numbers, ties by the original ones, gives the original numbering's order and cycle count."""
    rng = np.random.default_rng(5)
    n = 300
    front, back = rng.integers(0, n, 900), rng.integers(0, n, 900)
    keep = front != back
    front, back = front[keep], back[keep]
    depth = rng.integers(0, 40, n).astype(float)
    original = rng.permutation(n)
    rank = np.argsort(original)
    if loops == "compiled":
        fast = pytest.importorskip("dvr_gl.renderers.projected_tetrahedra.order_compiled")
        none = np.zeros((0, 2), np.int64)
        sort = functools.partial(fast.exact_order, n, none, np.zeros(0, np.int64))
    else:
        sort = functools.partial(topological, n)
    expected, expected_broken = sort(front, back, depth)
    order, broken = sort(rank[front], rank[back], depth[original], original)
    assert broken == expected_broken > 0
    assert np.array_equal(order, expected)


@pytest.mark.parametrize("compiled_loops", [True, False])
def test_the_order_on_cells_renumbered_for_locality_is_the_same(compiled_loops):
    """The per-view loops on the cells renumbered along a Morton curve (VisibilityOrder.renumber) give
    the order on the mesh's own numbering, cell for cell, with the same counts; a mesh whose cells
    are shuffled (so the renumbering moves them all) and cut (relations across a gap), seen in
    perspective and along an axis (faces edge on)."""
    if compiled_loops:
        pytest.importorskip("numba")
    mesh = jittered_mesh(n=(7, 6, 5))
    centroids = mesh.points[mesh.tets].mean(axis=1)
    keep = ~((centroids[:, 0] > 0.3) & (centroids[:, 0] < 0.7) & (centroids[:, 2] > 0.4))
    tets = mesh.tets[keep][np.random.default_rng(1).permutation(int(keep.sum()))]
    mesh = TetMesh(mesh.points, tets, mesh.values, name="shuffled")
    for camera in (Camera(eye=(2.5, 1.9, 2.2), target=(0.5, 0.4, 0.45), up=(0.0, 0.0, 1.0), fov=40.0),
                   Camera(eye=(0.5, 0.4, 5.0), target=(0.5, 0.4, 0.0), up=(0.0, 1.0, 0.0),
                          projection="orthographic", view_height=1.2)):
        local, plain = VisibilityOrder(mesh, compiled_loops), VisibilityOrder(mesh, compiled_loops)
        local.renumber, plain.renumber = True, False
        (a, sa), (b, sb) = local(camera, 24, 20), plain(camera, 24, 20)
        assert sa["renumbered"] and not sb["renumbered"]
        assert not np.array_equal(local.renumbered.cells, np.arange(len(tets)))
        assert np.array_equal(a, b)
        for key in ("face_relations", "boundary_relations", "edge_on_faces", "cycles_broken"):
            assert sa[key] == sb[key], key
        assert sa["boundary_relations"] > 0


def test_a_numbering_is_scattered_where_most_faces_join_far_cells():
    """Renumbering is chosen where more than half the interior faces join cells over NEAR_CELLS apart."""
    far, near = [0, NEAR_CELLS + 1], [5, 6]
    assert scattered(SimpleNamespace(pairs=np.array([far, far, near])))
    assert not scattered(SimpleNamespace(pairs=np.array([far, near, near])))
    assert not scattered(SimpleNamespace(pairs=np.zeros((0, 2), np.int64)))
    assert np.array_equal(locality_order(np.array([[1.0, 1, 1], [0, 0, 0], [1, 0, 0], [0, 1, 0]])), [1, 2, 3, 0])


def test_the_order_falls_back_to_numpy_without_numba(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba", None)
    monkeypatch.setitem(sys.modules, "dvr_gl.renderers.projected_tetrahedra.order_compiled", None)
    assert compiled() is None
    _, stats = VisibilityOrder(jittered_mesh())(Camera(eye=(2.5, 1.9, 2.2), target=(0.5, 0.4, 0.45)), 8, 8)
    assert not stats["compiled"]


@pytest.mark.skipif(not (SHARED_DATA / "unstructured").is_dir(), reason="the shared datasets are absent")
def test_the_jaw_from_above_in_the_exact_order(pt, converged):
    """Real data where whole lines of rays lie in face planes through the eye: the exact order is no
    worse than the centroid order (RMS 1.79e-6 against 1.89e-6 here; it was 1.8e-5, three pixels off
    by up to 3.3e-3, before cells were placed by depth in the sort), largest pixel error 3.1e-4,
    bound 1e-3 (the float32 clipping's rounding in those planes, the same in the centroid order)."""
    pytest.importorskip("meshio")
    from dvr_gl.bench.datasets import MESHES
    from dvr_gl.bench.datasets import mesh_scene_keys as scene_keys

    source, array = MESHES["jaw"]
    path = SHARED_DATA / source
    mesh = load_scene(None, {"volume.path": str(path)}).field
    scene = load_scene(None, {**scene_keys(path, array, mesh), "camera.azimuth": 0.0, "camera.elevation": 90.0,
                              "image.width": 128, "image.height": 128})
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    exact = pt.render(scene.with_renderer(cell_order="exact"))
    centroid = pt.render(scene.with_renderer(cell_order="centroid"))
    assert truth[..., 3].max() > 0.3
    assert rms(exact, truth) <= rms(centroid, truth), (rms(exact, truth), rms(centroid, truth))
    assert np.abs(exact - truth).max() < 1e-3


@pytest.mark.parametrize("mode", ["mip", "minip", "average", "isosurface"])
def test_projections_match_the_mesh_reference(pt, converged, mode):
    mesh = jittered_mesh()
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra", "renderer.compositing": mode,
                                "renderer.iso_value": 0.6, "camera.azimuth": 40.0, "camera.elevation": 25.0})
    image = pt.render(scene)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert truth[..., 3].max() > 0.3
    # float32 values and planes against float64: measured RMS 6e-7 (MIP) to 3e-6 (average), the
    # isosurface exact (its colour is the iso-value's; a grazing ray could flip, none here)
    assert rms(image, truth) < 1e-5, rms(image, truth)


def test_the_cli_and_the_viewer_take_a_mesh(tmp_path):
    """``dvr render --volume mesh.vtu`` renders with projected-tetrahedra (the default for a mesh); the
    viewer runs it under Xvfb and its benchmark line describes the mesh."""
    import subprocess
    import sys

    from dvr_gl.image import read_image
    from xvfb import xvfb_display

    scene = mesh_scene(jittered_mesh((3, 3, 3)))
    volume = scene.volume_source.path
    out = tmp_path / "mesh.exr"
    cli = [sys.executable, "-m", "dvr_gl.apps.cli"]
    done = subprocess.run([*cli, "render", "--volume", volume, "--size", "32", "-o", str(out)], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "projected-tetrahedra" in done.stdout and read_image(out)[..., 3].max() > 0.1
    with xvfb_display() as display:
        view = subprocess.run([*cli, "view", "--volume", volume, "--size", "48x48", "--no-gui", "--benchmark", "0.3"],
                              capture_output=True, text=True, timeout=300, env={**__import__("os").environ,
                                                                                "DISPLAY": display})
    assert view.returncode == 0, view.stderr
    assert "tetrahedra, projected-tetrahedra" in view.stdout
    # --resample N: the mesh on a grid, drawn by the grid renderers (the ray caster by default)
    grid = tmp_path / "resampled.exr"
    done = subprocess.run([*cli, "render", "--volume", volume, "--resample", "16", "--size", "32", "-o", str(grid)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert registry.default_for("grid") in done.stdout and read_image(grid)[..., 3].max() > 0.1


def test_the_tradeoff_bench_sweeps_a_mesh_through_the_registry():
    """``dvr bench tradeoff`` on a mesh scene: only the renderers of meshes are swept (their declared
    families: the cell order, cell-raycast's early termination), against the converged reference; the
    ray caster's tolerance check is left out with a note."""
    from dvr_gl.bench import tradeoff

    scene = mesh_scene(jittered_mesh(), **{"image.width": 24, "image.height": 24})
    rows, notes = tradeoff.run(scene, repeat=1)
    assert {(r["renderer"], r["setting"]) for r in rows} >= {("projected-tetrahedra", "centroid"),
                                                             ("projected-tetrahedra", "exact")}
    assert {r["renderer"] for r in rows} == set(renderers(kind="mesh", gl=True))
    exact = next(r for r in rows if r["setting"] == "exact")
    assert exact["rms"] < 1e-4 and exact["rms"] <= next(r for r in rows if r["setting"] == "centroid")["rms"]
    checks, note = tradeoff.tolerance_check(scene, rows, None)
    assert not checks and "renders grids, not mesh" in note


def test_the_cells_bench_sums_up_each_case_against_vtk():
    """``dvr bench cells``' lines under the table: per dvr-gl case, the views where it is at least as fast as
    VTK, the range of VTK ms / ms and of VTK's RMS over the case's; cases not timed beside VTK left out."""
    from dvr_gl.renderers.projected_tetrahedra.bench.measure import against_vtk

    row = lambda mesh, view, renderer, rms, vs=None: {"mesh": mesh, "view": view, "renderer": renderer,  # noqa: E731
                                                      "rms": rms, "vs_vtk": vs}
    rows = [row("a", "30/20", "dvr-gl st", 1e-3, 0.9), row("a", "30/20", "vtk-pt 9", 2e-2),
            row("a", "0/90", "dvr-gl st", 4e-3, 1.0), row("a", "0/90", "vtk-pt 9", 2e-2),
            row("b", "0/90", "dvr-gl st", 2e-3, 1.5), row("b", "0/90", "dvr-gl cell-raycast", 1e-7),
            row("b", "0/90", "vtk-pt 9", 1e-2)]
    assert against_vtk(rows) == ["dvr-gl st: at least as fast as VTK on 2 of 3 views (0.90-1.50x), "
                                 "VTK's RMS 5-20x its own"]
    assert against_vtk([r for r in rows if r["renderer"] != "dvr-gl st"]) == []


def test_dvr_bench_cells(tmp_path, monkeypatch, capsys):
    """The bench on a mesh of its own: per view, the exact and the centroid order (Shirley-Tuchman in each
    too) with their times and errors against the reference (the exact one at float32 level), VTK listed as
    absent when the peers' interpreter lacks it; bad arguments are one line."""
    from dvr_gl.apps.cli import main
    from dvr_gl.renderers.projected_tetrahedra.bench import measure as cells

    meshio = pytest.importorskip("meshio", reason="meshes are read with meshio (pip install 'dvr-gl[mesh]')")
    mesh = jittered_mesh()
    (tmp_path / "unstructured").mkdir()
    meshio.write(str(tmp_path / "unstructured" / "tiny.vtu"),
                 meshio.Mesh(mesh.points, [("tetra", mesh.tets)], point_data={"s": mesh.values}))
    monkeypatch.setattr(cells, "MESHES", {"tiny": ("unstructured/tiny.vtu", None)})
    monkeypatch.setattr(cells, "RESAMPLE", 24)
    base = ["bench", "cells", "--data-dir", str(tmp_path), "--size", "32", "--error-size", "24", "--frames", "1"]
    assert main(base + ["--meshes", "nope"]) == 1
    assert "--meshes: unknown nope" in capsys.readouterr().err
    assert main(base + ["--pictures", str(tmp_path / "absent")]) == 1
    assert "no such folder for the pictures" in capsys.readouterr().err
    assert main(base + ["--peers-python", sys.executable, "--pictures", str(tmp_path)]) == 0  # no VTK there
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("tiny ") and ":" not in line]  # the table
    assert [(r[1], r[2], r[3]) for r in rows] == [(v, *w) for v in ("30/20", "120/-10", "0/90")
                                                  for w in (("dvr-gl", "exact"), ("dvr-gl", "shirley-tuchman"),
                                                            ("dvr-gl", "centroid"),
                                                            ("dvr-gl", "shirley-tuchman"),  # VTK's order: centroid
                                                            ("dvr-gl", WALKER), (f"{GRID},", "resampled"))]
    assert sum(r[3:5] == ["shirley-tuchman", "centroid"] for r in rows) == 3
    # RMS against the reference (then VTK ms / ms, "-" without VTK, and the cycles broken)
    assert all(float(r[-3]) < 1e-4 for r in rows if r[3] == "exact"), rows
    # Shirley-Tuchman on this mesh of 144 large cells: measured 1.6e-2 to 2.1e-2
    assert all(float(r[-3]) < 5e-2 for r in rows if r[3] == "shirley-tuchman" and r[4] != "centroid"), rows
    # in the centroid order too (no cycles column): the fan's own error is larger than the order's (1e-3 here)
    assert all(float(r[-2]) < 5e-2 for r in rows if r[3:5] == ["shirley-tuchman", "centroid"]), rows
    # cell-raycast at its defaults: early termination drops at most 1/255 where a ray gets that opaque
    assert all(float(r[-2]) < 1e-3 for r in rows if r[3] == WALKER), rows  # (no cycles column)
    # resampling: its own error (no cycles column)
    assert all(1e-4 < float(r[-2]) < 0.05 for r in rows if r[2] == f"{GRID},"), rows
    assert "vtk-pt: not installed" in out
    from dvr_gl.image import read_image

    # reference, dvr-gl exact and shirley-tuchman, cell-raycast, resampled; 5x their errors
    sheet = read_image(tmp_path / "cells-tiny.png")
    assert sheet.shape[:2] == (48, 120)



def test_vtk_frames_interleave_with_the_bench(tmp_path):
    """dvr bench cells takes VTK's frames one at a time from a process of the peers' environment kept
    open (vtk_frames.py), in turn with dvr-gl's; without VTK there it says so and gives no frames.
    VTK's own frames run where the peers' environment has it (skipped elsewhere)."""
    from dvr_gl.bench.peers import default_peers_python
    from dvr_gl.renderers.projected_tetrahedra.bench import measure as cells

    mesh = jittered_mesh()
    scene = mesh_scene(mesh, **{"renderer.name": "projected-tetrahedra"})
    vtu = tmp_path / "tiny.vtu"
    cells.write_vtu(mesh, vtu)
    absent = cells._VtkFrames(sys.executable, cells._vtk_scene(scene, vtu), 32, tmp_path / "absent")
    absent.close()
    assert absent.failed and "did not start" in absent.failed and absent.frame() is None
    python = default_peers_python()
    if python is None or not cells.peers.available(python, ["vtk-pt"])[0]:
        pytest.skip("no VTK in a peers environment (.venv-peers: see docs/peers.md)")
    vtk = cells._VtkFrames(python, cells._vtk_scene(scene, vtu), 32, tmp_path / "vtk")
    try:
        assert vtk.failed is None
        seconds = [vtk.frame(), vtk.frame()]
    finally:
        vtk.close()
    assert all(0 < t < 60 for t in seconds), seconds

def test_a_resampled_mesh_renders_with_the_grid_renderers():
    """The mesh resampled onto a grid renders with the ray caster; its error against the mesh
    reference falls with the resolution (measured RMS 9.1e-3 at 16, 2.2e-3 at 64 samples along the
    longest axis on this mesh and band transfer function)."""
    from dvr_gl.fields.mesh_resample import resampled_scene

    scene = mesh_scene(jittered_mesh(), **{"renderer.name": "projected-tetrahedra"})
    truth = create_renderer(CONVERGED).render(scene.with_renderer(name=CONVERGED))
    with create_renderer(GRID) as grid:
        errors = [rms(grid.render(resampled_scene(scene, n, name=GRID, sample_distance_voxels=0.25)), truth)
                  for n in (16, 64)]
    assert errors[1] < errors[0] / 3 and errors[1] < 5e-3, errors


def test_volume_resample_in_a_scene():
    """``volume.resample`` loads the mesh as a grid (its outside below the scalar's range, the transfer
    function transparent there); on a grid file, or a demo, it is refused in one line."""
    scene = mesh_scene(jittered_mesh(), **{"volume.resample": 24})
    field = scene.field
    assert field.kind == "grid" and max(field.dims) == 24
    tf, given = scene.transfer_function, load_scene(None, {"transfer_function.points": BAND_TF,
                                                           "volume.demo": "blobs"}).transfer_function
    lo, hi = field.outside_value, field.inside_value
    assert lo < hi == min(jittered_mesh().values)
    assert tf.opacity([lo - 1.0, lo])[1] == 0.0 and tf.opacity([lo - 1.0])[0] == 0.0  # no material outside
    inside = np.linspace(hi, 2.5, 50)  # the given transfer function over the mesh's values
    assert np.allclose(tf.opacity(inside), given.opacity(inside)) and np.allclose(tf.color(inside), given.color(inside))
    assert scene.renderer.name == GRID
    with pytest.raises(SceneError, match="volume.resample applies to meshes"):
        load_scene(None, {"volume.path": str(_grid_file()), "volume.resample": 24})
    with pytest.raises(SceneError, match="volume.resample"):
        load_scene(None, {"volume.demo": "blobs", "volume.resample": 24})
    with pytest.raises(SceneError, match=r"volume.resample must be in \[2, 1024\]"):
        mesh_scene(jittered_mesh(), **{"volume.resample": 5000})


def _grid_file() -> Path:
    path = Path(tempfile.mkdtemp(prefix="dvr-grid-")) / "grid.npy"
    np.save(path, np.zeros((4, 4, 4), np.float32))
    return path


def test_projected_tetrahedra_estimates_its_work_and_reports_progress(monkeypatch):
    """Issue 40: 4096^2 of the oxygen post ran 95 s with no estimate and no progress.  The work is
    pixels x fragments (a multiple of the cube root of the cells); the frame is drawn in batches, in
    order, each reported (progress, and the time limit between them), and the picture is unchanged."""
    import dvr_gl.renderers.projected_tetrahedra.renderer as pt
    from dvr_gl import limits
    from dvr_gl.errors import DvrError

    scene = mesh_scene(jittered_mesh(), **REFERENCE_VIEWS[0])
    with create_renderer("projected-tetrahedra") as renderer:
        work = renderer.work(scene)
        assert work.unit == "gpu samples" and work.count == pytest.approx(
            scene.image.width * scene.image.height * pt.FRAGMENTS_PER_CUBE_ROOT * len(scene.field.tets) ** (1 / 3))
        whole = renderer.render(scene)
        steps = []
        renderer.progress = lambda done, total: steps.append((done, total))
        monkeypatch.setattr(pt, "BATCHES", 3)
        np.testing.assert_array_equal(renderer.render(scene), whole)
        assert len(steps) == 3 and steps[-1][0] == steps[-1][1]
        monkeypatch.setitem(limits.BOUNDS, "gpu samples", work.count / 2)
        with pytest.raises(DvrError, match=r"projected-tetrahedra would take .* gpu samples .*fragment samples for"):
            renderer.render(scene)


@pytest.mark.parametrize("height", list(SPHERE_HEIGHTS.values()), ids=list(SPHERE_HEIGHTS))
def test_sphere_in_front_of_and_inside_a_slab(tmp_path, gl_context, height):
    """tests/slab_scenes.py's sphere in or above the slab meshed into tetrahedra: float32, every clear pixel
    within 2e-6 of the true and inscribed spheres' forms."""
    keys = {"renderer.geometry": sphere_geometry(tmp_path, height), **SPHERE_KEYS}
    scene = mesh_scene(slab_mesh(), **slab_keys("projected-tetrahedra", **keys))
    with registry.plugin("projected-tetrahedra").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_within_sphere_bounds(image, scene, height, 2e-6)


def test_face_neighbours():
    """The cell across face k (opposite vertex k) of each cell, -1 on the boundary: two tetrahedra
    sharing a face, and the neighbours symmetric on a real split; the boundary faces from them, as the
    visibility order's adjacency finds them (the cell walk's boundary and this renderer's are one)."""
    tets = np.array([[0, 1, 2, 3], [4, 1, 2, 3]])
    assert face_neighbours(tets).tolist() == [[1, -1, -1, -1], [0, -1, -1, -1]]
    mesh = jittered_mesh()
    nb = face_neighbours(mesh.tets)
    cell, face = np.nonzero(nb >= 0)
    back = nb[nb[cell, face]]
    assert np.all(np.any(back == cell[:, None], axis=1))
    # 3x2x2 hexahedra: boundary quads 2 (2x2) + 2 (3x2) + 2 (3x2), two triangles each
    assert (nb < 0).sum() == 2 * (2 * 4 + 2 * 6 + 2 * 6)
    # the boundary from them: the visibility order's boundary faces, normals pointing out of their cells
    cell, corners, normal = boundary_faces(mesh.points, mesh.tets, nb)
    adj = adjacency(mesh.points, mesh.tets)
    key = lambda c, pts: sorted(zip(c.tolist(), np.round(np.sort(pts.reshape(len(c), -1), axis=1), 9).tolist()))  # noqa: E731
    assert key(cell, corners) == key(adj.boundary_cell, adj.boundary_corners)
    centroid = mesh.points[mesh.tets[cell]].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", normal, corners[:, 0] - centroid) > 0)
