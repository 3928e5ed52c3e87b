"""Shear-warp's own GL limits (from tests/scene/test_limits.py): its frame and its intermediate image
checked against the (faked smaller) limits before drawing, refused in one line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import small_scene
from dvr_gl import limits
from dvr_gl.errors import DvrError
from dvr_gl.renderers import create_renderer
from dvr_gl.scene.resolve import load_scene


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


def test_a_shear_that_widens_the_intermediate_image_is_bounded(renderer, tmp_path):
    """A long, thin volume seen obliquely: each of its slices is composited into an intermediate image the shear
    widens (a 1 x 20000 x 2 volume: 20000 slices into 6456 x 8866 pixels ran past 400 s, found by the fuzz
    campaign of 2026-11-29).  The work (slices x intermediate pixels) is refused in one line where it exceeds the
    bound, here lowered by a one-second budget (8e8 a second: the 1 x 2000 x 2 volume's 2000 x 578,500 is over it),
    and so is the intermediate image over the memory budget; the same volume renders without them."""
    from dvr_gl.sandbox import Sandbox, active

    data = np.random.default_rng(0).integers(0, 255, (1, 2000, 2)).astype(np.uint8)
    np.save(tmp_path / "thin.npy", data)
    scene = load_scene(None, {"renderer.name": "shearwarp", "volume.path": str(tmp_path / "thin.npy"),
                              "image.width": 32, "image.height": 32})
    work = renderer.work(scene)
    assert work.count > 1e9 and work.unit == "intermediate pixel-slices"
    with active(Sandbox(max_seconds=1.0)):
        with pytest.raises(DvrError, match=r"would take .* intermediate pixel-slices \(2000 slices x") as exc:
            renderer.render(scene)
    assert "\n" not in str(exc.value) and "use raycast" in str(exc.value)
    with active(Sandbox(max_bytes=64 << 20)):  # the image's 578,500 pixels take 141 MiB
        with pytest.raises(DvrError, match="intermediate image would take"):
            renderer.render(scene)
    assert renderer.render(scene)[..., 3].max() > 0
