"""Clipping planes and a cropping box (``[renderer.clipping]``): closed forms for the references, the
GPU renderers against their same-discretization references in every mode (each in its folder:
``dvr_gl/renderers/NAME/tests/test_clipping_NAME.py``), and what a scene without clipping keeps.

The closed forms: a slab of constant extinction ``S`` and colour ``C`` seen orthographically along
-z; a pixel whose ray keeps a chord of length ``L`` has alpha ``1 - exp(-S L)`` and premultiplied
colour ``C`` alpha (Beer-Lambert).  The plane ``0.2 x - z + 0.21 >= 0`` keeps ``z <= 0.21 + 0.2 x`` of
the slab ``0 <= z <= 1``: ``L = 0.21 + 0.2 x`` where the pixel's ray is at ``x`` (1 <= x <= 3 in view).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dvr_gl.clipping import ClipRegion
from dvr_gl.errors import SceneError
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from judges import CONVERGED, DISCRETE
from slab_scenes import CASES, beer_lambert, clipped_slab_scene
from slab_scenes import CLIPPED_PHANTOM as SMALL


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("name", [DISCRETE, CONVERGED])
def test_homogeneous_slab_clipped_is_beer_lambert(tmp_path, name, case):
    """Both references on the clipped chord to rounding (a constant medium's segments are exact)."""
    clipping, chord = CASES[case]
    scene = clipped_slab_scene(tmp_path, name, clipping)
    reference = ConvergedReference(scene) if name == CONVERGED else DiscreteReference(scene)
    image = reference.render_float64()
    expected = beer_lambert(scene, chord)
    assert expected[..., 3].max() > 0.3 and np.abs(image - expected).max() < 1e-9


def test_clip_region_interval_and_inside_agree():
    """The interval of a ray is where its points are inside (sampled densely), for random rays."""
    rng = np.random.default_rng(4)
    spec = type("C", (), {"planes": [(1.0, 2.0, -0.5, 0.3), (-0.2, 0.0, 1.0, 1.0)],
                          "box": ((-1.0, -1.5, -2.0), (1.0, 1.0, 2.0))})()
    clip = ClipRegion.of(type("R", (), {"clipping": spec})())
    origins = rng.uniform(-3, 3, (200, 3))
    directions = rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    t0, t1 = clip.interval(origins, directions, np.full(200, -10.0), np.full(200, 10.0))
    t = np.linspace(-10, 10, 4001)
    points = origins[:, None, :] + t[None, :, None] * directions[:, None, :]
    inside = clip.inside(points.reshape(-1, 3)).reshape(200, -1)
    for i in range(200):
        kept = t[inside[i]]
        if len(kept) == 0:
            assert t1[i] - t0[i] < 2 * (t[1] - t[0])
        else:
            assert abs(kept[0] - t0[i]) <= t[1] - t[0] and abs(kept[-1] - t1[i]) <= t[1] - t[0]
            assert len(kept) == np.count_nonzero((t >= kept[0]) & (t <= kept[-1]))  # one interval


def test_renderers_without_clipping_refuse_it():
    """Every renderer that does not declare the setting refuses a scene that clips, naming those that do."""
    for name in registry.names():
        plugin = registry.plugin(name)
        if (plugin.declared("clipping") is not None
                or (plugin.data_kinds is not None and "grid" not in plugin.data_kinds)):
            continue
        filters = plugin.choices("filter")
        scene = load_scene(None, {**SMALL, "renderer.filter": "linear" if "linear" in filters else filters[0],
                                  "camera.projection": plugin.projections[0],
                                  "renderer.compositing": plugin.choices("compositing")[0]})
        problem = registry.refusal(scene, name)
        assert problem is not None and "clipping" in problem and DISCRETE in problem, name


@pytest.mark.parametrize("clipping, words", [
    ({"planes": [[0.0, 0.0, 0.0, 1.0]]}, "has a zero normal"),
    ({"planes": [[0.0, 0.0, 1.0]]}, "expected a list of 4 numbers"),
    ({"box": [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]}, "must be at most its second"),
    ({"planes": [[1.0, 0.0, 0.0, float(i)] for i in range(17)]}, "at most 16"),
    ({"plane": [[1.0, 0.0, 0.0, 0.0]]}, "unknown key 'plane'"),
])
def test_bad_clipping_is_one_line(clipping, words):
    with pytest.raises(SceneError) as info:
        load_scene(None, {**SMALL, "renderer.name": DISCRETE, "renderer.clipping": clipping})
    assert words in str(info.value) and "\n" not in str(info.value)


def test_clipping_refuses_scattering_in_one_line():
    with pytest.raises(SceneError, match="the lights' rays are not clipped yet"):
        load_scene(None, {**SMALL, "renderer.name": DISCRETE, "renderer.scattering.enabled": True})


def test_clipping_round_trips_through_a_scene_file(tmp_path):
    scene = load_scene(None, {**SMALL, "renderer.name": DISCRETE})
    path = tmp_path / "scene.toml"
    path.write_text(scene.to_toml())
    again = load_scene(path)
    assert again.renderer.clipping == scene.renderer.clipping
    assert math.isclose(again.renderer.clipping.planes[0][3], 1.0)


def test_with_renderer_reads_tables_given_as_dicts():
    """``scene.with_renderer(clipping={...})`` (the API and the viewer change scenes so) reads the
    table as a scene file's: the region is the same, and a bad key is one line."""
    scene = load_scene(None, {**SMALL, "renderer.name": DISCRETE})
    changed = scene.with_renderer(clipping={"planes": [[0.0, 0.0, 2.0, 1.0]]})
    region = ClipRegion.of(changed.renderer)
    assert np.allclose(region.planes, [[0.0, 0.0, 1.0, 0.5]]) and not region.has_box
    with pytest.raises(SceneError, match="renderer.clipping: unknown key 'plane'"):
        scene.with_renderer(clipping={"plane": [[0.0, 0.0, 1.0, 0.0]]})
