"""The ray caster's own frame limits (from tests/scene/test_limits.py): a long one-pass frame drawn in
bands of rows, each a step that reports progress and may be interrupted."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import small_scene
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.raycast import renderer as raycast


@pytest.fixture(scope="module")
def renderer(shared_gl_context):
    made = create_renderer("raycast", ctx=shared_gl_context)
    yield made
    made.close()


def test_long_one_pass_frames_are_drawn_in_bands(renderer, monkeypatch):
    """A frame estimated over BAND_SECONDS is drawn in scissored bands of rows, reporting each: the
    image is bit-identical to the one-pass frame (each pixel's ray runs the same code), and a
    KeyboardInterrupt raised between bands stops the frame there (no Python runs inside a draw)."""
    scene = small_scene({"renderer.name": "raycast", "volume.size": 16, "image.width": 40, "image.height": 30})
    one_pass = renderer.render(scene)
    monkeypatch.setattr(raycast, "BAND_SECONDS", 1e-9)  # a band a row
    steps = []
    renderer.progress = lambda done, total: steps.append((done, total))
    try:
        banded = renderer.render(scene)
        assert steps == [(k, 30) for k in range(1, 31)]
        np.testing.assert_array_equal(banded, one_pass)

        def interrupt(done, total):
            if done == 3:
                raise KeyboardInterrupt

        renderer.progress = interrupt
        with pytest.raises(KeyboardInterrupt):
            renderer.render(scene)
        renderer.progress = None
        np.testing.assert_array_equal(renderer.render(scene), one_pass)  # the GL state is clean after
    finally:
        renderer.progress = None
