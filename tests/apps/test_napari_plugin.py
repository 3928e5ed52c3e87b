"""The napari plugin (dvr_gl/napari, docs/napari.md): its manifest validates, its readers place the voxels where
dvr-gl does, and its dock widget renders napari's 3D view of an image and a labels layer as dvr_gl.render renders
the same scene built directly, lying as napari's own canvas does.  One napari viewer for the module, in the
run's Xvfb display (napari's canvas needs a display: Qt's offscreen platform has no OpenGL widget)."""

import ctypes
import importlib.metadata
import inspect
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

napari = pytest.importorskip("napari")
npe2 = pytest.importorskip("npe2")

from dvr_gl import Camera, LabelTable, Member, TransferFunction, Volume, VolumeError, render  # noqa: E402
from dvr_gl.napari import readers  # noqa: E402
from dvr_gl.presets.colour import srgb_to_linear  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
MANIFEST = ROOT / "dvr_gl" / "napari" / "napari.yaml"


# --- the manifest -------------------------------------------------------------------------------------------

def test_the_manifest_validates_and_the_entry_point_finds_it():
    manifest = npe2.PluginManifest.from_file(MANIFEST)
    manifest.validate_imports()  # every python_name imports and exists
    assert manifest.name == "dvr-gl"
    assert {w.display_name for w in manifest.contributions.widgets} == {"dvr-gl render"}
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    value = project["project"]["entry-points"]["napari.manifest"]["dvr-gl"]
    entry = importlib.metadata.EntryPoint("dvr-gl", value, "napari.manifest")
    found = npe2.PluginManifest._from_entrypoint(entry, importlib.metadata.distribution("dvr-gl"))
    assert found.name == manifest.name  # npe2's own reading of "package:file", checked against the package's name
    assert "napari.yaml" in project["tool"]["setuptools"]["package-data"]["dvr_gl.napari"]  # installed with it


