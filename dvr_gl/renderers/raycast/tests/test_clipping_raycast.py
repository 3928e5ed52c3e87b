"""The ray caster's clipping: rays ended at the planes and the box with shortened segments, against the
Beer-Lambert closed form on the slab and the same-discretization reference in every mode."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from slab_scenes import CASES, beer_lambert, clipped_slab_scene
from slab_scenes import CLIPPED_PHANTOM as SMALL


@pytest.mark.parametrize("extra", [
    {}, {"renderer.compositing": "mip"}, {"renderer.compositing": "minip"}, {"renderer.compositing": "average"},
    {"renderer.compositing": "xray"}, {"renderer.compositing": "isosurface"},
    {"renderer.classification": "preintegrated"}, {"renderer.classification": "pre"},
    {"renderer.jitter": True}, {"renderer.order": "back_to_front"}, {"renderer.acceleration": "on"},
    {"renderer.texture_budget_mb": 0.004},  # bricked
    {"renderer.shading.enabled": True}, {"camera.projection": "orthographic"},
    {"renderer.clipping": {"planes": [[0.0, 0.0, 1.0, 0.5], [0.3, -1.0, 0.0, 2.0]]}},
    {"camera.eye": [0.0, -2.0, 0.5], "camera.target": [0.0, 8.0, 0.5]},  # inside the volume and the region
], ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(v, (list, dict)) else k.split('.')[-1]
                         for k, v in e.items()) or "default")
def test_raycast_clips_every_mode_as_its_reference(gl_context, extra):
    """Shepp-Logan cut by an oblique plane and a box crossing it: float32 against float64, to the
    conftest's bound (measured at most 3.5e-7 in every case here, bricks and skipping included, no
    value off by more than 1e-4)."""
    scene = load_scene(None, {**SMALL, "renderer.name": "raycast", "renderer.ert_threshold": 1.0, **extra})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["CLIPPING"]
    reference = DiscreteReference(scene).render_float64()
    unclipped = DiscreteReference(scene.with_renderer(clipping=type(scene.renderer.clipping)())).render_float64()
    if scene.renderer.compositing != "minip":  # the minimum is the air around the phantom, clipped or not
        assert np.abs(reference - unclipped).max() > 0.1 * unclipped.max()  # the clipping shows
    assert_close(image, reference)


def test_a_scene_without_clipping_compiles_none_and_is_unchanged(gl_context):
    """An empty table is no table: no define, the same image to the bit; a plane that keeps the whole
    volume changes nothing but rounding."""
    plain = load_scene(None, {**SMALL, "renderer.name": "raycast", "renderer.clipping": {}})
    empty = load_scene(None, {**SMALL, "renderer.name": "raycast", "renderer.clipping": {"planes": []}})
    everything = load_scene(None, {**SMALL, "renderer.name": "raycast",
                                   "renderer.clipping": {"planes": [[0.0, 0.0, 1.0, 100.0]]}})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        a = renderer.render(plain)
        defines = dict(renderer.stats["defines"])
        b = renderer.render(empty)
        c = renderer.render(everything)
    assert "CLIPPING" not in defines and np.array_equal(a, b)
    assert np.abs(a - c).max() < 1e-6


def test_a_plane_that_keeps_nothing_leaves_the_background(gl_context):
    scene = load_scene(None, {**SMALL, "renderer.name": "raycast",
                              "renderer.clipping": {"planes": [[0.0, 0.0, 1.0, -100.0]]}})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        assert not renderer.render(scene).any()
    assert not DiscreteReference(scene).render_float64().any()


@pytest.mark.parametrize("case", CASES)
def test_raycast_clips_the_slab_as_beer_lambert(tmp_path, gl_context, case):
    """The ray caster ends its rays at the planes with shortened segments (float32: measured 2e-7)."""
    clipping, chord = CASES[case]
    scene = clipped_slab_scene(tmp_path, "raycast", clipping)
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["CLIPPING"]
    assert np.abs(image - beer_lambert(scene, chord)).max() < 2e-6
