"""The scene contract's keys: exclusions declared on the keys, a renderer's own keys in its namespace, and the
flags typed by the schema (dvr_gl.scene.model.exclusive_keys, dvr_gl.scene.schema.flat_renderer_table,
dvr_gl.apps.render.scene_flag)."""

from __future__ import annotations

import argparse
import dataclasses

import pytest

from dvr_gl.apps import render as render_cmd
from dvr_gl.errors import SceneError
from dvr_gl.renderers import registry
from dvr_gl.scene.model import exclusive_keys
from dvr_gl.scene.resolve import apply_overrides, load_scene, parse_scene
from dvr_gl.scene.schema import CameraSpec, TransferFunctionSpec, VolumeSpec, owned_keys
from dvr_gl.scene.settings import SHARED_GROUPS, with_sample_distance

SMALL = {"volume.demo": "blobs", "volume.size": 12, "image.width": 8, "image.height": 8}


def _owned():
    """(a renderer, one of its own keys, another renderer that does not own it) from the registry."""
    owners = owned_keys(registry.renderer_spec_class())
    key, owner = next((k, o) for k, o in owners.items() if registry.setting(k).default_value() is not None)
    other = next(n for n in registry.names() if n != owner)
    return owner, key, other


def _tolerance():
    """(the renderer that owns a key choosing the sample distance, that key): the ray caster's tolerance."""
    s = next(s for s in registry.all_settings() if "sample_distance" in s.excludes and s.owner)
    return s.owner, s.name


def _owned_choice():
    """(a grid renderer, one of its own keys with choices, a choice other than the default)."""
    s = next(s for s in registry.all_settings() if s.owner and len(s.choices) > 1
             and "grid" in (registry.plugin(s.owner).data_kinds or ("grid",)))
    return s.owner, s.name, next(c for c in s.choices if c != s.default_value())


def test_exclusions_are_read_both_ways_from_the_declarations():
    """A key excludes what it declares and what declares it (a tolerance declares the sample distances it
    chooses; the shared sample distance does not name it)."""
    spec = registry.renderer_spec_class()
    tolerance = next(s for s in registry.all_settings() if "sample_distance" in s.excludes and s.owner)
    assert tolerance.name in exclusive_keys(spec, "sample_distance")
    assert set(exclusive_keys(spec, tolerance.name)) == {"sample_distance", "sample_distance_voxels"}
    assert exclusive_keys(VolumeSpec, "demo") == ("path",)
    assert exclusive_keys(CameraSpec, "azimuth") == ("view",)
    assert exclusive_keys(TransferFunctionSpec, "file") == ("points", "preset", "labels", "table_2d", "boxes_2d")
    assert exclusive_keys(CameraSpec, "fov") == ()


def test_an_override_drops_what_it_excludes_in_either_spelling():
    owner, tol = _tolerance()
    raw = {"renderer": {"name": owner, owner: {tol: 0.01}, "sample_distance_voxels": 1.0}}
    out = apply_overrides(raw, {"renderer.sample_distance": 0.1})
    assert out["renderer"] == {"name": owner, "sample_distance": 0.1}
    assert raw["renderer"][owner] == {tol: 0.01}  # the caller's dict is left as it was
    # the namespaced spelling replaces the flat one (and the other way round)
    assert apply_overrides({"renderer": {tol: 0.01}}, {f"renderer.{owner}.{tol}": 0.02}) == {
        "renderer": {owner: {tol: 0.02}}}
    with pytest.raises(SceneError, match=f"renderer.sample_distance and renderer.{tol} were both given"):
        apply_overrides({}, {"renderer.sample_distance": 0.1, f"renderer.{owner}.{tol}": 0.01})


def test_with_renderer_and_the_viewer_drop_the_excluded_settings():
    owner, tol = _tolerance()
    scene = load_scene(None, {**SMALL, "renderer.name": owner, "renderer.sample_distance_voxels": 1.0})
    changed = scene.with_renderer(sample_distance=0.25)
    assert changed.renderer.sample_distance == 0.25 and changed.spec.renderer.sample_distance_voxels is None
    requested = dataclasses.replace(scene.renderer, **{tol: 0.01})
    finer = with_sample_distance(requested, scene.field, voxels=0.25)
    assert getattr(finer, tol) is None and finer.sample_distance == 0.25 * scene.field.sample_spacing