def test_npe2_discovers_the_plugin_through_the_entry_point(tmp_path):
    """npe2's discovery, as napari runs it, in a fresh process that sees dvr-gl's metadata with the entry point
    of pyproject.toml (a checkout installed before the entry point was added lacks it until reinstalled)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    value = project["project"]["entry-points"]["napari.manifest"]["dvr-gl"]
    info = tmp_path / "dvr_gl-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: dvr-gl\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(f"[napari.manifest]\ndvr-gl = {value}\n")
    code = ("import npe2; pm = npe2.PluginManager(); pm.discover(); "
            "print(sorted(w.display_name for w in pm.get_manifest('dvr-gl').contributions.widgets))")
    done = subprocess.run([sys.executable, "-W", "ignore", "-c", code], capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, PYTHONPATH=str(tmp_path)))
    assert done.stdout.strip() == "['dvr-gl render']", done.stderr[-2000:]


# --- the readers ---------------------------------------------------------------------------------------------

DATA = np.arange(24, dtype=np.float32).reshape(2, 3, 4)  # [z, y, x]


def _nrrd(path, directions, origin):
    vectors = " ".join("(" + ",".join(map(repr, map(float, d))) + ")" for d in directions)
    path.write_bytes((f"NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
                      f"space: left-posterior-superior\nspace directions: {vectors}\n"
                      f"space origin: ({','.join(map(str, origin))})\n\n").encode() + DATA.astype("<f4").tobytes())
    return path


def _mhd(folder):
    (folder / "v.raw").write_bytes(DATA.astype("<f4").tobytes())
    (folder / "v.mhd").write_text("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
                                  "Offset = 1 2 3\nElementSpacing = 0.5 0.25 2\nDimSize = 4 3 2\n"
                                  "ElementType = MET_FLOAT\nElementDataFile = v.raw\n")
    return folder / "v.mhd"


def _vti(path):
    values = " ".join(repr(float(v)) for v in DATA.ravel())
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian">\n'
                    '<ImageData WholeExtent="0 3 0 2 0 1" Origin="1 2 3" Spacing="0.5 0.25 2">\n'
                    '<Piece Extent="0 3 0 2 0 1"><PointData Scalars="d">'
                    f'<DataArray type="Float32" Name="d" format="ascii">\n{values}\n</DataArray>'
                    '</PointData><CellData/></Piece></ImageData>\n</VTKFile>\n')
    return path


@pytest.mark.parametrize("write", [lambda f: _nrrd(f / "v.nrrd", np.diag([0.5, 0.25, 2.0]), (1, 2, 3)), _mhd,
                                   lambda f: _vti(f / "v.vti")], ids=["nrrd", "metaimage", "vti"])
def test_a_volume_reads_with_its_spacing_and_origin(tmp_path, write):
    path = write(tmp_path)
    reader = readers.get_reader(str(path))
    [(data, attributes, kind)] = reader(str(path))
    assert kind == "image"
    np.testing.assert_array_equal(data, DATA)
    assert attributes["scale"] == (2.0, 0.25, 0.5)  # (z, y, x): the spacing reversed
    assert attributes["translate"] == (3.0, 2.0, 1.0)


def test_an_oriented_volume_is_placed_where_dvr_gl_places_it(tmp_path):
    # index axes x -> world -y (1.5 apart), y -> world +x (0.5), z -> world -z (2): a rotation with a mirror
    directions = [(0, -1.5, 0), (0.5, 0, 0), (0, 0, -2)]
    path = _nrrd(tmp_path / "o.nrrd", directions, (4, 5, 6))
    [(data, attributes, _)] = readers.get_reader(str(path))(str(path))
    layer = napari.layers.Image(data, **attributes)
    for index_xyz in [(0, 0, 0), (3, 0, 0), (0, 2, 1), (3, 2, 1)]:
        expected = np.array([4, 5, 6]) + np.array(directions).T @ np.array(index_xyz, dtype=float)
        np.testing.assert_allclose(layer.data_to_world(index_xyz[::-1]), expected[::-1], atol=1e-9)


def test_a_bad_file_is_one_line(tmp_path):
    path = tmp_path / "bad.nrrd"
    path.write_bytes(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3\nencoding: raw\n\n" + bytes(96))
    with pytest.raises(VolumeError) as refused:
        readers.get_reader(str(path))(str(path))
    assert "bad.nrrd" in str(refused.value) and "\n" not in str(refused.value)


def test_meshes_read_as_surfaces(tmp_path):
    tet = tmp_path / "t.vtk"
    tet.write_text("# vtk DataFile Version 3.0\ntet\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
                   "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\n"
                   "SCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3\n")
    [((vertices, faces, values), _, kind)] = readers.get_reader(str(tet))(str(tet))
    assert kind == "surface" and faces.shape == (4, 3)  # one tetrahedron: four boundary triangles
    np.testing.assert_array_equal(vertices[:, ::-1], [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    np.testing.assert_array_equal(values, [0, 1, 2, 3])
    obj = tmp_path / "m.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 2 0\nf 1 2 3\n")
    [((vertices, faces), _, kind)] = readers.get_reader(str(obj))(str(obj))
    assert kind == "surface" and faces.tolist() == [[0, 1, 2]]
    np.testing.assert_array_equal(vertices[2], [0, 2, 0])  # (z, y, x) of x = 0, y = 2
    assert readers.get_reader(str(tmp_path / "picture.png")) is None
    (tmp_path / "series").mkdir()
    (tmp_path / "series" / "IM0001.dcm").write_bytes(b"")
    assert readers.get_reader(str(tmp_path / "series")) is readers.read  # a DICOM series folder
    (tmp_path / "pictures").mkdir()
    (tmp_path / "pictures" / "a.png").write_bytes(b"")
    assert readers.get_reader(str(tmp_path / "pictures")) is None


# --- the dock widget ------------------------------------------------------------------------------------------

def _clear_pending_gl_errors():
    """Read away the errors pending on whatever OpenGL context an earlier test of this process left current:
    napari's new canvas queries its limits on the thread's current context before making its own, and PyOpenGL
    reports a stale error there as its own (GL_INVALID_OPERATION from ``glGetParameter`` in two CI runs, when
    pytest-xdist put another GL test file first in the process).  libGL dispatches to the current context,
    EGL's included; without one, glGetError returns 0."""
    get_error = ctypes.CDLL("libGL.so.1").glGetError
    for _ in range(64):  # OpenGL keeps at most one flag per error kind
        if get_error() == 0:
            return


