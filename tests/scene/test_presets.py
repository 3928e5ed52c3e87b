"""Transfer-function presets: 3D Slicer's (against the shipped XML, parsed here independently),
Slicer .vp and ParaView JSON files written here, names in any case, matplotlib maps, exact viridis,
refusals, and a rendered Slicer preset against the same-discretization reference."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import array_scene, assert_close
from dvr_gl.errors import SceneError
from dvr_gl.presets import colormaps
from dvr_gl.presets.property import COLOUR_TOLERANCE
from dvr_gl.presets.slicer import PRESETS_FILE
from dvr_gl.scene.resolve import load_scene
from dvr_gl.transfer_function import PRESETS, find_preset, linear_to_srgb, preset

SLICER_NAMES = ["CT-AAA", "CT-AAA2", "CT-Bone", "CT-Bones", "CT-Cardiac", "CT-Cardiac2", "CT-Cardiac3",
                "CT-Chest-Contrast-Enhanced", "CT-Chest-Vessels", "CT-Coronary-Arteries", "CT-Coronary-Arteries-2",
                "CT-Coronary-Arteries-3", "CT-Cropped-Volume-Bone", "CT-Fat", "CT-Liver-Vasculature", "CT-Lung",
                "CT-MIP", "CT-Muscle", "CT-Pulmonary-Arteries", "CT-Soft-Tissue", "CT-Air", "CT-X-ray", "MR-Angio",
                "MR-Default", "MR-MIP", "MR-T2-Brain", "DTI-FA-Brain", "US-Fetal"]


def _source():
    """Slicer's presets read straight from the XML: name -> (opacity pairs, colour quadruples, attributes)."""
    out = {}
    for e in ET.parse(PRESETS_FILE).getroot():
        def rows(key, width):
            n = [float(t) for t in e.attrib[key].split()]
            assert n[0] == len(n) - 1
            return np.array(n[1:]).reshape(-1, width)
        out[e.attrib["name"]] = (rows("scalarOpacity", 2), rows("colorTransfer", 4), e.attrib)
    return out


SOURCE = _source()


def test_every_slicer_preset_is_shipped_under_its_name():
    assert set(SLICER_NAMES) <= set(SOURCE) <= set(PRESETS)


@pytest.mark.parametrize("name", sorted(SOURCE))
def test_slicer_preset_matches_the_xml(name):
    """At each control value of the source, opacity is the source's (exactly: it is linear in value
    in both) and colour, back in sRGB, the source's; between colour points, the source's RGB
    interpolation within COLOUR_TOLERANCE (half an 8-bit step) wherever there is opacity."""
    opacity, colours, _ = SOURCE[name]
    with pytest.warns(UserWarning) if name == "uCT-Skull" else _no_warning():
        tf = preset(name, (0.0, 1.0))
    single = lambda x: np.sum(x == x[:, None], axis=0) == 1  # noqa: E731 (repeated values are nudged apart)
    ox, ok = opacity[:, 0], single(opacity[:, 0])
    np.testing.assert_allclose(tf.opacity(ox[ok]), opacity[ok, 1], atol=1e-12)
    cx, ck = colours[:, 0], single(colours[:, 0])
    np.testing.assert_allclose(linear_to_srgb(tf.color(cx[ck])), colours[ck, 1:], atol=1e-9)
    between = np.linspace(cx[0], cx[-1], 4001)
    between = between[(tf.opacity(between) > 0) & ~np.isin(between, cx)]
    last = np.r_[cx[1:] != cx[:-1], True]  # just above a repeated value, the later point holds
    source_rgb = np.stack([np.interp(between, cx[last], colours[last, c]) for c in (1, 2, 3)], axis=-1)
    assert np.abs(linear_to_srgb(tf.color(between)) - source_rgb).max() <= COLOUR_TOLERANCE + 1e-9


class _no_warning:
    def __enter__(self):
        import warnings
        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        self._w.__exit__(*exc)


