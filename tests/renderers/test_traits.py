"""The capabilities a renderer declares (``RendererPlugin``: order, sort_last, view_aligned_slices,
scattering_methods) are what the registry, distributed rendering and the viewer act on: each test
picks its renderers by trait, so it holds for any set of registered renderers."""

from __future__ import annotations

import pytest

from conftest import small_scene
from dvr_gl.errors import SceneError
from dvr_gl.renderers import registry
from dvr_gl.scene.model import SCATTERING_METHODS

PLUGINS = registry.plugins()


def test_the_registry_lists_the_renderers_in_their_declared_order():
    keys = [(p.order, n) for n, p in PLUGINS.items()]
    assert keys == sorted(keys)
    built_in = [p for p in PLUGINS.values() if str(p.renderer).startswith("dvr_gl.")]
    assert all(p.order < 1000 for p in built_in)  # each declares its place; others come after them
    assert len({p.order for p in built_in}) == len(built_in)


def _scattering_scene(name: str, method: str):
    sc = {"renderer.scattering.enabled": True, "renderer.scattering.method": method,
          "renderer.scattering.lights": [{"type": "directional", "direction": [0.0, 0.3, 1.0]}]}
    return small_scene({"renderer.name": name, **sc})


@pytest.mark.parametrize("name", [n for n, p in PLUGINS.items() if p.declared("scattering") is not None])
def test_scattering_is_refused_by_the_methods_it_does_not_declare(name):
    """A renderer that declares scattering takes its declared methods and refuses the others in one line,
    naming the methods it takes and the renderers of the data that take the asked one."""
    plugin = PLUGINS[name]
    for method in SCATTERING_METHODS:
        scene = _scattering_scene(name, method)
        refusal = registry.refusal(scene)
        if method in plugin.scattering_methods:
            assert refusal is None or "scattering" not in refusal, refusal
            continue
        assert refusal is not None and "\n" not in refusal and repr(method) in refusal, refusal
        assert all(repr(m) in refusal for m in plugin.scattering_methods), refusal
        takers = [n for n, p in PLUGINS.items() if method in p.scattering_methods and p.declared("scattering")
                  and registry.refusal(scene, n) is None]
        assert takers and all(n in refusal for n in takers), refusal


def test_distributed_rendering_takes_the_sort_last_renderers_only():
    plan = pytest.importorskip("dvr_gl.distributed.plan")
    sort_last = [n for n, p in PLUGINS.items() if p.sort_last]
    assert sort_last
    for name in sort_last:
        plan.check_scene(small_scene({"renderer.name": name}))
    other = next(n for n, p in PLUGINS.items() if not p.sort_last)
    with pytest.raises(SceneError) as info:
        plan.check_scene(small_scene({"renderer.name": other}))
    assert all(n in str(info.value) for n in sort_last) and other in str(info.value)


def test_the_viewer_calls_view_aligned_slices_a_slice_spacing():
    from dvr_gl.viewer import settings

    scene = small_scene()
    for name, p in PLUGINS.items():
        if p.fixed_planes or "sample_distance" not in p.setting_names:
            continue
        text = settings.sampling_text(scene.with_renderer(name=name))
        assert text.startswith("slice spacing" if p.view_aligned_slices else "sample distance"), (name, text)
    assert any(p.view_aligned_slices for p in PLUGINS.values())