#: Under pytest-xdist the widget's tests run in a fresh process of their own (test_the_widget_in_a_fresh_process):
#: in a worker that ran other GL test files first, napari's canvas met their OpenGL state (an error pending on a
#: context left current: GL_INVALID_OPERATION or GL_INVALID_ENUM from vispy) in two of three CI runs.
IN_A_SHARED_WORKER = "PYTEST_XDIST_WORKER" in os.environ and not os.environ.get("DVR_GL_NAPARI_FRESH")


def _widget_tests() -> list[str]:
    """The node ids of this file's tests that need napari's viewer (the ones skipped in an xdist worker)."""
    return [f"{__file__}::{name}" for name, test in globals().items()
            if name.startswith("test_") and "viewer" in inspect.signature(test).parameters]


def test_the_widget_in_a_fresh_process():
    """The widget's tests in a fresh pytest process, where napari's viewer is the first GL user (skipped in an
    xdist worker, they run there and must all pass; the file's other tests ran in the worker already)."""
    if not IN_A_SHARED_WORKER:
        pytest.skip("this process is fresh: the widget's tests run here")
    tests = _widget_tests()
    assert len(tests) >= 4, tests
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider", *tests],
                          cwd=ROOT, capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, DVR_GL_NAPARI_FRESH="1"))
    assert done.returncode == 0, done.stdout[-4000:]
    assert f"{len(tests)} passed" in done.stdout and "skipped" not in done.stdout.splitlines()[-1], done.stdout[-2000:]


@pytest.fixture(scope="module")
def viewer(xvfb):
    if IN_A_SHARED_WORKER:
        pytest.skip("run in a fresh process by test_the_widget_in_a_fresh_process (napari meets other files' GL state)")
    _clear_pending_gl_errors()
    with pytest.MonkeyPatch.context() as env:
        env.setenv("DISPLAY", xvfb)
        env.setenv("QT_QPA_PLATFORM", "xcb")
        v = napari.Viewer(show=False)
        yield v
        v.close()


@pytest.fixture(scope="module")
def widget(viewer):
    """One dock widget for the module (its GL context, once napari's window has been shown, made once)."""
    from dvr_gl.napari.widget import RenderWidget

    return RenderWidget(viewer)


def _scene(viewer):
    """An asymmetric image (a bright block at large x, small y, small z) and a label block, in 3D."""
    viewer.layers.clear()
    image = np.zeros((12, 16, 20), np.float32)
    image[1:4, 2:5, 14:19] = 1.0
    labels = np.zeros((12, 16, 20), np.int32)
    labels[6:10, 9:14, 3:8] = 2
    viewer.add_image(image, scale=(2.0, 1.0, 1.0), translate=(1.0, 0.0, 0.0), name="image", gamma=1.0)
    viewer.add_labels(labels, scale=(2.0, 1.0, 1.0), translate=(1.0, 0.0, 0.0), name="labels", opacity=0.8)
    viewer.dims.ndisplay = 3
    viewer.reset_view()
    return image, labels


def _expected(viewer, image, labels, camera, renderer, size, ctx):
    """dvr_gl.render of the same scene built directly from the documented mapping (docs/napari.md)."""
    grid = dict(spacing=(1.0, 1.0, 2.0), origin=(0.0, 0.0, 1.0))
    s = np.linspace(0.0, 1.0, 64)  # the grey colormap, contrast limits 0..1, gamma 1, opacity 1, depth 10 voxels
    tf = TransferFunction(np.column_stack([s, srgb_to_linear(np.stack([s] * 3, axis=1)), s]), unit_distance=10.0)
    rgba = np.asarray(viewer.layers["labels"].colormap.map(np.array([2])))[0]
    table = LabelTable([2], [srgb_to_linear(rgba[:3])], [0.8 * rgba[3]], unit_distance=1.0)
    members = [Member(Volume(image, name="image", **grid), "scalar", "image"),
               Member(Volume(labels.astype(np.uint8), name="labels", **grid), "label", "labels")]
    picture = render(members, transfer_function=[tf, table], camera=camera, renderer=renderer, size=size,
                     background=(0, 0, 0, 1), ctx=ctx)
    return picture.srgb8()[:, ::-1, :3]  # napari's default orientation mirrors (x, y, z): columns flipped


