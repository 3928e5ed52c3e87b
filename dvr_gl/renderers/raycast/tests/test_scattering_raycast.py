"""The ray caster's single scattering: shadow rays, the light volume and the albedo column against the
same-discretization reference (float32 against float64), and what a scene without scattering keeps.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dvr_gl.errors import SceneError
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from scattering_scenes import ALBEDO_BY_DEFAULT, COLUMN_LIT, LIT, SMALL


@pytest.mark.parametrize("extra", [
    {}, {"renderer.ert_threshold": 0.99}, {"camera.projection": "orthographic"},
    {"renderer.scattering.phase": "henyey_greenstein", "renderer.scattering.g": -0.4},
    {"renderer.scattering.lights": [{"type": "point", "position": [3.0, 20.0, 10.0], "intensity": 300.0},
                                    {"direction": [0.0, 0.0, -1.0], "color": [0.5, 0.7, 1.0]}]},
    {"renderer.scattering.lights": [{"type": "point", "position": [6.0, 6.0, 6.0], "intensity": 4.0}]},  # inside
    {"renderer.classification": "pre"}, {"renderer.classification": "preintegrated"},
    {"renderer.gradient_opacity": True}, {"renderer.scattering.shadows": False}, {"renderer.acceleration": "on"},
    {"renderer.filter": "cubic_bspline"},
], ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(v, list) else k.split('.')[-1]
                          for k, v in e.items()) or "default")
def test_raycast_shadow_rays_match_the_same_discretization(gl_context, extra):
    """The ray caster's shadow rays against the reference's (same segments on both rays): float32
    against float64, measured at most 6e-6 (the conftest's bound: 1e-4 for 0.5 % of values)."""
    from conftest import assert_close

    scene = load_scene(None, {**LIT, "renderer.name": "raycast", **extra})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["SCATTERING"]
    reference = DiscreteReference(scene).render_float64()
    assert image[..., :3].max() > 0.1  # lit, not black
    assert_close(image, reference)


def test_raycast_shadow_rays_longer_than_the_loop_cap_go_in_passes(gl_context):
    """A shadow ray per sample multiplies a ray's loop iterations; llvmpipe stops a shader's loops after
    65535 in all, so the frame is drawn in windows of segments (here 3): without them the far half of
    every ray would be missing."""
    from conftest import assert_close
    from dvr_gl.renderers.raycast.renderer import segment_windows

    scene = load_scene(None, {**LIT, "renderer.name": "raycast", "renderer.sample_distance_voxels": 0.05,
                              "image.width": 6, "image.height": 5})
    assert len(segment_windows(scene)) >= 3
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["passes"] >= 3
    assert_close(image, DiscreteReference(scene).render_float64())


def test_a_scene_without_scattering_compiles_none_and_is_unchanged(gl_context):
    """``enabled = false`` (whatever else the table holds) is the scene without the table: no scattering
    define, the same image to the bit."""
    plain = load_scene(None, {**SMALL, "renderer.name": "raycast"})
    off = load_scene(None, {**SMALL, "renderer.name": "raycast",
                            "renderer.scattering": {"enabled": False, "albedo": 0.3, "shadows": True,
                                                    "lights": [{"type": "point", "intensity": 9.0}]}})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        a = renderer.render(plain)
        defines = dict(renderer.stats["defines"])
        b = renderer.render(off)
        assert renderer.stats["defines"] == defines
    assert not any(k in defines for k in ("SCATTERING", "SHADOWS", "NUM_SCATTER_LIGHTS", "PHASE_HG"))
    assert np.array_equal(a, b)


def test_raycast_refuses_other_methods_and_bricks(gl_context):
    scene = load_scene(None, {**LIT, "renderer.name": "raycast", "renderer.scattering.method": "half_angle"})
    assert "not by renderer.scattering.method = 'half_angle'" in registry.refusal(scene)
    bricked = load_scene(None, {**LIT, "renderer.name": "raycast", "renderer.texture_budget_mb": 0.002})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        with pytest.raises(SceneError, match="the lights. rays cross bricks"):
            renderer.render(bricked)


VOLUME_LIT = {**LIT, "renderer.scattering.method": "light_volume", "renderer.scattering.light_volume_size": 20}


@pytest.mark.parametrize("extra", [
    {}, {"renderer.scattering.lights": [{"type": "point", "position": [3.0, 20.0, 10.0], "intensity": 300.0},
                                        {"direction": [0.0, 0.0, -1.0], "color": [0.5, 0.7, 1.0]}]},
    {"renderer.classification": "pre"}, {"renderer.classification": "preintegrated"},
    {"renderer.gradient_opacity": True}, {"renderer.filter": "cubic_bspline"},
    {"renderer.scattering.light_volume_size": 5},
], ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(v, list) else k.split('.')[-1]
                          for k, v in e.items()) or "default")
