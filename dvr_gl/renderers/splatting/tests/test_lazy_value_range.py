"""A scene that uses neither value-range default never reads the value range (issue 44): a million SPH
particles' range is the interpolant at the particles (seconds)."""
import dataclasses

import pytest

from dvr_gl.fields.particles import ParticleSet, plummer_sphere
from dvr_gl.renderers.splatting.renderer import SplattingRenderer
from dvr_gl.scene.resolve import apply_overrides, parse_scene, resolve_scene
from dvr_gl.scene.settings import resolve_renderer


class Unread(ParticleSet):
    @property
    def value_range(self):
        raise AssertionError("the value range was read")


def test_a_scene_using_neither_default_never_reads_the_value_range(shared_gl_context):
    """The iso-value and the gradient-opacity reference are the only defaults read from the value range (and
    shading's threshold, which scales with it); a scene that uses none of them resolves and renders without
    it."""
    p = plummer_sphere(512)
    field = Unread(p.positions, p.smoothing_lengths, p.masses, p.densities)
    overrides = {"image.width": 12, "image.height": 12, "renderer.shading.enabled": False,
                 "transfer_function.points": [[0, 0, 0, 0, 0], [16, 1, 1, 1, 0.9]]}
    renderer = SplattingRenderer(ctx=shared_gl_context)
    try:
        for compositing in ("emission_absorption", "xray"):
            spec = parse_scene(apply_overrides({}, {**overrides, "renderer.name": renderer.name,
                                                    "renderer.compositing": compositing}), "test")
            scene = resolve_scene(spec, field=field)
            assert scene.renderer.iso_value is None and scene.renderer.gradient_opacity_reference is None
            assert renderer.render(scene)[..., 3].max() > 1e-3  # drew the particles (X-ray: 7e-3)
    finally:
        renderer.close()
    # the check can fail: an isosurface's default iso-value reads the range
    isosurface = dataclasses.replace(scene.renderer, compositing="isosurface", iso_value=None)
    with pytest.raises(AssertionError, match="value range was read"):
        resolve_renderer(isosurface, field, ())