def test_the_widget_renders_napari_view_of_an_image_and_labels(viewer, widget):
    image, labels = _scene(viewer)
    camera = viewer.camera
    widget.width_box.setValue(96)
    layer = widget.render_layer()
    picture = np.asarray(layer.data)
    h, w = (float(x) for x in viewer.canvas.viewbox_size(viewer.layers))
    assert picture.shape == (round(96 * h / w), 96, 3)
    # napari at angles (0, 0, 0), orthographic, default orientation: looking down -z from +z, +y down the
    # screen: eye above the centre, up = -y, the view canvas_height / zoom world units high
    centre = np.array(camera.center)[::-1]
    height = h / camera.zoom
    expected_camera = Camera(tuple(centre + (0, 0, height)), tuple(centre), (0, -1, 0), projection="orthographic",
                             view_height=height)
    expected = _expected(viewer, image, labels, expected_camera, layer.name.removeprefix("dvr-gl "),
                         picture.shape[1::-1], widget.context())
    np.testing.assert_array_equal(picture, expected)  # the same renderer on the same scene: the same bytes
    # the renderer list: those that take an image and a label map, and none that does not
    from dvr_gl import registry
    from dvr_gl.napari.scene import view_scene

    scene = view_scene(viewer, width=96)
    listed = [widget.renderer.itemText(i) for i in range(widget.renderer.count())]
    assert listed and all(registry.refusal(scene, name) is None for name in listed)
    assert all(registry.refusal(scene, name) for name in set(registry.names()) - set(listed))
    # orientation in words: the bright grey block (large x, small y) is right of centre and above it
    grey = (picture.min(axis=2) > 100) & (np.ptp(picture, axis=2) < 8)  # the labels are blue
    ys, xs = np.nonzero(grey)
    assert xs.mean() > 0.6 * picture.shape[1] and ys.mean() < 0.4 * picture.shape[0]


def test_the_picture_lies_as_napari_canvas_shows_it(viewer, widget):
    """napari's own canvas (drawn in the window, shown for this test) and the widget's picture at the canvas's
    size put the bright block's centre at the same pixel, in an oblique perspective view and an oblique
    orthographic one (measured: within 0.2 pixels; 1 allowed for napari's sampling at the block's edges); with
    napari's projection taken over, the pictures are the same."""
    from dvr_gl.napari.scene import render_view

    _scene(viewer)
    viewer.layers["labels"].visible = False
    viewer.layers["image"].rendering = "mip"
    viewer.window.show()
    assert widget.context() is not None
    try:
        for angles, perspective in (((0, 30, 60), 30.0), ((20, -40, 10), 0.0)):
            viewer.camera.angles, viewer.camera.perspective = angles, perspective
            shot = viewer.screenshot(canvas_only=True)[..., 0].astype(int)
            mine = render_view(viewer, ctx=widget.context()).srgb8()[..., 0]  # the kept context: window shown
            assert shot.shape == mine.shape, (shot.shape, mine.shape)
            where = [np.argwhere(a > 100).mean(axis=0) for a in (shot, mine)]
            np.testing.assert_allclose(where[1], where[0], atol=1.0)
            # napari's MIP (the layer's rendering) as dvr-gl's: the same colours too, every pixel 8-bit sRGB;
            # measured 0.13 to 0.19 on average (the blocks' edges), 1 allowed
            projected = render_view(viewer, projection=True, ctx=widget.context())
            assert projected.scene.renderer.compositing == "mip"
            assert np.abs(projected.srgb8()[..., 0].astype(int) - shot).mean() < 1.0
    finally:
        viewer.window._qt_window.hide()
        viewer.layers["labels"].visible = True