def test_a_sample_distance_far_past_the_box_is_refused_or_capped():
    """Past a million diagonals float32 breaks (1e39: a black picture): refused as the user gave it, in world
    units or voxels; a coarser preview of a distance near the bound (the viewer's refinement) is capped."""
    from dvr_gl.fields import diagonal
    from dvr_gl.scene.settings import MAX_SAMPLE_DIAGONALS

    for key in ("sample_distance", "sample_distance_voxels"):
        with pytest.raises(SceneError, match=f"renderer.{key} = 1e\\+39 .*times the volume's diagonal"):
            load_scene(None, {**SMALL, f"renderer.{key}": 1e39})
    scene = load_scene(None, SMALL)
    limit = MAX_SAMPLE_DIAGONALS * diagonal(scene.field)
    with pytest.raises(SceneError, match="renderer.sample_distance_voxels = 1e\\+39"):
        with_sample_distance(scene.renderer, scene.field, voxels=1e39)
    near = with_sample_distance(scene.renderer, scene.field, world=limit / 2)
    assert with_sample_distance(near, scene.field, factor=4.0).sample_distance == pytest.approx(limit)


def test_a_renderers_own_keys_read_in_its_namespace():
    owner, key, _ = _owned()
    default = registry.setting(key).default_value()
    flat = parse_scene({"renderer": {"name": owner, key: default}}).renderer
    spaced = parse_scene({"renderer": {"name": owner, owner: {key: default}}}).renderer
    assert flat == spaced
    chooser, choice_key, value = _owned_choice()
    scene = load_scene(None, {**SMALL, "renderer.name": chooser, f"renderer.{chooser}.{choice_key}": value})
    assert getattr(scene.renderer, choice_key) == value and getattr(scene.own, choice_key) == value
    assert set(vars(scene.own)) == {k for k, o in owned_keys(scene.renderer).items() if o == chooser}


@pytest.mark.parametrize("case", ["other renderer", "unnamed", "not its own", "shared", "both spellings"])
def test_a_namespaced_key_is_refused_in_one_line(case):
    owner, key, other = _owned()
    value = registry.setting(key).default_value()
    tables = {"other renderer": {"name": other, owner: {key: value}},
              "unnamed": {owner: {key: value}},
              "not its own": {"name": owner, owner: {"no_such_key": 1}},
              "shared": {"name": owner, owner: {"filter": "linear"}},
              "both spellings": {"name": owner, key: value, owner: {key: value}}}
    expected = {"other renderer": f"is {owner}'s own setting, and the scene's renderer is '{other}'",
                "unnamed": "the scene's renderer is not named", "not its own": "its own are",
                "shared": "write renderer.filter", "both spellings": "were both given: give one"}
    with pytest.raises(SceneError, match=expected[case]) as info:
        parse_scene({"renderer": tables[case]})
    assert "\n" not in str(info.value)


def test_flat_keys_of_another_renderer_keep_working():
    """The flat spelling is read as before: a renderer ignores another's own key (the conformance scenes
    give the converged reference's tolerance to every renderer)."""
    scene = load_scene(None, {**SMALL, "renderer.name": registry.default_for("grid"),
                              "renderer.converged_tolerance": 1e-3})
    assert scene.renderer.converged_tolerance == 1e-3 and not hasattr(scene.own, "converged_tolerance")


def test_owners_are_the_groups_that_name_a_renderer():
    for s in registry.all_settings():
        assert (s.owner is None) == (s.group in SHARED_GROUPS)
        if s.owner is not None:
            assert registry.plugin(s.owner).declared(s.name) is not None


def test_scene_flags_take_their_type_and_choices_from_the_schema():
    p = argparse.ArgumentParser()
    render_cmd.add_arguments(p)
    actions = {a.dest: a for a in p._actions}
    assert actions["projection"].choices == dataclasses.fields(CameraSpec)[0].metadata["choices"]
    assert actions["azimuth"].type is float and actions["header_bytes"].type is int
    assert actions["spacing"].nargs == 3 and actions["spacing"].type is float
    assert isinstance(actions["shading"], argparse.BooleanOptionalAction)
    args = p.parse_args(["-o", "x.png", "--sample-distance", "0.5", "--azimuth", "10"])
    assert render_cmd.overrides_from(args) == {"camera.azimuth": 10.0, "renderer.sample_distance": 0.5}


@pytest.mark.parametrize("name", ["ct-aaa", "no-such-preset"])
def test_a_preset_is_looked_up_once(monkeypatch, name):
    """The preset's shading (parsing) and its transfer function (resolution) read one lookup of the name as
    written (an unknown one: one line, from the one lookup)."""
    from dvr_gl.scene import resolve

    spellings = []

    def counting(text):
        spellings.append(text)
        return find_preset(text)

    find_preset = resolve.find_preset
    monkeypatch.setattr(resolve, "find_preset", counting)
    overrides = {**SMALL, "transfer_function.preset": name}
    if name == "ct-aaa":
        scene = load_scene(None, overrides)
        assert scene.renderer.shading.enabled  # Slicer's CT-AAA shades: its shading was read from the lookup
    else:
        with pytest.raises(SceneError, match="unknown transfer function preset 'no-such-preset'"):
            load_scene(None, overrides)
    assert spellings == [name]