def test_values_read_off_the_source_by_hand():
    """CT-AAA in Slicer's presets.xml: opacity 0.696078 at 214.389 HU, colour 1 1 1 there, 0 below
    143.556 HU; shade 1, ambient 0.1, diffuse 0.9, specular 0.2, specular power 10."""
    tf = preset("CT-AAA", (0, 1))
    assert tf.opacity([214.389])[0] == pytest.approx(0.696078)
    assert tf.opacity([100.0])[0] == 0.0
    np.testing.assert_allclose(tf.color([214.389])[0], [1, 1, 1])
    scene = load_scene(None, {"volume.demo": "blobs", "volume.size": 8, "transfer_function.preset": "ct-aaa"})
    sh = scene.renderer.shading
    assert (sh.enabled, sh.ambient, sh.diffuse, sh.specular, sh.shininess) == (True, 0.1, 0.9, 0.2, 10.0)


def test_names_in_any_case_and_the_old_five():
    for a, b in [("CT-AAA", "ct-aaa"), ("MR-Default", "mr-DEFAULT"), ("CT-Bone", "CT-BONE")]:
        np.testing.assert_array_equal(preset(a, (0, 1)).points, preset(b, (0, 1)).points)
    assert len(preset("ct-bone-ivory", (0, 1)).points) == 5  # dvr-gl's own
    np.testing.assert_array_equal(preset("ct-bone", (0, 1)).points, preset("CT-Bone", (0, 1)).points)  # Slicer's
    assert len(preset("ct-bone", (0, 1)).points) > 5
    for name in ("grayscale", "viridis", "ct-bone-ivory", "ct-skin", "shepp-logan", "GrayScale"):
        assert preset(name, (0, 100)).points[:, 4].max() > 0


def test_no_two_preset_names_differ_only_by_case():
    """One namespace without regard to case: every spelling of a name finds the same preset."""
    folded = {}
    for name in PRESETS:
        assert name.lower() not in folded, f"{name} and {folded[name.lower()]} differ only by case"
        folded[name.lower()] = name
        assert find_preset(name.upper()) == find_preset(name.lower()) == name


def test_rescale_intercept_places_hounsfield_units():
    """Data stored as HU + 1024 (CThead): rescale_intercept = -1024 moves every point up 1024."""
    hu, shifted = preset("CT-Bone", (0, 1)), preset("CT-Bone", (0, 1), rescale_intercept=-1024)
    np.testing.assert_allclose(shifted.points[:, 0], hu.points[:, 0] + 1024)
    np.testing.assert_array_equal(shifted.points[:, 1:], hu.points[:, 1:])


def test_user_shading_wins_over_the_preset():
    base = {"volume.demo": "blobs", "volume.size": 8, "transfer_function.preset": "CT-AAA"}
    off = load_scene(None, {**base, "renderer.shading.enabled": False}).renderer.shading
    assert not off.enabled and off.ambient == 0.1  # the coefficients not given still come from the preset
    mine = load_scene(None, {**base, "renderer.shading.ambient": 0.5}).renderer.shading
    assert mine.enabled and mine.ambient == 0.5
    unshaded = load_scene(None, {**base, "transfer_function.preset": "CT-Soft-Tissue"}).renderer.shading
    assert not unshaded.enabled  # shade="0" in Slicer's file


def test_viridis_is_matplotlibs_table():
    """The shipped table's first and last entries as matplotlib prints them (no matplotlib needed)."""
    tf = preset("viridis", (0.0, 255.0))
    assert len(tf.points) == 256
    np.testing.assert_allclose(linear_to_srgb(tf.color([0.0, 255.0])), [[0.267004, 0.004874, 0.329415],
                                                                       [0.993248, 0.906157, 0.143936]], atol=1e-12)
    np.testing.assert_allclose(tf.opacity([0.0, 127.5, 255.0]), [0.0, 0.05, 0.1])


def test_viridis_against_matplotlib():
    matplotlib = pytest.importorskip("matplotlib")
    ours = linear_to_srgb(preset("viridis", (0.0, 255.0)).color(np.arange(256.0)))
    theirs = matplotlib.colormaps["viridis"](np.arange(256))[:, :3]
    assert np.abs(ours - theirs).max() < 1e-12


