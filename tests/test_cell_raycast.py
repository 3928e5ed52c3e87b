"""Ray casting from cell to cell (``cell-raycast``) against the float64 mesh reference: a
transfer-function feature inside cells from oblique and axis-aligned views, the camera inside the
mesh, rays that leave and enter the mesh more often than the walk sorts at once and than the list
nodes first reserved, and the walk's own accounting.  (The closed forms on meshes, every mode, run
in tests/test_conformance.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.errors import SceneError
from dvr_gl.fields.mesh import TetMesh
from dvr_gl.fields.mesh_cells import hexahedra_of_grid, tetrahedralize
from dvr_gl.fields.mesh_rays import face_neighbours
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.cell_raycast import renderer as walk_module
from test_projected_tetrahedra import jittered_mesh, mesh_scene, rms


@pytest.fixture(scope="module")
def walker():
    r = create_renderer("cell-raycast")
    yield r
    r.close()


@pytest.fixture(scope="module")
def converged():
    return create_renderer("reference-converged")


def exact(scene):
    """No early termination: the image to compare with the reference at float32 level."""
    return scene.with_renderer(name="cell-raycast", ert_threshold=1.0)


@pytest.mark.parametrize("view", [
    {"camera.azimuth": 30.0, "camera.elevation": 20.0},
    {"camera.azimuth": 0.0, "camera.elevation": 0.0},             # along an axis: faces seen edge on
    {"camera.projection": "orthographic", "camera.azimuth": 90.0, "camera.elevation": 0.0},
    {"camera.projection": "orthographic", "camera.azimuth": -50.0, "camera.elevation": 35.0},
])
def test_emission_absorption_matches_the_mesh_reference(walker, converged, view):
    """Each piece integrates the exact transfer function (the band inside the cells is there) and the
    walk finds every piece along every ray, seen along an axis too.  Measured RMS 1.6e-5 to 2.1e-5
    (float32 planes and values, as projected tetrahedra); bound 1e-4.  No walk is given up."""
    scene = mesh_scene(jittered_mesh(), **view)
    image = walker.render(exact(scene))
    truth = converged.render(scene.with_renderer(name="reference-converged"))
    assert truth[..., 3].max() > 0.3
    assert rms(image, truth) < 1e-4, rms(image, truth)
    stats = walker.walk_stats(exact(scene))
    assert stats[..., 2].sum() == 0, "walks given up"
    assert stats[..., 1].max() >= 1 and walker.stats["start_cells"] is False


def test_early_termination_drops_at_most_what_it_promises(walker, converged):
    """The default threshold (1 - 1/255) stops a ray once that opaque: what it leaves out of a pixel is
    at most 1/255 of a channel, and nothing where rays stay below it."""
    scene = mesh_scene(jittered_mesh(), **{"camera.azimuth": 30.0, "camera.elevation": 20.0,
                                           "transfer_function.unit_distance": 0.02})
    truth = converged.render(scene.with_renderer(name="reference-converged"))
    image = walker.render(scene.with_renderer(name="cell-raycast"))
    assert truth[..., 3].max() > 0.999, "some rays reach the threshold"
    error = np.abs(image.astype(float) - truth).max(axis=2)
    assert error.max() < 1.0 / 255.0 + 1e-4
    assert error[truth[..., 3] < 0.99].max() < 1e-3


@pytest.mark.parametrize("lens", [{"camera.fov": 70.0},
                                  {"camera.projection": "orthographic", "camera.view_height": 0.6}])
def test_camera_inside_the_mesh(walker, converged, lens):
    """The eye inside a cell: each ray's first cell is located on the host (no boundary face is
    entered there) and walked from the near plane; the picture is the reference's."""
    keys = {"camera.eye": [0.45, 0.35, 0.4], "camera.target": [1.0, 0.8, 0.9], "camera.up": [0, 0, 1], **lens}
    scene = mesh_scene(jittered_mesh(), **keys)
    image = walker.render(exact(scene))
    assert walker.stats["start_cells"] is True
    truth = converged.render(scene.with_renderer(name="reference-converged"))
    assert truth[..., 3].min() > 0.05, "every ray starts inside"
    assert rms(image, truth) < 1e-4, rms(image, truth)


