"""Clipping planes and a cropping box (``[renderer.clipping]``): closed forms for the references, the
GPU renderers against their same-discretization references in every mode, and what a scene without
clipping keeps.

The closed forms: a slab of constant extinction ``S`` and colour ``C`` seen orthographically along
-z; a pixel whose ray keeps a chord of length ``L`` has alpha ``1 - exp(-S L)`` and premultiplied
colour ``C`` alpha (Beer-Lambert).  The plane ``0.2 x - z + 0.21 >= 0`` keeps ``z <= 0.21 + 0.2 x`` of
the slab ``0 <= z <= 1``: ``L = 0.21 + 0.2 x`` where the pixel's ray is at ``x`` (1 <= x <= 3 in view).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import array_scene, assert_close
from dvr_gl.clipping import ClipRegion
from dvr_gl.errors import SceneError
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene

COLOUR = np.array([0.9, 0.6, 0.3])
SIGMA = 1.3
PLANE = [0.2, 0.0, -1.0, 0.21]  # 0.21: no slice or pixel centre on the plane (float32 would decide it)


def _slab_scene(tmp_path, renderer, clipping):
    """A slab 4 x 4 x 1 (world) of constant data, seen orthographically from +z, x and y in [1, 3]."""
    data = np.full((3, 9, 9), 0.5, np.float32)
    overrides = {"renderer.name": renderer, "transfer_function.points": [[0.0, *COLOUR, SIGMA], [1.0, *COLOUR, SIGMA]],
                 "transfer_function.opacity_model": "extinction", "image.width": 12, "image.height": 10,
                 "camera.projection": "orthographic", "camera.eye": [2.0, 2.0, 10.0], "camera.target": [2.0, 2.0, 0.5],
                 "camera.up": [0.0, 1.0, 0.0], "camera.view_height": 2.0, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-7, "renderer.clipping": clipping}
    return array_scene(tmp_path, data, overrides, spacing=(0.5, 0.5, 0.5))


def _beer_lambert(scene, chord) -> np.ndarray:
    """The expected image, ``chord(x, y)`` the kept length of each pixel's ray."""
    origins, _ = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    alpha = -np.expm1(-SIGMA * chord(origins[:, 0], origins[:, 1]))
    rgba = np.concatenate([COLOUR * alpha[:, None], alpha[:, None]], axis=1)
    return rgba.reshape(scene.image.height, scene.image.width, 4)