def test_matplotlib_map_by_name():
    matplotlib = pytest.importorskip("matplotlib")
    tf = preset("Inferno", (10.0, 20.0))
    theirs = matplotlib.colormaps["inferno"]([0, 128, 255])[:, :3]
    np.testing.assert_allclose(linear_to_srgb(tf.color([10.0, 10.0 + 1280 / 255, 20.0])), theirs, atol=1e-12)
    np.testing.assert_allclose(tf.opacity([10.0, 20.0]), [0.0, 0.1])


def test_matplotlib_missing_says_which_extra(monkeypatch):
    monkeypatch.setattr(colormaps, "matplotlib_names", lambda: None)
    with pytest.raises(SceneError, match=r"pip install -e '\.\[plot\]'"):
        preset("inferno", (0, 1))
    assert preset("viridis", (0, 1)).points.shape == (256, 5)  # the shipped table needs no matplotlib


def test_unknown_name_suggests_close_matches():
    with pytest.raises(SceneError, match="did you mean CT-AAA") as info:
        preset("ct-aa", (0, 1))
    assert "\n" not in str(info.value)


VP = """1
1
0.9
0.1
0.2
10
8 -1000 0 100 0 300 0.5 2000 0.8
4 0 1 255 1
16 -1000 0 0 0 100 0.8 0.4 0.2 300 1 1 1 2000 1 1 0.9
"""


def test_slicer_vp_file_in_a_scene(tmp_path):
    """A .vp written here, named relative to the scene file: the points and shading as written."""
    (tmp_path / "tf").mkdir()
    (tmp_path / "tf" / "bone.vp").write_text(VP)
    np.save(tmp_path / "v.npy", np.zeros((4, 4, 4), np.int16))
    (tmp_path / "s.toml").write_text('[volume]\npath = "v.npy"\n[transfer_function]\nfile = "tf/bone.vp"\n'
                                     'rescale_intercept = -1024.0\n')
    scene = load_scene(tmp_path / "s.toml")
    tf = scene.transfer_function
    assert tf.opacity([300 + 1024])[0] == pytest.approx(0.5)
    np.testing.assert_allclose(linear_to_srgb(tf.color([100 + 1024]))[0], [0.8, 0.4, 0.2], atol=1e-12)
    sh = scene.renderer.shading
    assert (sh.enabled, sh.diffuse, sh.ambient, sh.specular, sh.shininess) == (True, 0.9, 0.1, 0.2, 10.0)
    again = scene.replace(volume=scene.field)  # re-resolved from another folder: the path was made absolute
    np.testing.assert_array_equal(again.transfer_function.points, tf.points)


COOL_TO_WARM = {"Name": "Cool to Warm", "ColorSpace": "Diverging",
                "RGBPoints": [0, 0.231373, 0.298039, 0.752941, 1, 0.705882, 0.0156863, 0.14902]}


def _scene_with_file(tmp_path, file_name, content, **tf):
    path = tmp_path / file_name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content if isinstance(content, str) else json.dumps(content))
    data = np.linspace(0, 200, 64, dtype=np.float32).reshape(4, 4, 4)
    return array_scene(tmp_path, data, {"transfer_function.file": str(path),
                                        **{f"transfer_function.{k}": v for k, v in tf.items()}})


def test_paraview_json_diverging_map_is_stretched(tmp_path):
    """ParaView's Cool to Warm, stretched onto the data's 0..200: its middle is Moreland's grey
    (221, 221, 221) and its quarter (141, 176, 254) (his paper's table, 8-bit, so +-1 code)."""
    tf = _scene_with_file(tmp_path, "c2w.json", [COOL_TO_WARM]).transfer_function
    srgb = linear_to_srgb(tf.color([0.0, 50.0, 100.0, 200.0])) * 255
    np.testing.assert_allclose(srgb[1:3], [[141, 176, 254], [221, 221, 221]], atol=1.0)
    np.testing.assert_allclose(srgb[[0, 3]] / 255, [COOL_TO_WARM["RGBPoints"][1:4], COOL_TO_WARM["RGBPoints"][5:]],
                               atol=1e-9)
    np.testing.assert_allclose(tf.opacity([0.0, 200.0]), [0.0, 0.1])  # no "Points": the stated ramp