def test_napari_rendering_modes_map_to_dvr_gl_modes(viewer, widget):
    """Each of napari's renderings of one image layer, followed (``projection``): translucent is emission and
    absorption, mip/minip/average the same compositing, iso the isosurface at the layer's iso_threshold (data
    units: the block's surface drawn, nothing where the threshold is above the data), attenuated_mip and additive
    the nearest mode with a one-line note in the status line; not followed, every mode is emission and
    absorption."""
    from dvr_gl.napari.scene import render_view, rendering_note, view_scene

    _scene(viewer)
    viewer.layers["labels"].visible = False
    layer = viewer.layers["image"]
    expected = {"translucent": "emission_absorption", "mip": "mip", "minip": "minip", "average": "average",
                "iso": "isosurface", "attenuated_mip": "mip", "additive": "average"}
    try:
        for mode, compositing in expected.items():
            layer.rendering = mode
            assert view_scene(viewer, width=32, projection=True).renderer.compositing == compositing, mode
            assert view_scene(viewer, width=32).renderer.compositing == "emission_absorption"
            note = rendering_note(viewer)
            assert (note is not None) == (mode in ("attenuated_mip", "additive")), (mode, note)
            assert note is None or (mode in note and "\n" not in note)
        layer.rendering, layer.iso_threshold = "iso", 0.5
        scene = view_scene(viewer, width=32, projection=True)
        assert scene.renderer.iso_value == 0.5
        assert render_view(viewer, width=32, projection=True, ctx=widget.context()).rgba[..., 3].max() > 0.5
        layer.iso_threshold = 2.0  # above the block's 1: no surface
        assert render_view(viewer, width=32, projection=True, ctx=widget.context()).rgba[..., 3].max() == 0.0
        layer.rendering, layer.attenuation = "attenuated_mip", 0.25
        widget.projection.setChecked(True)
        widget.output.setCurrentText("new layer")
        widget.width_box.setValue(32)
        widget.run()
        status = widget.status.text()
        assert "added layer" in status and "attenuated_mip is drawn as mip" in status and "0.25" in status, status
    finally:
        widget.projection.setChecked(False)
        layer.rendering = "translucent"
        viewer.layers["labels"].visible = True


def test_a_refused_view_says_why_in_the_status_line(viewer, widget):
    _scene(viewer)
    viewer.dims.ndisplay = 2
    widget.output.setCurrentText("new layer")
    widget.run()
    assert "3D" in widget.status.text() and "\n" not in widget.status.text()
    viewer.dims.ndisplay = 3
    widget.output.setCurrentText("orbit")
    widget.frames.setValue(3)
    widget.width_box.setValue(32)
    widget.run()
    assert viewer.layers[-1].data.shape[0] == 3, widget.status.text()
    # time: a 4D layer [t, z, y, x] of two steps, the block moved in x at step 1: two frames that differ
    viewer.layers.clear()
    movie = np.zeros((2, 12, 16, 20), np.float32)
    movie[0, 1:4, 2:5, 14:19] = 1.0
    movie[1, 1:4, 2:5, 2:7] = 1.0
    viewer.add_image(movie, name="movie", scale=(1.0, 2.0, 1.0, 1.0))
    still = np.zeros((12, 16, 20), np.uint8)  # a 3D labels layer beside the 4D image: the viewer's last 3 axes
    still[6:10, 9:14, 3:8] = 1
    viewer.add_labels(still, scale=(2.0, 1.0, 1.0))
    viewer.dims.ndisplay = 3
    widget.output.setCurrentText("time")
    widget.frames.setValue(0)
    widget.run()
    frames = np.asarray(viewer.layers[-1].data)
    assert frames.shape[0] == 2 and not np.array_equal(frames[0], frames[1]), widget.status.text()
    assert viewer.dims.current_step[0] == 0  # napari's position is put back
    assert os.environ.get("QT_QPA_PLATFORM") == "xcb"


def test_a_perspective_too_narrow_for_dvr_gl_is_orthographic():
    """napari's perspective 0 is orthographic; so is one below dvr-gl's narrowest field of view (refused as a
    perspective fov: its framing distance outgrows float32), not an error from the widget."""
    from types import SimpleNamespace

    from dvr_gl.camera import MIN_FOV
    from dvr_gl.napari.scene import view_camera

    for perspective, projection in ((0.0, "orthographic"), (MIN_FOV / 10, "orthographic"), (30.0, "perspective")):
        camera = SimpleNamespace(view_direction=(1.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0), center=(5, 5, 5),
                                 zoom=2.0, perspective=perspective)
        assert view_camera(camera, 100).projection == projection
