"""Clipping and opaque meshes in the GL renderers of tetrahedral meshes (those that declare the ``mesh``
data kind): each fragment's (walk's) piece narrowed to the kept region and ended at the nearest
surface (``dvr_gl/renderers/mesh/shaders/kept_part.glsl``), against closed forms and the float64 mesh reference.

The closed forms are tests/slab_scenes.py's slab (Beer-Lambert on the
kept chord; a square inside and above it), here as a mesh of hexahedra split into tetrahedra.
"""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.gl.context import make_current
from dvr_gl.renderers import create_renderer, registry
from judges import CONVERGED, renderers
from mesh_inputs import jittered_mesh, mesh_scene, rms
from slab_scenes import GREY, PLANE, beer_lambert, slab_keys, slab_mesh, square, square_expected

meshio = pytest.importorskip("meshio", reason="meshes are read by meshio (the mesh extra)")

# the GL renderers of volume meshes
MESH_RENDERERS = renderers(kind="mesh", gl=True)


@pytest.fixture(scope="module", params=MESH_RENDERERS)
def renderer(request, shared_gl_context):
    """One renderer per module on the session's context (made current: an earlier test may have left none)."""
    r = create_renderer(request.param, ctx=make_current(shared_gl_context))
    yield r
    r.close()


# The box's faces lie between pixel centres (x = 1.5 would hold one: float32 would decide it).
CASES = {
    "plane": ({"planes": [PLANE]}, lambda x, y: 0.21 + 0.2 * x),
    "box": ({"box": [[1.45, 1.35, 0.2], [2.55, 2.65, 0.7]]},
            lambda x, y: np.where((abs(x - 2.0) <= 0.55) & (abs(y - 2.0) <= 0.65), 0.5, 0.0)),
    "both": ({"planes": [PLANE], "box": [[0.0, 0.0, 0.3], [4.0, 4.0, 1.0]]},
             lambda x, y: np.maximum(0.21 + 0.2 * x - 0.3, 0.0)),
}


@pytest.mark.parametrize("case", CASES)
def test_a_clipped_mesh_slab_is_beer_lambert(renderer, case):
    """Each cell's piece ends at the planes and the box exactly: float32 planes, measured 1.3e-6."""
    clipping, chord = CASES[case]
    scene = mesh_scene(slab_mesh(), **slab_keys(renderer.name, **{"renderer.clipping": clipping}))
    image = renderer.render(scene)
    expected = beer_lambert(scene, chord)
    assert expected[..., 3].max() > 0.3 and np.abs(image - expected).max() < 2e-6


@pytest.mark.parametrize("height", [0.4, 1.5], ids=["inside", "above"])
def test_a_square_in_and_above_a_mesh_slab(tmp_path, renderer, height):
    """Pieces end at the square's depth (the surface layer's t), the square shows behind: float32,
    measured 4.8e-7."""
    geometry = [{"path": square(tmp_path / "square.obj", height), "color": list(GREY)}]
    scene = mesh_scene(slab_mesh(), **slab_keys(renderer.name, **{"renderer.geometry": geometry}))
    image = renderer.render(scene)
    assert np.abs(image - square_expected(scene, height)).max() < 2e-6


def _crossing(tmp_path):
    """A tilted square through the jittered mesh (0 <= x <= 1, 0 <= y <= 0.8, 0 <= z <= 0.9) and a
    small triangle in front of it, seen from the azimuths below."""
    points = np.array([[-0.2, -0.2, 0.2], [1.2, -0.2, 0.5], [1.2, 1.0, 0.75], [-0.2, 1.0, 0.45],
                       [0.3, 0.1, 1.2], [0.6, 0.1, 1.2], [0.6, 0.4, 1.3]])
    path = tmp_path / "crossing.ply"
    meshio.write_points_cells(str(path), points, [("triangle", np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]], np.int32))])
    return [{"path": str(path), "color": [0.3, 0.5, 0.9]}]