def test_paraview_json_absolute_values_and_opacity_points(tmp_path):
    m = {"Name": "abs", "ColorSpace": "RGB", "RGBPoints": [20, 0, 0, 1, 120, 1, 0, 0],
         "Points": [20, 0, 0.5, 0, 120, 0.8, 0.25, 0, 150, 0.4, 0.5, 0]}
    tf = _scene_with_file(tmp_path, "abs.json", [{"Name": "other", **COOL_TO_WARM}, m],
                          stretch=False, name="ABS").transfer_function
    # 120..150 has midpoint 0.25: half way (0.6) a quarter along, at 127.5
    assert tf.opacity([20.0, 70.0, 120.0, 127.5, 150.0]) == pytest.approx([0.0, 0.4, 0.8, 0.6, 0.4])
    np.testing.assert_allclose(linear_to_srgb(tf.color([20.0, 120.0])), [[0, 0, 1], [1, 0, 0]], atol=1e-12)


@pytest.mark.parametrize("name, content, message", [
    ("x.json", "{not json", "not valid JSON"),
    ("x.json", [{"Name": "a", "IndexedColors": [1, 0, 0]}], "no RGBPoints"),
    ("x.json", [{"Name": "a", "RGBPoints": [0, 1, 0]}], "not a non-empty multiple of 4"),
    ("x.json", [{"Name": "a", "ColorSpace": "Step", "RGBPoints": [0, 1, 0, 0, 1, 0, 0, 1]}], "Step"),
    ("x.json", [{"Name": "a", "RGBPoints": [0, 0, 0, 0, 1, 1, 1, 1], "Points": [0, 0, 0.5, 0.7, 1, 1, 0.5, 0]}],
     "sharpness"),
    ("x.json", [COOL_TO_WARM, {**COOL_TO_WARM, "Name": "b"}], "holds 2 colour maps"),
    ("x.json", [{"Name": "a", "RGBPoints": [0, 2, 0, 0]}], "outside"),
    ("x.vp", VP.replace("4 0 1 255 1\n", ""), "8 lines"),
    ("x.vp", VP.replace("8 -1000", "9 -1000"), "does not match"),
    ("x.vp", VP.replace("\n0.9\n", "\nabc\n"), "diffuse: not a number"),
    ("x.vp", b"\xff\xfe\x00", "not a text file"),
    ("x.xml", "<MRML><VolumeProperty", "not a valid XML"),
    ("x.xml", "<MRML/>", "no VolumeProperty"),
    ("x.lut", "1 2 3", "cannot tell the transfer function format"),
    # issue 40: nesting, entity declarations, numbers that are not
    ("x.json", "[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ("x.xml", '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;&a;">]><MRML '
              'x="&b;"/>', "DOCTYPE or entity declaration"),
    ("x.xml", '<?xml version="1.0" encoding="UTF-16"?><!DOCTYPE l [<!ENTITY a "a">]><MRML/>'.encode("utf-16"),
     "DOCTYPE or entity declaration"),
    ("x.xml", '<!DOCTYPE MRML SYSTEM "/etc/passwd"><MRML/>', "DOCTYPE or entity declaration"),
    ("x.vp", VP.replace("8 -1000 0 100", "8 -1000 nan 100"), "NaN or infinite"),
    ("x.vp", VP.replace("8 -1000 0 100", "8 -1000 0 1e999"), "NaN or infinite"),
    ("x.vp", VP.replace("8 -1000", "8.5 -1000"), "does not match"),
    ("x.vp", VP.replace("8 -1000", "-8 -1000"), "does not match"),
    ("x.vp", VP.replace("\n10\n", "\ninf\n"), "specular power: not a finite number"),
    ("x.json", '[{"Name": "a", "RGBPoints": [0, 0, 0, 0, NaN, 1, 1, 1]}]', "NaN or infinite"),
    ("x.json", '[{"Name": "a", "RGBPoints": [0, 0, 0, 0, 1e999, 1, 1, 1]}]', "NaN or infinite"),
    ("x.json", '[{"Name": "a", "RGBPoints": [0, 0, 0, "x", 1, 1, 1, 1]}]', "not a list of numbers"),
    ("x.json", '[{"Name": "a", "RGBPoints": {"x": 1}}]', "not a list of numbers"),
])
def test_malformed_files_are_one_line(tmp_path, name, content, message):
    with pytest.raises(SceneError, match=message) as info:
        _scene_with_file(tmp_path, name, content)
    assert "\n" not in str(info.value)


