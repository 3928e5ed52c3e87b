"""The public Python API: dvr_gl.render on arrays, fields, files and scenes; the Image it returns;
scenes that re-resolve when their field changes; compact reprs."""

import numpy as np
import pytest

import dvr_gl
from conftest import REPO, small_scene
from dvr_gl.image import read_image
from dvr_gl.renderers import create_renderer, registry
from judges import CONVERGED, DISCRETE
from judges import renderers as declaring

#: the renderer a grid gets when none is named, and another GL grid renderer
DEFAULT = registry.default_for("grid")
OTHER = next(n for n in declaring(kind="grid", gl=True) if n != DEFAULT)
#: a renderer without maximum intensity projection among its compositing modes
NO_MIP = next(n for n in registry.names() if "mip" not in registry.plugin(n).choices("compositing"))


def blob(shape=(20, 16, 12)):
    z, y, x = np.indices(shape, dtype=np.float32)
    c = [(n - 1) / 2 for n in shape]
    return np.exp(-((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) / 20.0).astype(np.float32)


def test_the_top_level_exports_the_parts():
    for name in ("render", "Image", "Scene", "load_scene", "Volume", "Field", "TransferFunction", "Camera",
                 "create_renderer", "registry"):
        assert hasattr(dvr_gl, name), name


def test_render_of_an_array_is_the_renderer_on_the_resolved_scene():
    """The array with x-first spacing, a preset and the camera keywords: the same image as the default
    renderer on the scene the API resolved, and that scene holds what was given."""
    data = blob()
    image = dvr_gl.render(data, spacing=(0.5, 1.0, 2.0), transfer_function="viridis", azimuth=40, elevation=10,
                          size=(40, 30), sample_distance_voxels=0.25)
    scene = image.scene
    assert scene.volume.dims == (12, 16, 20) and scene.volume.spacing == (0.5, 1.0, 2.0)
    assert scene.camera.orbit[:2] == (40.0, 10.0) and (scene.image.width, scene.image.height) == (40, 30)
    assert scene.renderer.sample_distance == pytest.approx(0.125)   # a quarter of the smallest spacing
    assert scene.renderer.name == DEFAULT
    with create_renderer(DEFAULT) as r:
        np.testing.assert_array_equal(image.rgba, r.render(scene))
    assert image.rgba.shape == (30, 40, 4) and image.rgba.dtype == np.float32 and image.rgba[..., 3].max() > 0.05


def test_keywords_reach_every_renderer_setting_and_unknown_ones_are_named():
    image = dvr_gl.render(blob(), renderer=DISCRETE, compositing="mip", filter="nearest", size=16)
    assert (image.scene.renderer.name, image.scene.renderer.compositing, image.scene.renderer.filter) == (
        DISCRETE, "mip", "nearest")
    with pytest.raises(dvr_gl.SceneError, match="unknown keyword 'sample_distanse'; renderer settings are"):
        dvr_gl.render(blob(), sample_distanse=0.5)
    with pytest.raises(dvr_gl.SceneError, match=f"{NO_MIP} does not support renderer.compositing = 'mip'"):
        dvr_gl.render(blob(), renderer=NO_MIP, compositing="mip", size=8)


def test_shading_keyword_and_transfer_function_points():
    points = [[0.0, 0.2, 0.4, 0.9, 0.0], [1.0, 1.0, 0.8, 0.3, 0.5]]
    image = dvr_gl.render(blob(), transfer_function=points, shading=True, size=16)
    assert image.scene.renderer.shading.enabled
    np.testing.assert_array_equal(image.scene.transfer_function.points, points)


def test_scattering_keyword():
    """scattering=True lights by single scattering (shading off unless asked for, which is refused beside
    it); a dict gives [renderer.scattering]'s keys."""
    lit = dvr_gl.render(blob(), scattering=True, size=12)
    assert lit.scene.renderer.scattering.enabled and not lit.scene.renderer.shading.enabled
    assert float(np.abs(lit.rgba - dvr_gl.render(blob(), size=12).rgba).max()) > 1e-3
    volume = dvr_gl.render(blob(), size=12, scattering={"method": "light_volume", "light_volume_size": 8,
                                                        "lights": [{"direction": (1.0, 0.0, -1.0)}]})
    assert volume.scene.renderer.scattering.lights[0].direction == (1.0, 0.0, -1.0)
    with pytest.raises(dvr_gl.SceneError, match="turn one off"):
        dvr_gl.render(blob(), scattering=True, shading=True, size=8)


def test_clipping_keyword():
    """clipping={...} gives [renderer.clipping]'s keys: a plane through the blob's middle (z = 9.5) keeps its
    upper half."""
    cut = dvr_gl.render(blob(), size=12, renderer=DISCRETE, clipping={"planes": [[0.0, 0.0, 1.0, -9.5]]})
    assert cut.scene.renderer.clipping.planes == [(0.0, 0.0, 1.0, -9.5)]
    whole = dvr_gl.render(blob(), size=12, renderer=DISCRETE)
    assert 0.0 < cut.rgba[..., 3].sum() < 0.9 * whole.rgba[..., 3].sum()
    with pytest.raises(dvr_gl.SceneError, match="zero normal"):
        dvr_gl.render(blob(), size=8, clipping={"planes": [[0.0, 0.0, 0.0, 1.0]]})


def test_render_of_files_and_of_scenes(tmp_path):
    path = tmp_path / "blob.npy"
    np.save(path, blob())
    from_file = dvr_gl.render(path, spacing=(1, 1, 2), size=16)
    assert from_file.scene.volume.spacing == (1.0, 1.0, 2.0)
    from_array = dvr_gl.render(blob(), spacing=(1, 1, 2), size=16)
    np.testing.assert_array_equal(from_file.rgba, from_array.rgba)
    scene_file = REPO / "examples" / "shepp-logan.toml"
    # The demo's scene file has a 2D transfer function (value x gradient magnitude), which the default
    # renderer takes; another renderer takes the scene with a 1D function given beside it.
    from_toml = dvr_gl.render(scene_file, size=16)
    assert from_toml.scene.renderer.name == DEFAULT and from_toml.scene.volume.name == "shepp-logan"
    again = dvr_gl.render(from_toml.scene, renderer=OTHER, transfer_function="grayscale", azimuth=0)
    assert again.scene.renderer.name == OTHER and again.scene.camera.orbit[0] == 0.0
    assert again.scene.volume is from_toml.scene.volume


def test_image_pixels_and_files(tmp_path):
    image = dvr_gl.render(blob(), size=24, background=(0.1, 0.2, 0.3))
    composited = image.composited()
    np.testing.assert_allclose(composited[..., :3], image.rgba[..., :3] + (1 - image.rgba[..., 3:]) * [0.1, 0.2, 0.3],
                               atol=1e-6)
    png = image.save(tmp_path / "x.png")
    assert np.array_equal(np.round(read_image(png) * 255).astype(np.uint8), image.srgb8())
    exr = image.save(tmp_path / "x.exr")
    np.testing.assert_allclose(read_image(exr), composited, atol=1e-7)
    with pytest.raises(dvr_gl.DvrError, match="exists"):
        image.save(png)
    with pytest.raises(dvr_gl.DvrError, match="output file's path holds a NUL byte"):
        image.save(tmp_path / "x\x00.png")
    with pytest.raises(dvr_gl.DvrError, match="output file's path is too long|a name in the output file's path"):
        image.save(tmp_path / ("a" * 300) / "x.png")
    with pytest.raises(dvr_gl.DvrError, match="volume file's path holds a NUL byte"):
        dvr_gl.render(str(tmp_path / "v\x00.nrrd"))
    assert image._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"
    assert repr(image).startswith(f"Image(24x24, {DEFAULT}")


def test_replacing_the_volume_reframes_and_re_resolves():
    """The issue's trap: a scene built for one volume, given another. The camera keeps its direction
    but aims at the new box's centre from a distance that frames it; the preset spans the new values;
    the default iso-value and the sample distance in voxels follow the new data."""
    scene = small_scene({"camera.azimuth": 70.0, "renderer.sample_distance_voxels": 0.5})
    far = dvr_gl.Volume(10.0 * blob(), spacing=(3.0, 3.0, 3.0), origin=(100.0, 50.0, 0.0))
    moved = scene.replace(volume=far)
    lo, hi = far.box
    np.testing.assert_allclose(moved.camera.target, (lo + hi) / 2)
    assert moved.camera.orbit[:2] == pytest.approx(scene.camera.orbit[:2])
    from dvr_gl.camera import framing_distance
    radius = float(np.linalg.norm(hi - lo)) / 2
    assert moved.camera.orbit[2] == pytest.approx(framing_distance(radius, scene.camera.fov, 1.0))  # frames it
    assert moved.renderer.sample_distance == pytest.approx(1.5)              # 0.5 voxel of 3 units
    iso = moved.with_renderer(compositing="isosurface").renderer.iso_value  # resolved where used
    assert iso == pytest.approx(sum(far.value_range) / 2)
    assert moved.transfer_function.domain[1] == pytest.approx(1.0)          # the demo's preset keeps its name
    image = dvr_gl.render(moved, size=32)
    rows, cols = np.nonzero(image.rgba[..., 3] > 0.01)
    assert abs(rows.mean() - 15.5) < 3 and abs(cols.mean() - 15.5) < 3       # centred on the new data


def test_reprs_are_short():
    scene = small_scene()
    for obj in (scene, scene.volume, scene.transfer_function, scene.camera):
        text = repr(obj)
        assert len(text) < 400 and "\n" not in text and "array(" not in text, text


def test_any_field_renders_with_the_renderers_that_declare_its_kind():
    """An analytic field through the same call: the references render it (any field; without a
    renderer named, the first of them), the grid renderers refuse it in one line naming those that do."""
    sphere = dvr_gl.SphereField((0.0, 0.0, 0.0), 2.0)
    points = [[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.5]]
    image = dvr_gl.render(sphere, renderer=CONVERGED, transfer_function=points, size=16)
    o, d = image.scene.camera.pixel_rays(16, 16)
    b = np.linalg.norm(np.cross(-o, d), axis=1)                    # each ray's distance from the centre
    chord = 2.0 * np.sqrt(np.maximum(4.0 - b * b, 0.0)).reshape(16, 16)
    sigma = -np.log1p(-0.5)                                         # alpha 0.5 per unit distance
    # measured 1.9e-8 (float32 output)
    np.testing.assert_allclose(image.rgba[..., 3], -np.expm1(-sigma * chord), atol=1e-6)
    judges = " or ".join(n for n in registry.names() if registry.plugin(n).data_kinds is None)
    refusal = f"{DEFAULT} renders grid data or several fields, not analytic data; use {judges}"
    with pytest.raises(dvr_gl.SceneError, match=refusal):
        dvr_gl.render(sphere, renderer=DEFAULT, transfer_function=points, size=16)
    assert dvr_gl.render(sphere, transfer_function=points, size=8).scene.renderer.name == registry.default_for(
        "analytic")


@pytest.mark.parametrize("keywords, fragment", [
    ({"size": (8,)}, "size: give pixels as n or (width, height)"),
    ({"size": 1.5}, "image.width: expected an integer, got 1.5"),
    ({"background": "red"}, "background: give linear RGB or RGBA"),
    ({"background": (1, 0, 2)}, "image.background must be in [0, 1]"),
    ({"transfer_function": []}, "transfer_function.points must be a non-empty list"),
    ({"fov": 0}, "camera.fov must be in [0.001, 180) degrees"),
    ({"sample_distance_voxels": 0}, "renderer.sample_distance_voxels must be positive"),
    ({"spacing": (1e300, 1, 1)}, "array: the spacing: a voxel of 1 and a box of 7e+300 world units are out of range"),
    # found by the fuzz campaign of 2026-11-29: ValueError and TypeError before
    ({"spacing": "abc"}, "array: spacing must be three numbers (x, y, z), got 'abc'"),
    ({"spacing": 2.0}, "array: spacing must be three numbers"),
    ({"spacing": (1j, 1, 1)}, "array: spacing must be three numbers"),
    ({"origin": "0,0,0"}, "array: origin must be three numbers"),
    ({"transfer_function": [["a", 1, 1, 1, 1]]}, "transfer_function: give control points as rows of numbers"),
    ({"transfer_function": {"a": 1}}, "transfer_function: give control points as rows of numbers"),
    ({"transfer_function": "ct-bone", "rescale_intercept": "x"}, "rescale_intercept must be a number, got 'x'"),
])
def test_bad_keywords_name_the_key(keywords, fragment):
    """Keywords are checked as scene keys are: a DvrError naming them, never a ValueError (issue 14)."""
    with pytest.raises(dvr_gl.DvrError) as caught:
        dvr_gl.render(np.zeros((8, 8, 8), np.float32), renderer=DISCRETE, **{"size": 8, **keywords})
    assert fragment in str(caught.value)


def test_an_array_spacing_is_three_numbers():
    """``spacing=np.array(...)``: its truth value is ambiguous, and ``spacing or (1, 1, 1)`` raised on it."""
    image = dvr_gl.render(np.zeros((4, 4, 4), np.float32), renderer=DISCRETE, size=8,
                          spacing=np.array([1.0, 2.0, 3.0]))
    assert image.scene.field.spacing == (1.0, 2.0, 3.0)


@pytest.mark.parametrize("call, fragment", [
    (lambda tmp: dvr_gl.Camera(eye="abc", target=(0, 0, 0)), "camera.eye must be three numbers"),
    (lambda tmp: dvr_gl.Camera(eye=(0, 0, 5), target=(0, 0, 0), up=3), "camera.up must be three numbers"),
    (lambda tmp: dvr_gl.Camera(eye=(0, 0, 5), target=(0, 0, 0), fov="w"), "camera.fov must be a number"),
    (lambda tmp: dvr_gl.load_volume(_npy(tmp), nan_value="x"), "nan_value must be a number"),
    (lambda tmp: dvr_gl.load_volume(_npy(tmp), origin="abc"), "origin must be three numbers"),
    (lambda tmp: dvr_gl.render(np.zeros((4, 4, 4), np.float32), renderer=DISCRETE, size=8).save(
        tmp / "a.png", annotations="bogus"), "annotations: give a dict"),
])
def test_bad_arguments_of_the_api_name_themselves(tmp_path, call, fragment):
    """Found by the fuzz campaign of 2026-11-29: each raised a ValueError or TypeError; now a DvrError of one
    line naming the argument, and no file written."""
    with pytest.raises(dvr_gl.DvrError, match=fragment):
        call(tmp_path)
    assert not (tmp_path / "a.png").exists()


def _npy(folder):
    np.save(folder / "v.npy", np.zeros((4, 4, 4), np.float32))
    return folder / "v.npy"