def slabs(count=40, gap=0.02, thickness=0.01):
    """``count`` separate slabs (one hexahedron each, split into tetrahedra) stacked along z: a ray
    along z enters the mesh ``count`` times."""
    points, hexes = [], []
    base = hexahedra_of_grid(2, 2, 2)
    for i in range(count):
        z0 = i * gap
        for z in (z0, z0 + thickness):
            for y in (0.0, 0.5):
                for x in (0.0, 0.5):
                    points.append((x, y, z))
        hexes.append(base + 8 * i)
    p = np.array(points)
    values = p[:, 0] + p[:, 2]
    pts, tets, _, v = tetrahedralize(p, [("hexahedron", np.concatenate(hexes))], values)
    return TetMesh(pts, tets, v, name="slabs")


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_rays_entering_many_times(walker, converged, monkeypatch, projection):
    """40 re-entries along each ray: more than the walk sorts in one round (16) and than the list nodes
    first reserved (4 a pixel, so the lists are drawn again with room enough); every slab counts."""
    monkeypatch.setattr(walk_module, "FIRST_NODES_PER_PIXEL", 4)
    walker._nodes = None  # reserve again, at the patched size
    tf = [[0.0, 0.9, 0.6, 0.2, 0.05], [1.3, 0.2, 0.5, 0.9, 0.1]]
    keys = {"camera.eye": [0.25, 0.25, -0.5], "camera.target": [0.25, 0.25, 0.5], "camera.up": [0, 1, 0],
            "camera.projection": projection, "camera.fov": 10.0, "camera.view_height": 0.3,
            "transfer_function.points": tf, "transfer_function.unit_distance": 0.01}
    scene = mesh_scene(slabs(), **keys)
    image = walker.render(exact(scene))
    w, h = scene.image.width, scene.image.height
    assert walker.stats["entries"] > 4 * w * h, "the first lists overflowed"
    truth = converged.render(scene.with_renderer(name="reference-converged"))
    assert rms(image, truth) < 1e-5, rms(image, truth)
    walks = walker.walk_stats(exact(scene))[..., 1]
    assert walks.max() >= 40


def test_face_neighbours():
    """The cell across face k (opposite vertex k) of each cell, -1 on the boundary: two tetrahedra
    sharing a face, and the neighbours symmetric on a real split."""
    tets = np.array([[0, 1, 2, 3], [4, 1, 2, 3]])
    assert face_neighbours(tets).tolist() == [[1, -1, -1, -1], [0, -1, -1, -1]]
    mesh = jittered_mesh()
    nb = face_neighbours(mesh.tets)
    cell, face = np.nonzero(nb >= 0)
    back = nb[nb[cell, face]]
    assert np.all(np.any(back == cell[:, None], axis=1))
    # 3x2x2 hexahedra: boundary quads 2 (2x2) + 2 (3x2) + 2 (3x2), two triangles each
    assert (nb < 0).sum() == 2 * (2 * 4 + 2 * 6 + 2 * 6)


def test_too_many_transfer_function_points_are_refused(walker):
    """As projected tetrahedra: the control points live in the fragment shader's uniforms."""
    n = walker.max_tf_points() + 1
    points = [[float(v), 0.5, 0.5, 0.5, 0.3] for v in np.linspace(-1.0, 2.0, n)]
    scene = mesh_scene(jittered_mesh(), **{"renderer.name": "cell-raycast", "transfer_function.points": points})
    with pytest.raises(SceneError, match=r"transfer_function.points: .* at most \d+"):
        walker.render(scene)
