"""The one-pass frame drawn only within the pixels whose rays can meet the volume (renderer.box_rectangle, a
scissor box), and each brick's pass only within those whose rays can meet the brick: the same image, bit for
bit, as the whole image drawn, in every compositing mode and view."""

import numpy as np
import pytest

from dvr_gl.api import scene_of
from dvr_gl.camera import Camera
from dvr_gl.fields.grid import Volume
from dvr_gl.gl.context import make_current
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.raycast import renderer as raycast
from dvr_gl.scene.resolve import load_scene
from dvr_gl.transfer_function import TransferFunction

BASE = {"volume.demo": "blobs", "volume.size": 20, "image.width": 40, "image.height": 30}
CASES = {
    "composite": {}, "mip": {"renderer.compositing": "mip"},
    "mip two brackets": {"renderer.compositing": "mip", "renderer.extremum_brackets": 2},
    "minip": {"renderer.compositing": "minip"}, "average": {"renderer.compositing": "average"},
    "xray": {"renderer.compositing": "xray"},
    "isosurface": {"renderer.compositing": "isosurface", "renderer.iso_value": 0.3},
    "back to front": {"renderer.order": "back_to_front"},
    "orthographic": {"camera.projection": "orthographic"},
    "from below, wide": {"camera.azimuth": 80.0, "camera.elevation": -60.0, "camera.fov": 120.0},
    "jittered": {"renderer.jitter": True},
    "counted": {},
}


@pytest.fixture(scope="module")
def renderer(shared_gl_context):
    with create_renderer("raycast", ctx=make_current(shared_gl_context)) as made:
        yield made


@pytest.mark.parametrize("case", list(CASES))
def test_the_scissored_frame_is_the_whole_frame(renderer, monkeypatch, case):
    """Outside the box's pixels a ray meets nothing and the pass writes zero, which the clear writes: the images
    (and the sample counts) are equal to the bit; each case leaves pixels out (else it would test nothing)."""
    scene = load_scene(None, {**BASE, **CASES[case]})
    rect = raycast.box_rectangle(scene)
    assert rect is not None and rect[2] * rect[3] < 0.9 * scene.image.width * scene.image.height
    drawn = raycast.RayCastRenderer(ctx=renderer.ctx, count_samples=True) if case == "counted" else renderer
    scissored = drawn.render(scene)
    counts = getattr(drawn, "counts", None)
    monkeypatch.setattr(raycast, "box_rectangle", lambda scene, *args, **kw: None)
    whole = drawn.render(scene)
    assert np.array_equal(scissored, whole)
    if case == "counted":
        assert np.array_equal(counts, drawn.counts) and counts.sum() > 0


def test_the_eye_inside_the_box_draws_every_pixel():
    """Where the eye is inside the box no rectangle can be told: every pixel is drawn (None)."""
    scene = load_scene(None, {**BASE, "camera.distance": 1.0})
    assert raycast.box_rectangle(scene) is None


@pytest.mark.parametrize("case", ["composite", "mip two brackets", "minip", "average", "xray", "isosurface",
                                  "back to front", "orthographic"])
def test_the_bricks_scissored_passes_are_the_whole_passes(renderer, monkeypatch, case):
    """Bricked (a texture budget of a few bricks), each pass draws only over the pixels whose rays can meet its
    brick, on a copy of the state (a ray that misses the brick keeps it): the images equal the whole passes' to the
    bit."""
    scene = load_scene(None, {**BASE, **CASES[case], "renderer.texture_budget_mb": 0.01})
    scissored = renderer.render(scene)
    assert renderer.stats["bricks"] > 2
    monkeypatch.setattr(Camera, "pixel_rectangle", lambda *args, **kw: None)
    whole = renderer.render(scene)
    assert np.array_equal(scissored, whole)


@pytest.mark.parametrize("compositing", ["emission_absorption", "mip", "isosurface"])
def test_several_fields_scissored_are_the_whole_frame(renderer, monkeypatch, compositing):
    """Several fields (one pass of their mixture): every mode's empty state is zero, so the scissored frame equals
    the whole one to the bit."""
    z, y, x = np.mgrid[0:10, 0:11, 0:12].astype(np.float32)
    fields = [Volume((np.sin(x / 3) * np.cos(y / 4) + z / 10).astype(np.float32)),
              Volume((((x - 6) ** 2 + (y - 5) ** 2 + (z - 5) ** 2) / 50).astype(np.float32))]
    tfs = [TransferFunction([[lo, 0.9, 0.4, 0.2, 0.0], [hi, 0.2, 0.5, 0.9, 0.8]]) for lo, hi in ((-1, 2), (0, 2))]
    scene = scene_of(fields, transfer_function=tfs, renderer="raycast", size=(40, 30), compositing=compositing,
                     **({"iso_value": 0.5} if compositing == "isosurface" else {}))
    rect = raycast.box_rectangle(scene)
    assert rect is not None and rect[2] * rect[3] < 0.9 * 40 * 30
    scissored = renderer.render(scene)
    monkeypatch.setattr(Camera, "pixel_rectangle", lambda *args, **kw: None)
    assert np.array_equal(scissored, renderer.render(scene))
