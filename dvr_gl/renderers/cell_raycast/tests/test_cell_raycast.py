"""Ray casting from cell to cell (``cell-raycast``) against the float64 mesh reference: a
transfer-function feature inside cells from oblique and axis-aligned views, the camera inside the
mesh, rays that leave and enter the mesh more often than the walk sorts at once and than the list
nodes first reserved, and the walk's own accounting.  (The closed forms on meshes, every mode, run
in tests/renderers/test_conformance.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import SHARED_DATA
from dvr_gl.errors import SceneError
from dvr_gl.fields.mesh import TetMesh
from dvr_gl.fields.mesh_cells import hexahedra_of_grid, tetrahedralize
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.renderers.cell_raycast import renderer as walk_module
from judges import CONVERGED, renderers
from mesh_inputs import REFERENCE_VIEWS, jittered_mesh, mesh_scene, rms

# the GL renderer of meshes that sorts its cells and projects them (the walk's comparison: the same pieces)
SORTED = renderers("cell_order", kind="mesh", gl=True)[0]

needs_data = pytest.mark.skipif(not (SHARED_DATA / "unstructured").is_dir(),
                                reason=f"{SHARED_DATA / 'unstructured'} is absent (shared datasets)")


@pytest.fixture(scope="module")
def walker():
    r = create_renderer("cell-raycast")
    yield r
    r.close()


def exact(scene):
    """No early termination: the image to compare with the reference at float32 level."""
    return scene.with_renderer(name="cell-raycast", ert_threshold=1.0)


@pytest.mark.parametrize("view", REFERENCE_VIEWS)
def test_emission_absorption_matches_the_mesh_reference(walker, converged, view):
    """Each piece integrates the exact transfer function (the band inside the cells is there) and the
    walk finds every piece along every ray, seen along an axis too.  Measured RMS 2.3e-5 to 2.7e-5
    (float32 planes and values, as projected tetrahedra); bound 1e-4.  No walk is given up."""
    scene = mesh_scene(jittered_mesh(), **view)
    image = walker.render(exact(scene))
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert truth[..., 3].max() > 0.3
    assert rms(image, truth) < 1e-4, rms(image, truth)
    stats = walker.walk_stats(exact(scene))
    assert stats[..., 2].sum() == 0, "walks given up"
    assert stats[..., 1].max() >= 1 and walker.stats["start_cells"] is False


def test_early_termination_drops_at_most_what_it_promises(walker, converged):
    """The default threshold (1 - 1/255) stops a ray once that opaque: what it leaves out of a pixel is
    at most 1/255 of a channel (measured 3.9e-3), and nothing where rays stay below it (measured
    2.2e-5 there, float32 as in the other tests; bound 1e-3)."""
    scene = mesh_scene(jittered_mesh(), **{"camera.azimuth": 30.0, "camera.elevation": 20.0,
                                           "transfer_function.unit_distance": 0.02})
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    image = walker.render(scene.with_renderer(name="cell-raycast"))
    assert truth[..., 3].max() > 0.999, "some rays reach the threshold"
    error = np.abs(image.astype(float) - truth).max(axis=2)
    assert error.max() < 1.0 / 255.0 + 1e-4
    assert error[truth[..., 3] < 0.99].max() < 1e-3


@pytest.mark.parametrize("lens", [{"camera.fov": 70.0},
                                  {"camera.projection": "orthographic", "camera.view_height": 0.6}])
def test_camera_inside_the_mesh(walker, converged, lens):
    """The eye inside a cell: each ray's first cell is located on the host (no boundary face is
    entered there) and walked from the near plane; the picture is the reference's (measured RMS 2e-7
    perspective, 9e-6 orthographic; bound 1e-4 as above)."""
    keys = {"camera.eye": [0.45, 0.35, 0.4], "camera.target": [1.0, 0.8, 0.9], "camera.up": [0, 0, 1], **lens}
    scene = mesh_scene(jittered_mesh(), **keys)
    image = walker.render(exact(scene))
    assert walker.stats["start_cells"] is True
    truth = converged.render(scene.with_renderer(name=CONVERGED))
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
    first reserved (4 a pixel here, so the lists are drawn again with room enough); every slab counts
    (measured RMS 1.1-1.2e-6; bound 1e-5: one slab left out is 1e-3 or more)."""
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
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert rms(image, truth) < 1e-5, rms(image, truth)
    walks = walker.walk_stats(exact(scene))[..., 1]
    assert walks.max() >= 40


