"""Splatting with opaque meshes: each kernel integrated over the pixel's ray part in front of the meshes,
against its oracle."""

from __future__ import annotations

import pytest

from conftest import assert_close
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from slab_scenes import tilted


@pytest.mark.parametrize("extra", [{}, {"renderer.sheet_buffer": "axis_aligned"}, {"renderer.classification": "pre"},
                                   {"renderer.compositing": "average"}],
                         ids=["image-aligned", "axis-aligned", "pre", "average"])
def test_splatting_ends_its_parts_at_the_meshes_as_its_oracle(tmp_path, gl_context, extra):
    """Splatting integrates each kernel over the pixel's ray part in front of the layer's surface, and
    composites over the layer; its oracle does the same with the float64 surfaces (measured at most
    7.1e-8)."""
    from dvr_gl.renderers.splatting.oracle import oracle

    scene = load_scene(None, {"volume.demo": "shepp-logan", "volume.size": 12, "image.width": 16, "image.height": 12,
                              "renderer.name": "splatting", "renderer.filter": "gaussian",
                              "renderer.ert_threshold": 1.0,
                              "renderer.geometry": tilted(tmp_path), **extra})
    with registry.plugin("splatting").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_close(image, oracle(scene))
