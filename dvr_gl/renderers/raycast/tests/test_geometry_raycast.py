"""The ray caster with opaque meshes: rays ended at the meshes (the closed forms of the square and the
sphere in the slab, the same-discretization reference on the tilted meshes), and the meshes' budgets."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.errors import DvrError
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from judges import DISCRETE
from slab_scenes import (
    GREY,
    SPHERE_HEIGHTS,
    SPHERE_KEYS,
    TILTED,
    assert_square_in_or_above,
    assert_within_sphere_bounds,
    degenerate_mesh_renders_as_none,
    meshed_slab_scene,
    only_layers,
    sphere_geometry,
    sphere_stl,
    square,
    tilted,
)


@pytest.mark.parametrize("extra", [
    {}, {"camera.projection": "orthographic"}, {"renderer.compositing": "mip"},
    {"renderer.compositing": "isosurface"}, {"renderer.compositing": "average"},
    {"renderer.classification": "preintegrated"}, {"renderer.shading.enabled": True},
    {"renderer.acceleration": "on"}, {"renderer.texture_budget_mb": 0.004}, {"renderer.ert_threshold": 0.95},
    {"renderer.clipping": {"planes": [[1.0, 0.4, -0.3, 1.0]]}},
    {"camera.eye": [0.0, -2.0, 0.5], "camera.target": [0.0, 8.0, 0.5]},  # the eye inside, the meshes around it
    {"camera.near": 20.0},  # the near plane cuts the meshes away with the volume
], ids=lambda e: ",".join(f"{k.split('.')[-1]}={v}" if not isinstance(v, (list, dict)) else k.split('.')[-1]
                         for k, v in e.items()) or "default")
def test_raycast_ends_rays_at_the_meshes_as_its_reference(tmp_path, gl_context, extra):
    """The ray caster against the reference with the same meshes: GL rasterizes them (the depth test
    keeps the nearest; pixel centres decide coverage, as the reference's rays do) and ends each ray
    at the layer's distance; to the conftest's bound (measured at most 5.1e-7 in every case here, no
    value off by more than 1e-4: no edge pixel fell the other way)."""
    scene = load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": tilted(tmp_path), **extra})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    reference = DiscreteReference(scene).render_float64()
    plain = DiscreteReference(scene.with_renderer(geometry=[])).render_float64()
    assert np.abs(reference - plain).max() > 0.2  # the meshes show
    assert_close(image, reference)


def test_a_scene_without_meshes_compiles_none_and_is_unchanged(gl_context):
    scene = load_scene(None, {**TILTED, "renderer.name": "raycast"})
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        a = renderer.render(scene)
        assert "GEOMETRY" not in renderer.stats["defines"]
        b = renderer.render(scene.with_renderer(geometry=[]))
    assert np.array_equal(a, b)


def test_meshes_count_against_the_memory_budget(tmp_path, gl_context):
    """Issue 40: a 327k-triangle STL rendered under a 4 MiB budget at 421 MB.  Reading (10x the file),
    the GL layer and the host test are now checked before they are made."""
    from dvr_gl.renderers.base import create_renderer
    from dvr_gl.sandbox import Sandbox, SandboxError, active

    path = sphere_stl(tmp_path)  # 5120 triangles, 256 kB
    geometry = [{"path": str(path), "color": [0.3, 0.5, 0.9]}]
    with active(Sandbox(max_bytes=2 << 20)), pytest.raises(SandboxError, match="reading the mesh sphere4.stl"):
        load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": geometry})
    for name, words in (("raycast", "drawing 5120 triangles"), (DISCRETE, "testing 320 rays against 5120")):
        scene = load_scene(None, {**TILTED, "renderer.name": name, "renderer.geometry": geometry})
        with active(Sandbox(max_bytes=3 << 20)), create_renderer(name, ctx=gl_context) as renderer, \
                pytest.raises(SandboxError, match=words):
            renderer.render(scene)


def test_the_gl_surface_layer_counts_its_fragments_against_the_work_bound(tmp_path, gl_context, monkeypatch):
    """Every renderer that takes geometry estimates it: the host test its ray-triangle pairs, the GL layer
    the pixels of its triangles' boxes (huge or countless triangles refused in one line, naming them)."""
    from dvr_gl import limits
    from dvr_gl.renderers.base import create_renderer

    scene = load_scene(None, {**TILTED, "renderer.name": "raycast", "renderer.geometry": tilted(tmp_path)})
    monkeypatch.setitem(limits.BOUNDS, "gpu samples", 100.0)  # the layer: 3 triangles, boxes of 190 pixels
    monkeypatch.setattr(limits, "check_work", only_layers(limits.check_work))
    with create_renderer("raycast", ctx=gl_context) as renderer, \
            pytest.raises(DvrError, match=r"raycast would take .* gpu samples \(3 triangles covering about"):
        renderer.render(scene)


@pytest.mark.parametrize("height", [0.4, 1.5], ids=["inside", "above"])
def test_square_in_and_above_a_slab(tmp_path, gl_context, height):
    """The ray caster to float32 (measured 1.9e-7)."""
    scene = meshed_slab_scene(tmp_path, "raycast", [{"path": square(tmp_path / "square.obj", height),
                                                     "color": list(GREY)}])
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        assert renderer.stats["defines"]["GEOMETRY"]
    assert_square_in_or_above(image, scene, height, 2e-6)


@pytest.mark.parametrize("height", list(SPHERE_HEIGHTS.values()), ids=list(SPHERE_HEIGHTS))
def test_sphere_in_front_of_and_inside_a_slab(tmp_path, gl_context, height):
    """Float32: every clear pixel within 2e-6 of the true and inscribed spheres' forms."""
    scene = meshed_slab_scene(tmp_path, "raycast", sphere_geometry(tmp_path, height), **SPHERE_KEYS)
    with registry.plugin("raycast").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_within_sphere_bounds(image, scene, height, 2e-6)


def test_a_mesh_of_only_degenerate_triangles_renders_as_none(tmp_path, gl_context):
    degenerate_mesh_renders_as_none(gl_context, tmp_path, "raycast")
