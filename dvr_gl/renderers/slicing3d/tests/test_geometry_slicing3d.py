"""3D texture slicing with opaque meshes: a slice's fragments behind the meshes discarded, as the reference
of the same planes drops them; half-angle slicing with a mesh."""

from __future__ import annotations

import pytest

from conftest import assert_close
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from slab_scenes import TILTED, degenerate_mesh_renders_as_none, tilted


def test_half_angle_slicing_with_a_mesh(tmp_path, gl_context):
    """Scattering's half-angle slicing takes the meshes too (they end the view's samples; the lights'
    rays do not see them: meshes cast no shadows)."""
    from dvr_gl.renderers.slicing3d.oracle import oracle

    scene = load_scene(None, {**TILTED, "renderer.name": "slicing3d", "renderer.geometry": tilted(tmp_path),
                              "renderer.scattering": {"enabled": True, "method": "half_angle",
                                                      "light_buffer_size": 32}})
    with registry.plugin("slicing3d").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_close(image, oracle(scene))


@pytest.mark.parametrize("extra", [{}, {"camera.projection": "orthographic"}, {"renderer.shading.enabled": True},
                                   {"renderer.classification": "preintegrated"}],
                         ids=["default", "orthographic", "shaded", "preintegrated"])
def test_slicing3d_discards_fragments_behind_the_meshes_as_its_planes(tmp_path, gl_context, extra):
    """A slice's fragment behind the layer's surface is discarded, as the reference of the same planes
    drops the planes a ray crosses past its surface (measured at most 5.3e-7, no value off by more than
    1e-4)."""
    from dvr_gl.renderers.slicing3d.oracle import oracle

    scene = load_scene(None, {**TILTED, "renderer.name": "slicing3d", "renderer.geometry": tilted(tmp_path), **extra})
    with registry.plugin("slicing3d").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["GEOMETRY"]
    assert_close(image, oracle(scene))


def test_a_mesh_of_only_degenerate_triangles_renders_as_none(tmp_path, gl_context):
    degenerate_mesh_renders_as_none(gl_context, tmp_path, "slicing3d")