def test_too_many_transfer_function_points_are_refused(walker):
    """As projected tetrahedra: the control points live in the fragment shader's uniforms."""
    n = walker.max_tf_points() + 1
    points = [[float(v), 0.5, 0.5, 0.5, 0.3] for v in np.linspace(-1.0, 2.0, n)]
    scene = mesh_scene(jittered_mesh(), **{"renderer.name": "cell-raycast", "transfer_function.points": points})
    with pytest.raises(SceneError, match=r"transfer_function.points: .* at most \d+"):
        walker.render(scene)


def grid_mesh(n=4, size=1.0):
    """A regular box of hexahedra split into tetrahedra (no jitter: the faces' diagonals line up),
    with a smooth point scalar."""
    axes = np.linspace(0.0, size, n)
    z, y, x = np.meshgrid(axes, axes, axes, indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    values = np.sin(3.0 * p[:, 0]) + p[:, 1] * p[:, 2] * 2.0
    points, tets, _, v = tetrahedralize(p, [("hexahedron", hexahedra_of_grid(n, n, n))], values)
    return TetMesh(points, tets, v, name="grid")


@pytest.mark.parametrize("projection", ["orthographic", "perspective"])
def test_rays_through_edges_and_faces_along_an_axis(walker, converged, projection):
    """Seen straight along an axis, pixel centres fall on the boundary faces' shared edges (the
    diagonals of the split squares) and rays run inside interior face planes, where a ray touches
    cells it does not cross.  The walk finds the pieces projected tetrahedra draw (largest pixel
    difference measured 1e-7; bound 1e-5: a lost piece is 1e-3 or more here), and both match the
    reference to float32 with this steep band (RMS 2.7-3.3e-5; bound 1e-4, as above)."""
    keys = {"camera.eye": [0.5, 0.5, 3.0], "camera.target": [0.5, 0.5, 0.5], "camera.up": [0, 1, 0],
            "camera.projection": projection, "camera.view_height": 1.2, "camera.fov": 25.0,
            "image.width": 48, "image.height": 48}
    scene = mesh_scene(grid_mesh(), **keys)
    image = walker.render(exact(scene))
    pt = create_renderer(SORTED, ctx=walker.ctx)
    try:
        drawn = pt.render(scene.with_renderer(name=SORTED))
    finally:
        pt.close()
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert truth[..., 3].max() > 0.3
    assert np.abs(image.astype(float) - drawn).max() < 1e-5
    assert rms(image, truth) < 1e-4, rms(image, truth)


@needs_data
def test_the_oxygen_post_along_its_axis():
    """Real data where rays meet a boundary edge shared by two entering faces while grazing them: an
    entry whose cell the ray clearly misses is given up (walking on from it skipped a stretch of
    cells: 3 pixels off by up to 0.08 at 256x256, RMS 3.4e-4).  The walk matches projected
    tetrahedra, which the bench matches to the reference at 2.3e-7 here: largest pixel difference
    measured 4e-6, bound 1e-4."""
    from dvr_gl.bench.datasets import MESHES
    from dvr_gl.bench.datasets import mesh_scene_keys as scene_keys
    from dvr_gl.scene.resolve import load_scene

    source, array = MESHES["post"]
    path = SHARED_DATA / source
    mesh = load_scene(None, {"volume.path": str(path), "volume.array": array}).field
    scene = load_scene(None, {**scene_keys(path, array, mesh), "camera.azimuth": 0.0, "camera.elevation": 90.0,
                              "image.width": 256, "image.height": 256})
    walker = create_renderer("cell-raycast")
    pt = create_renderer(SORTED, ctx=walker.ctx)
    try:
        image = walker.render(scene.with_renderer(name="cell-raycast", ert_threshold=1.0)).astype(float)
        drawn = pt.render(scene.with_renderer(name=SORTED, cell_order="exact")).astype(float)
    finally:
        pt.close()
        walker.close()
    assert drawn[..., 3].max() > 0.3
    assert np.abs(image - drawn).max() < 1e-4, np.unravel_index(np.abs(image - drawn).argmax(), image.shape)


def test_the_cli_and_the_viewer_with_its_panel(tmp_path):
    """``dvr render --renderer cell-raycast`` on a mesh file, and the viewer with its panel: the
    transfer-function editor's histogram is of the mesh's values (it asked a grid's samples of the
    mesh and ended in an internal error, with either mesh renderer)."""
    import os
    import subprocess
    import sys

    from dvr_gl.image import read_image
    from xvfb import xvfb_display

    volume = mesh_scene(jittered_mesh((3, 3, 3))).volume_source.path
    out = tmp_path / "mesh.exr"
    cli = [sys.executable, "-m", "dvr_gl.apps.cli"]
    done = subprocess.run([*cli, "render", "--volume", volume, "--renderer", "cell-raycast", "--size", "32", "-o",
                           str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "cell-raycast" in done.stdout and read_image(out)[..., 3].max() > 0.1
    with xvfb_display() as display:
        view = subprocess.run([*cli, "view", "--volume", volume, "--renderer", "cell-raycast", "--size", "48x48",
                               "--benchmark", "0.3"], capture_output=True, text=True, timeout=300,
                              env={**os.environ, "DISPLAY": display})
    assert view.returncode == 0, view.stderr
    assert "tetrahedra, cell-raycast" in view.stdout


def test_a_histogram_of_a_mesh_s_values():
    """The viewer's histogram takes a mesh's values (one axis) as well as a grid's samples."""
    from dvr_gl.viewer.gui import histogram

    heights = histogram(np.array([0.0, 0.1, 0.1, 0.9]), (0.0, 1.0), bins=10)
    assert heights.shape == (10,) and heights[1] == 1.0 and heights[0] > 0 and heights[5] == 0


def test_more_entries_than_the_gl_holds_are_refused(monkeypatch):
    """Rays entering the mesh more often in all than this GL's storage buffers hold list nodes (here
    made 10): one line naming what to do, not a wrong image."""
    r = create_renderer("cell-raycast")
    try:
        limit_bytes = int(r.ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"])
        monkeypatch.setattr(walk_module, "NODE_BYTES", limit_bytes // 10)
        scene = mesh_scene(jittered_mesh(), **{"renderer.name": "cell-raycast"})
        with pytest.raises(SceneError, match=r"the rays enter the mesh \d+ times in all, more than the 10 list nodes"):
            r.render(scene)
    finally:
        r.close()


@pytest.mark.parametrize("name", renderers(kind="mesh", gl=True))
def test_many_control_points(converged, name):
    """Past 16 control points the integral finds a value's control interval by binary search instead
    of counting (transfer_segment.glsl): 40 points, both mesh renderers, against the reference
    (measured RMS 1.3e-7; bound 1e-5: a wrong interval is far more)."""
    values = np.linspace(-1.0, 2.0, 40)
    points = [[float(v), 0.5 + 0.4 * np.sin(3 * v), 0.5, 0.5 - 0.4 * np.sin(2 * v), 0.3 + 0.25 * np.cos(5 * v)]
              for v in values]
    scene = mesh_scene(jittered_mesh(), **{"renderer.name": name, "transfer_function.points": points,
                                           "camera.azimuth": 30.0, "camera.elevation": 20.0})
    r = create_renderer(name)
    try:
        image = r.render(scene.with_renderer(ert_threshold=1.0) if registry.plugin(name).declared("ert_threshold")
                         else scene)
    finally:
        r.close()
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    assert truth[..., 3].max() > 0.3
    assert rms(image, truth) < 1e-5, rms(image, truth)
