"""The default opacity unit distance is one voxel of the data (docs/conventions.md): the same volume at
spacing 0.001 and at spacing 1 gives the same picture with every renderer that takes grids (the camera
frames the data, so everything scales together); a mesh of small cells is as visible as the same mesh
at size 1; a unit distance the scene gives still wins.

"The same picture": equal to float32 rounding (positions and steps scaled by 0.001 round differently):
the largest difference measured was 5.2e-6 (shear-warp), at most 5e-7 for the other GL renderers, 0 for
the references, 1.3e-6 for the mesh; asserted within 2e-5.
"""

from __future__ import annotations

import numpy as np
import pytest

import dvr_gl
from closed_forms import VIEWS, own_filter
from dvr_gl.phantoms import shepp_logan
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from mesh_inputs import jittered_mesh, mesh_scene

DATA = shepp_logan(12).astype(np.float32)
TF = [[0.0, 0.2, 0.4, 0.9, 0.0], [1.0, 1.0, 0.8, 0.3, 0.6]]
GRID_RENDERERS = [n for n, p in registry.plugins().items() if p.data_kinds is None or "grid" in p.data_kinds]


def _image(renderer: str, spacing: float, **keys) -> np.ndarray:
    plugin = registry.plugin(renderer)
    mode = plugin.choices("compositing")[0]
    view = next(v for v in VIEWS if v in plugin.projections)
    keys = {**{k.removeprefix("renderer."): v for k, v in own_filter(renderer, mode).items()},
            **{k.removeprefix("camera."): v for k, v in VIEWS[view].items()}, **keys}
    scene = dvr_gl.scene_of(DATA, spacing=(spacing,) * 3, transfer_function=TF, size=12, renderer=renderer,
                            compositing=mode, **keys)
    return dvr_gl.render(scene).rgba


@pytest.mark.parametrize("renderer", GRID_RENDERERS)
def test_a_volume_at_spacing_0001_looks_as_at_spacing_1(renderer):
    small, unit = _image(renderer, 0.001), _image(renderer, 1.0)
    assert unit[..., 3].max() > 0.05   # something drawn (the X-ray of Fourier rendering: 0.09)
    np.testing.assert_allclose(small, unit, rtol=0, atol=2e-5)


def test_the_resolved_unit_distance_is_one_voxel_and_a_given_one_wins():
    anisotropic = dvr_gl.scene_of(DATA, spacing=(0.002, 0.001, 0.003), transfer_function=TF)
    assert anisotropic.transfer_function.unit_distance == 0.001        # the smallest spacing
    given = load_scene(None, {"volume.demo": "blobs", "volume.size": 8, "transfer_function.unit_distance": 1.0})
    assert given.transfer_function.unit_distance == 1.0
    scene = dvr_gl.scene_of(DATA, spacing=(0.001,) * 3, transfer_function="grayscale")
    old = scene.replace(transfer_function=dvr_gl.TransferFunction(np.array(TF), unit_distance=1.0))
    assert old.transfer_function.unit_distance == 1.0
    assert dvr_gl.render(old, size=12).rgba[..., 3].max() < 0.01        # per world unit: nearly invisible


def test_a_mesh_of_small_cells_is_visible():
    mesh = jittered_mesh()
    small = type(mesh)(mesh.points * 1e-3, mesh.tets, mesh.values, name="small")
    images = [dvr_gl.render(mesh_scene(m, **{"renderer.name": registry.default_for("mesh"), "image.width": 16,
                                             "image.height": 16})).rgba for m in (mesh, small)]
    assert images[1][..., 3].max() > 0.3
    np.testing.assert_allclose(images[1], images[0], rtol=0, atol=2e-5)
