"""Splatting's clipping: each kernel integrated over the clipped parts of the pixel's ray, against its
oracle; particles refuse clipping."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.errors import SceneError
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from slab_scenes import CLIPPED_PHANTOM

SPLATTED = {"volume.demo": "shepp-logan", "volume.size": 12, "image.width": 16, "image.height": 12,
            "renderer.name": "splatting", "renderer.filter": "gaussian", "renderer.ert_threshold": 1.0,
            "renderer.clipping": CLIPPED_PHANTOM["renderer.clipping"]}


@pytest.mark.parametrize("extra", [{}, {"renderer.sheet_buffer": "axis_aligned"}, {"renderer.classification": "pre"},
                                   {"renderer.compositing": "average"}, {"renderer.filter": "cubic_bspline"}],
                         ids=["image-aligned", "axis-aligned", "pre", "average", "bspline"])
def test_splatting_integrates_the_clipped_parts_as_its_oracle(gl_context, extra):
    """Splatting's kernels are integrated over each pixel's ray part inside the clipped region (the
    sheets' parts narrowed as the box's), as its oracle integrates them (measured at most 5.4e-8)."""
    from dvr_gl.renderers.splatting.oracle import oracle

    scene = load_scene(None, {**SPLATTED, **extra})
    with registry.plugin("splatting").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    expected = oracle(scene)
    unclipped = oracle(scene.with_renderer(clipping=type(scene.renderer.clipping)()))
    assert np.abs(expected - unclipped).max() > 0.1 * unclipped.max()  # the clipping shows
    assert_close(image, expected)


def test_splatting_refuses_clipping_particles():
    with pytest.raises(SceneError, match="turn renderer.clipping and renderer.geometry off for particle sets"):
        registry.check(load_scene(None, {"volume.demo": "plummer", "volume.size": 8, "renderer.name": "splatting",
                                         "renderer.clipping": {"planes": [[1.0, 0.0, 0.0, 0.0]]}}))