def test_cli_names_files_and_refusals(tmp_path):
    dvr = [sys.executable, "-m", "dvr_gl.apps"]
    common = ["render", "--demo", "blobs", "--size", "24x24"]
    (tmp_path / "m.vp").write_text(VP)
    for arg, out in [("ct-aaa", "a.png"), (str(tmp_path / "m.vp"), "b.png")]:
        run = subprocess.run(dvr + common + ["--transfer-function", arg, "-o", str(tmp_path / out)],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        assert (tmp_path / out).is_file()
    run = subprocess.run(dvr + common + ["--transfer-function", "CT-Bonez", "-o", str(tmp_path / "c.png")],
                         capture_output=True, text=True)
    assert run.returncode == 1 and "did you mean CT-Bone" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and not (tmp_path / "c.png").exists()


def ct_phantom(n: int = 20) -> np.ndarray:
    """A CT-like int16 volume in HU: air (-1000) around a soft-tissue ball (40 HU) holding a bone
    ball (1200 HU), the boundaries ramped over two voxels so that gradients are smooth."""
    z, y, x = np.mgrid[:n, :n, :n] - (n - 1) / 2
    r = np.sqrt(x * x + y * y + (1.2 * z) ** 2)
    tissue = np.clip((0.42 * n - r) / 2, 0, 1)
    bone = np.clip((0.3 * n - r) / 2, 0, 1)
    return np.round(-1000 + 1040 * tissue + 1160 * bone).astype(np.int16)


def test_slicer_preset_rendered_against_the_reference(tmp_path, gl_context):
    """CT-AAA (shaded, opacity per mm) on the phantom: the grid's default GPU renderer (the ray caster)
    against its oracle, the float64 same-discretization reference, with assert_close's bounds (at most
    0.5 % of values off by more than 1e-4, mean 2e-6 over the rest).  Measured: max 1.4e-4 (0.03 % of
    values above 1e-4), mean 2.9e-7: the usual float32-against-float64 error, well inside."""
    from dvr_gl.renderers import create_renderer, registry

    default = registry.default_for("grid")
    scene = array_scene(tmp_path, ct_phantom(), {"transfer_function.preset": "CT-AAA", "image.width": 40,
                                                 "image.height": 40, "renderer.ert_threshold": 1.0},
                        spacing=(0.8, 0.8, 1.0))
    assert scene.renderer.shading.enabled
    reference = registry.plugin(default).oracle_image(scene)
    assert reference[..., 3].max() > 0.9 and reference[..., 3].min() == 0.0  # the bone shows, air does not
    gpu = create_renderer(default, ctx=gl_context)
    try:
        image = gpu.render(scene)
    finally:
        gpu.close()
    assert_close(image, reference)


def test_unsorted_and_duplicate_points_are_made_increasing_as_slicer_does(tmp_path):
    """Slicer's HigherAndUnique: a value not above the last moves 10 float32 steps above it (the vectorized
    check agrees with the loop, value by value)."""
    from dvr_gl.presets.property import unique_values

    def by_loop(x):
        out = np.array(x, dtype=np.float64)
        for i in range(1, len(out)):
            floor = np.float32(out[i - 1]) if out[i - 1] != 0 else np.finfo(np.float32).tiny
            for _ in range(10):
                floor = np.nextafter(floor, np.float32(np.inf))
            out[i] = max(out[i], float(floor))
        return out

    rng = np.random.default_rng(0)
    for x in ([0.0, 0, 0, 1, 1, 2], [5.0, 1, 0, -3], [-2.0, -2, -2, -1.9999999], np.round(rng.normal(size=300), 1),
              np.sort(rng.normal(size=300)), [1.0]):
        np.testing.assert_array_equal(unique_values(x), by_loop(x))
    vp = VP.replace("16 -1000 0 0 0 100 0.8 0.4 0.2", "16 100 0 0 0 100 0.8 0.4 0.2")  # a repeated colour value
    tf = _scene_with_file(tmp_path, "dup.vp", vp).transfer_function
    assert np.all(np.diff(tf.points[:, 0]) > 0)


def _big_map(count: int, space: str, rng) -> dict:
    values = np.linspace(0.0, 1000.0, count)
    return {"Name": "big", "ColorSpace": space, "RGBPoints": np.column_stack([values, rng.random((count, 3))]).ravel()
            .tolist(), "Points": [0, 0.5, 0.5, 0, 1000, 0.5, 0.5, 0]}


@pytest.mark.parametrize("space", ["RGB", "Lab", "HSV", "Diverging"])
def test_many_points_take_a_few_passes_not_one_per_segment(tmp_path, space, monkeypatch):
    """The conversion interpolates the whole map a few times per block of 1024 segments (it did so once
    per segment, over the whole map each time: a 40,000-point .vp took 90 s)."""
    from dvr_gl.presets import colour

    calls = []
    real = colour.interpolate
    monkeypatch.setattr(colour, "interpolate", lambda *a, **k: calls.append(len(a[0])) or real(*a, **k))
    tf = _scene_with_file(tmp_path, "big.json", [_big_map(1500, space, np.random.default_rng(1))],
                          stretch=False).transfer_function
    assert len(tf.points) >= 1500 and len(calls) <= 2 * (1 + 7) + 2
    # and each block's calls see the rows of its own segments, not the whole map (converted to Lab or Msh)
    assert sorted(calls)[-2] <= 2 * 1024 and max(calls) == 1500
    assert np.isfinite(tf.points).all() and np.all(np.diff(tf.points[:, 0]) > 0)


def test_a_large_vp_file_loads_in_seconds(tmp_path):
    """Issue 40's case at half the size: 20,000 opacity and colour points (40,000 took 90 s before, 8 s
    now on a loaded 2-core machine, most of it the conversion's 257 probes per segment)."""
    import time

    n = 20_000
    v = np.linspace(-1000, 3000, n)
    ramp = np.linspace(0, 1, n)
    opacity = " ".join(f"{x:.6f} {a:.6f}" for x, a in zip(v, ramp))
    colours = " ".join(f"{x:.6f} {a:.6f} {a:.6f} {a:.6f}" for x, a in zip(v, ramp))
    text = "\n".join(["1", "1", "0.9", "0.1", "0.2", "10", f"{2 * n} {opacity}", "4 0 1 255 1", f"{4 * n} {colours}"])
    start = time.perf_counter()
    tf = _scene_with_file(tmp_path, "big.vp", text + "\n").transfer_function
    assert time.perf_counter() - start < 20 and len(tf.points) >= n


def test_rescale_intercept_beyond_its_range_names_the_key(tmp_path):
    """A huge intercept collapses the preset's points ``HU - intercept`` onto one float64 value: the message
    names the intercept, not points the user never gave."""
    for value in (1e300, 1e30, -1e13):
        with pytest.raises(SceneError, match=r"transfer_function.rescale_intercept \(--rescale-intercept\)") as info:
            preset("CT-Bone", (0.0, 4000.0), value)
        assert "points" not in str(info.value)
    assert preset("CT-Bone", (0.0, 4000.0), -1e9).domain[0] == pytest.approx(-3024 + 1e9)