CASES = {
    "plane": ({"planes": [PLANE]}, lambda x, y: 0.21 + 0.2 * x),
    "box": ({"box": [[1.5, 1.4, 0.2], [2.5, 2.6, 0.7]]},
            lambda x, y: np.where((abs(x - 2.0) <= 0.5) & (abs(y - 2.0) <= 0.6), 0.5, 0.0)),
    "both": ({"planes": [PLANE], "box": [[0.0, 0.0, 0.3], [4.0, 4.0, 1.0]]},
             lambda x, y: np.maximum(0.21 + 0.2 * x - 0.3, 0.0)),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("name", ["reference", "reference-converged"])
def test_homogeneous_slab_clipped_is_beer_lambert(tmp_path, name, case):
    """Both references on the clipped chord to rounding (a constant medium's segments are exact)."""
    clipping, chord = CASES[case]
    scene = _slab_scene(tmp_path, name, clipping)
    reference = ConvergedReference(scene) if name == "reference-converged" else DiscreteReference(scene)
    image = reference.render_float64()
    expected = _beer_lambert(scene, chord)
    assert expected[..., 3].max() > 0.3 and np.abs(image - expected).max() < 1e-9


def _same_samples(scene, name) -> np.ndarray:
    """The same-discretization reference of a renderer that samples fixed planes."""
    from dvr_gl.renderers.grid.slicing import same_planes_2d, same_planes_3d
    from dvr_gl.renderers.shearwarp.renderer import reference

    return {"slicing3d": same_planes_3d, "slicing2d": same_planes_2d, "shearwarp": reference}[name](scene)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("name", ["raycast", "slicing3d", "slicing2d", "shearwarp"])
def test_gpu_renderers_clip_the_slab_as_beer_lambert(tmp_path, gl_context, name, case):
    """The ray caster ends its rays at the planes with shortened segments (float32: measured 2e-7); the
    slicers discard fragments outside and shear-warp drops samples outside, so a slice spacing s errs by
    up to S s on the chord: against their same planes instead."""
    clipping, chord = CASES[case]
    scene = _slab_scene(tmp_path, name, clipping)
    with registry.plugin(name).create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
        if name != "shearwarp":  # shear-warp clips on the host
            assert renderer.stats["defines"]["CLIPPING"]
    if name == "raycast":
        assert np.abs(image - _beer_lambert(scene, chord)).max() < 2e-6
    else:
        assert_close(image, _same_samples(scene, name))
        spacing = scene.renderer.sample_distance if name == "slicing3d" else 0.5
        assert np.abs(image - _beer_lambert(scene, chord)).max() < SIGMA * spacing


SMALL = {"volume.demo": "shepp-logan", "volume.size": 16, "image.width": 20, "image.height": 16,
         "renderer.clipping": {"planes": [[1.0, 0.4, -0.3, 1.0]], "box": [[-9.0, -4.0, -9.0], [9.0, 5.0, 6.0]]}}


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


FIXED_PLANE_CASES = [(name, extra) for name in ("slicing3d", "slicing2d", "shearwarp")
                     for extra in ({}, {"renderer.classification": "preintegrated"}, {"renderer.shading.enabled": True},
                                   {"camera.projection": "orthographic"})
                     if not (name == "shearwarp" and extra.get("renderer.classification") == "preintegrated")]


@pytest.mark.parametrize("name, extra", FIXED_PLANE_CASES,
                         ids=[f"{n}-{','.join(v for v in e.values() if isinstance(v, str)) or 'default'}"
                              f"{'-shaded' if e.get('renderer.shading.enabled') else ''}"
                              for n, e in FIXED_PLANE_CASES])
def test_fixed_plane_renderers_drop_what_is_clipped_as_their_references(gl_context, name, extra):
    """The slicers' fragments and shear-warp's samples outside the region are dropped, as their
    references' plane crossings outside each ray's interval are (measured: slicers 2.7e-7, shear-warp
    1.4e-7, no value off by more than 1e-4; shear-warp does not pre-integrate)."""
    scene = load_scene(None, {**SMALL, "renderer.name": name, **extra})
    with registry.plugin(name).create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    assert_close(image, _same_samples(scene, name))


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
        assert problem is not None and "clipping" in problem and "reference" in problem, name


@pytest.mark.parametrize("clipping, words", [
    ({"planes": [[0.0, 0.0, 0.0, 1.0]]}, "has a zero normal"),
    ({"planes": [[0.0, 0.0, 1.0]]}, "expected a list of 4 numbers"),
    ({"box": [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]}, "must be at most its second"),
    ({"planes": [[1.0, 0.0, 0.0, float(i)] for i in range(17)]}, "at most 16"),
    ({"plane": [[1.0, 0.0, 0.0, 0.0]]}, "unknown key 'plane'"),
])
def test_bad_clipping_is_one_line(clipping, words):
    with pytest.raises(SceneError) as info:
        load_scene(None, {**SMALL, "renderer.name": "reference", "renderer.clipping": clipping})
    assert words in str(info.value) and "\n" not in str(info.value)


def test_clipping_refuses_scattering_in_one_line():
    with pytest.raises(SceneError, match="the lights' rays are not clipped yet"):
        load_scene(None, {**SMALL, "renderer.name": "reference", "renderer.scattering.enabled": True})


def test_clipping_round_trips_through_a_scene_file(tmp_path):
    scene = load_scene(None, {**SMALL, "renderer.name": "reference"})
    path = tmp_path / "scene.toml"
    path.write_text(scene.to_toml())
    again = load_scene(path)
    assert again.renderer.clipping == scene.renderer.clipping
    assert math.isclose(again.renderer.clipping.planes[0][3], 1.0)


SPLATTED = {"volume.demo": "shepp-logan", "volume.size": 12, "image.width": 16, "image.height": 12,
            "renderer.name": "splatting", "renderer.filter": "gaussian", "renderer.ert_threshold": 1.0,
            "renderer.clipping": SMALL["renderer.clipping"]}


@pytest.mark.parametrize("extra", [{}, {"renderer.sheet_buffer": "axis_aligned"}, {"renderer.classification": "pre"},
                                   {"renderer.compositing": "average"}, {"renderer.filter": "cubic_bspline"}],
                         ids=["image-aligned", "axis-aligned", "pre", "average", "bspline"])
def test_splatting_integrates_the_clipped_parts_as_its_oracle(gl_context, extra):
    """Splatting's kernels are integrated over each pixel's ray part inside the clipped region (the
    sheets' parts narrowed as the box's), as its oracle integrates them (measured at most 5.4e-8)."""
    from dvr_gl.renderers.splatting.oracle import reference

    scene = load_scene(None, {**SPLATTED, **extra})
    with registry.plugin("splatting").create(ctx=gl_context) as renderer:
        image = renderer.render(scene)
    expected = reference(scene)
    unclipped = reference(scene.with_renderer(clipping=type(scene.renderer.clipping)()))
    assert np.abs(expected - unclipped).max() > 0.1 * unclipped.max()  # the clipping shows
    assert_close(image, expected)


def test_splatting_refuses_clipping_particles():
    with pytest.raises(SceneError, match="turn renderer.clipping and renderer.geometry off for particle sets"):
        registry.check(load_scene(None, {"volume.demo": "plummer", "volume.size": 8, "renderer.name": "splatting",
                                         "renderer.clipping": {"planes": [[1.0, 0.0, 0.0, 0.0]]}}))


def test_with_renderer_reads_tables_given_as_dicts():
    """``scene.with_renderer(clipping={...})`` (the API and the viewer change scenes so) reads the
    table as a scene file's: the region is the same, and a bad key is one line."""
    scene = load_scene(None, {**SMALL, "renderer.name": "reference"})
    changed = scene.with_renderer(clipping={"planes": [[0.0, 0.0, 2.0, 1.0]]})
    region = ClipRegion.of(changed.renderer)
    assert np.allclose(region.planes, [[0.0, 0.0, 1.0, 0.5]]) and not region.has_box
    with pytest.raises(SceneError, match="renderer.clipping: unknown key 'plane'"):
        scene.with_renderer(clipping={"plane": [[0.0, 0.0, 1.0, 0.0]]})
