"""Shear-warp with opaque meshes: samples behind the meshes dropped on the host, as its same-slices
reference does."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from slab_scenes import TILTED, degenerate_mesh_renders_as_none, tilted


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
    from dvr_gl.renderers.shearwarp.oracle import intermediate_reference, oracle
    from dvr_gl.renderers.shearwarp.renderer import composite
    from dvr_gl.renderers.shearwarp.shading import frame_table

    scene = load_scene(None, {**TILTED, "renderer.name": "shearwarp", "renderer.geometry": tilted(tmp_path), **extra})
    with registry.plugin("shearwarp").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        fact = factorize(scene.camera, scene.volume, scene.image.width, scene.image.height)
        rle = renderer.encoding(scene, fact.axis)
        intermediate, _ = composite(fact, rle, scene, frame_table(scene) if rle.codes is not None else None)
    expected = intermediate_reference(scene)
    tolerance = 5e-8 if scene.renderer.classification == "pre" else 1e-12
    assert np.abs(intermediate - expected).max() <= tolerance
    assert_close(image, oracle(scene))


def test_a_mesh_of_only_degenerate_triangles_renders_as_none(tmp_path, gl_context):
    degenerate_mesh_renders_as_none(gl_context, tmp_path, "shearwarp")