CLIP = {"planes": [[1.0, 0.3, -0.2, -0.45]], "box": [[-1.0, 0.1, -1.0], [2.0, 0.75, 0.7]]}
VIEWS = [{"camera.azimuth": 30.0, "camera.elevation": 20.0},
         {"camera.projection": "orthographic", "camera.azimuth": -50.0, "camera.elevation": 35.0}]
MODES = ["emission_absorption", "mip", "minip", "average", "isosurface"]


@pytest.mark.parametrize("view", VIEWS, ids=["perspective", "orthographic"])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("what", ["clipping", "geometry", "both"])
def test_mesh_renderers_clip_and_stop_at_meshes_as_the_reference(tmp_path, renderer, converged, what, mode, view):
    """Every mode, against the converged mesh reference with the same region and surfaces.  Bounds as
    the unclipped tests': emission-absorption RMS 1e-4 (measured at most 1.7e-5: the band's slope on
    float32 values), the projections 1e-5 (measured at most 4.8e-6, the average's: its integral in
    float32 over a chord narrowed in float64; the isosurface 1.7e-8)."""
    keys = {"renderer.name": renderer.name, "renderer.compositing": mode, "renderer.iso_value": 0.6, **view}
    if what in ("clipping", "both"):
        keys["renderer.clipping"] = CLIP
    if what in ("geometry", "both"):
        keys["renderer.geometry"] = _crossing(tmp_path)
    if registry.plugin(renderer.name).declared("ert_threshold") is not None:  # no early termination
        keys["renderer.ert_threshold"] = 1.0
    scene = mesh_scene(jittered_mesh(), **keys)
    image = renderer.render(scene)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    plain = converged.render(scene.with_renderer(name=CONVERGED, clipping=None, geometry=[]))
    assert rms(truth, plain) > 0.03  # the region and the surfaces change the picture
    bound = 1e-4 if mode == "emission_absorption" else 1e-5
    assert rms(image, truth) < bound, rms(image, truth)


@pytest.mark.parametrize("lens", [{"camera.fov": 70.0},
                                  {"camera.projection": "orthographic", "camera.view_height": 0.6}])
def test_camera_inside_a_clipped_mesh(tmp_path, renderer, converged, lens):
    """The eye inside a cell (projected tetrahedra: cells covering the whole image; the walk: start
    cells located on the host), a plane cutting the view and a surface ahead: as the reference."""
    keys = {"renderer.name": renderer.name, "camera.eye": [0.45, 0.35, 0.4], "camera.target": [1.0, 0.8, 0.9],
            "camera.up": [0, 0, 1], "renderer.clipping": {"planes": [[-1.0, 0.2, 0.1, 0.75]]},
            "renderer.geometry": _crossing(tmp_path), "renderer.ert_threshold": 1.0, **lens}
    scene = mesh_scene(jittered_mesh(), **keys)
    image = renderer.render(scene)
    truth = converged.render(scene.with_renderer(name=CONVERGED))
    plain = converged.render(scene.with_renderer(name=CONVERGED, clipping=None, geometry=[]))
    assert rms(truth, plain) > 0.03
    assert rms(image, truth) < 1e-4, rms(image, truth)


def test_a_region_that_keeps_nothing_leaves_the_background(renderer):
    scene = mesh_scene(jittered_mesh(), **{"renderer.name": renderer.name,
                                           "renderer.clipping": {"planes": [[0.0, 0.0, 1.0, -5.0]]}})
    assert not renderer.render(scene).any()


def test_a_mesh_scene_without_clipping_is_unchanged(renderer):
    scene = mesh_scene(jittered_mesh(), **{"renderer.name": renderer.name, "camera.azimuth": 30.0})
    a = renderer.render(scene)
    b = renderer.render(scene.with_renderer(clipping={"planes": [[0.0, 0.0, 1.0, 5.0]]}))  # keeps everything
    assert np.abs(a - b).max() < 1e-6  # the same pieces, narrowed by nothing (float32 rounding only)
