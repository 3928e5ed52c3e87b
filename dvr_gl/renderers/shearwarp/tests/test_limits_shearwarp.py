"""Shear-warp's own GL limits (from tests/scene/test_limits.py): its frame and its intermediate image
checked against the (faked smaller) limits before drawing, refused in one line."""

from __future__ import annotations

import dataclasses

import pytest

from conftest import small_scene
from dvr_gl import limits
from dvr_gl.errors import DvrError
from dvr_gl.renderers import create_renderer


@pytest.fixture(scope="module")
def renderer(shared_gl_context):
    made = create_renderer("shearwarp", ctx=shared_gl_context)
    yield made
    made.close()


def fake(monkeypatch, ctx, **smaller):
    """Pretend this GL has the given (smaller) limits."""
    real = limits.gl_limits(ctx)
    monkeypatch.setattr(limits, "gl_limits", lambda _ctx: dataclasses.replace(real, **smaller))


def test_image_over_the_render_target_limit(renderer, gl_context, monkeypatch):
    fake(monkeypatch, gl_context, renderbuffer_size=24)
    scene = small_scene({"renderer.name": "shearwarp", "volume.size": 16, "image.width": 25, "image.height": 8})
    with pytest.raises(DvrError) as exc:
        renderer.render(scene)
    text = str(exc.value)
    assert "\n" not in text
    assert "image 25x8 exceeds GL_MAX_RENDERBUFFER_SIZE 24" in text and "at most 24 a side" in text


def test_intermediate_image_over_the_texture_limit(renderer, gl_context, monkeypatch):
    fake(monkeypatch, gl_context, texture_size=20)  # a 32^3 volume's intermediate image is > 32 a side
    scene = small_scene({"renderer.name": "shearwarp", "image.width": 16, "image.height": 16})
    with pytest.raises(DvrError, match="shear-warp's intermediate image of .* exceeds GL_MAX_TEXTURE_SIZE 20"):
        renderer.render(scene)