def test_raycast_light_volume_matches_the_same_discretization(gl_context, extra):
    """The light volume marched in GL from its nodes and interpolated in the shader, against the
    reference marching the same rays in float64: measured at most 6e-6, the conftest's bound."""
    from conftest import assert_close

    scene = load_scene(None, {**VOLUME_LIT, "renderer.name": "raycast", **extra})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["LIGHT_VOLUME"] and "SHADOWS" not in renderer.stats["defines"]
    assert image[..., :3].max() > 0.1
    assert_close(image, DiscreteReference(scene).render_float64())


def test_light_volume_is_made_once_per_light_and_transfer_function(gl_context):
    scene = load_scene(None, {**VOLUME_LIT, "renderer.name": "raycast"})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        renderer.render(scene)
        assert renderer.stats["light_volume_seconds"] > 0
        assert renderer._cache["light volume"][1].texture.components == 1  # a channel per light, no more
        renderer.render(scene.replace(camera=scene.camera.orbited(azimuth=80.0)))  # a new view: kept
        assert renderer.stats["light_volume_seconds"] == 0
        moved = scene.with_renderer(scattering=dataclasses.replace(
            scene.renderer.scattering, lights=[dataclasses.replace(scene.renderer.scattering.lights[0],
                                                                   direction=(0.0, 1.0, -1.0))]))
        renderer.render(moved)
        assert renderer.stats["light_volume_seconds"] > 0
        plain = load_scene(None, {**SMALL, "renderer.name": "raycast"})
        with registry.plugin("raycast").create(ctx=gl_context) as fresh:
            fresh.render(plain)
            assert "light volume" not in fresh._cache  # nothing of scattering uploaded


@pytest.mark.parametrize("method", ["shadow_rays", "light_volume"])
def test_shadow_step_of_its_own(gl_context, method):
    """renderer.scattering.shadow_step_voxels marches shadow rays at their own step (the view rays keep
    theirs): the GPU within float32 of the reference at that step, and a coarser step changes the image."""
    from conftest import assert_close

    over = {**LIT, "renderer.name": "raycast", "renderer.scattering.method": method,
            "renderer.scattering.light_volume_size": 12}
    coarse = load_scene(None, {**over, "renderer.scattering.shadow_step_voxels": 2.0})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(coarse)
        fine = renderer.render(load_scene(None, over))
    assert_close(image, DiscreteReference(coarse).render_float64())
    assert np.abs(image - fine).max() > 1e-3


@pytest.mark.parametrize("extra", [
    {}, {"renderer.classification": "preintegrated"},
    {"renderer.scattering.method": "light_volume", "renderer.scattering.light_volume_size": 20},
], ids=["post", "preintegrated", "light_volume"])
def test_raycast_albedo_column_matches_the_same_discretization(gl_context, extra):
    """The ray caster looks the albedo up in its own table beside the transfer function's, as the
    reference does: float32 against float64 to the conftest's bound, and unlike one number's image."""
    from conftest import assert_close

    scene = load_scene(None, {**COLUMN_LIT, "renderer.name": "raycast", **ALBEDO_BY_DEFAULT, **extra})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["ALBEDO_TABLE"]
        number = renderer.render(load_scene(None, {**LIT, "renderer.name": "raycast", **extra}))
    assert_close(image, DiscreteReference(scene).render_float64())
    assert np.abs(image - number).max() > 0.05


def test_an_albedo_column_without_scattering_is_not_uploaded(gl_context):
    """Without scattering the column is ignored: no define, no table, the five-column image to the bit."""
    plain = load_scene(None, {**LIT, "renderer.name": "raycast", "renderer.scattering.enabled": False})
    column = load_scene(None, {**COLUMN_LIT, "renderer.name": "raycast", "renderer.scattering.enabled": False})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        a = renderer.render(plain)
        b = renderer.render(column)
        assert "ALBEDO_TABLE" not in renderer.stats["defines"] and "albedo lut" not in renderer._cache
    assert np.array_equal(a, b)
