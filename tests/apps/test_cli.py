"""The dvr command end to end: rendering, overrides, frames, saved scenes and bad input.

Most cases call ``main`` in-process (fast); one runs the installed console script."""

import gzip
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import run_cli
from dvr_gl.image import read_image
from dvr_gl.renderers import registry
from judges import renderers as declaring

#: the renderer of a grid that names none; the first GL grid renderer without pre-integration; the
#: first without scattering
DEFAULT = registry.default_for("grid")
NO_PREINTEGRATION = next(n for n in declaring(kind="grid", gl=True)
                         if "preintegrated" not in registry.plugin(n).choices("classification"))
NO_SCATTERING = next(n for n in declaring(kind="grid", gl=True) if registry.plugin(n).declared("scattering") is None)

SMALL = ["--size", "40x32", "--set", "volume.size=24"]


run = run_cli


def assert_one_line_error(code, err, *fragments):
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1, err  # one line, no traceback
    for f in fragments:
        assert f in lines[0], lines[0]


def test_render_demo_writes_a_picture(tmp_path, capsys):
    out = tmp_path / "demo.png"
    code, stdout, _ = run(capsys, "render", "--demo", "-o", out, *SMALL)
    assert code == 0 and "wrote" in stdout
    img = read_image(out)
    assert img.shape == (32, 40, 4)
    assert img[..., :3].max() > 0.3 and (img[..., :3].max(axis=2) < 0.01).mean() > 0.2  # object on black


def test_outputs_get_ordinary_permissions(tmp_path, capsys):
    umask = os.umask(0o022)
    try:
        run(capsys, "render", "--demo", "-o", tmp_path / "a.png", *SMALL, "--save-scene", tmp_path / "a.toml")
    finally:
        os.umask(umask)
    assert (tmp_path / "a.png").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "a.toml").stat().st_mode & 0o777 == 0o644
    (tmp_path / "a.png").chmod(0o600)  # replacing keeps the owner's choice
    run(capsys, "render", "--demo", "-o", tmp_path / "a.png", *SMALL, "--overwrite")
    assert (tmp_path / "a.png").stat().st_mode & 0o777 == 0o600


def test_console_script_renders_the_demo(tmp_path):
    dvr = Path(sys.executable).parent / "dvr"
    out = tmp_path / "demo.exr"
    proc = subprocess.run([str(dvr), "render", "--demo", "-o", str(out), *SMALL], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert read_image(out).dtype == np.float32


def test_acceleration_flags_leave_the_image_unchanged(tmp_path, capsys):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    c = tmp_path / "c.exr"
    run(capsys, "render", "--demo", "-o", a, *SMALL, "--acceleration", "off", "--ert-threshold", "1")
    run(capsys, "render", "--demo", "-o", b, *SMALL, "--acceleration", "on", "--block-size", "4",
        "--ert-threshold", "1")
    run(capsys, "render", "--demo", "-o", c, *SMALL, "--ert-threshold", "1")  # auto
    assert np.abs(read_image(a) - read_image(b)).max() <= 2e-6
    assert np.abs(read_image(a) - read_image(c)).max() <= 2e-6


def test_overrides_change_the_image(tmp_path, capsys):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    run(capsys, "render", "--demo", "-o", a, *SMALL)
    run(capsys, "render", "--demo", "-o", b, *SMALL, "--azimuth", "140", "--filter", "nearest")
    assert np.abs(read_image(a) - read_image(b)).max() > 0.05


def test_saved_scene_renders_the_same_image(tmp_path, capsys):
    first, again, scene = tmp_path / "first.exr", tmp_path / "again.exr", tmp_path / "sub" / "scene.toml"
    scene.parent.mkdir()
    code, _, _ = run(capsys, "render", "--demo", "-o", first, *SMALL, "--elevation", "-10", "--jitter",
                     "--set", "renderer.shading.shininess=12.5", "--background", "0.1,0.2,0.3", "--save-scene", scene)
    assert code == 0
    code, _, _ = run(capsys, "render", scene, "-o", again)
    assert code == 0
    np.testing.assert_array_equal(read_image(first), read_image(again))  # bit for bit


def test_frames_render_an_orbit_with_progress(tmp_path, capsys):
    out = tmp_path / "orbit.png"
    code, stdout, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", "3")
    assert code == 0
    frames = [tmp_path / f"orbit_{i:04d}.png" for i in range(3)]
    assert all(f.exists() for f in frames) and not out.exists()
    assert "3/3" in err  # the progress bar
    imgs = [read_image(f) for f in frames]
    assert np.abs(imgs[0] - imgs[1]).max() > 0.05


def test_render_a_volume_file_with_a_preset(tmp_path, capsys):
    data = (np.arange(16 ** 3) % 4096).reshape(16, 16, 16).astype(">i2")
    path = tmp_path / "ct.raw.gz"
    path.write_bytes(gzip.compress(data.tobytes()))
    code, _, err = run(capsys, "render", "--volume", path, "--dims", 16, 16, 16, "--dtype", "int16",
                       "--endian", "big", "--transfer-function", "ct-bone-ivory", "--rescale-intercept", "-1024",
                       "--size", "16", "-o", tmp_path / "ct.png")
    assert code == 0, err
    assert read_image(tmp_path / "ct.png")[..., :3].max() > 0.1


def test_existing_output_is_kept_unless_overwrite(tmp_path, capsys):
    out = tmp_path / "keep.png"
    out.write_bytes(b"precious")
    code, _, err = run(capsys, "render", "--demo", "-o", out, *SMALL)
    assert_one_line_error(code, err, "exists; pass --overwrite")
    assert out.read_bytes() == b"precious"
    code, _, _ = run(capsys, "render", "--demo", "-o", out, *SMALL, "--overwrite")
    assert code == 0 and out.read_bytes() != b"precious"


def test_a_frame_sequence_is_checked_before_rendering(tmp_path, capsys):
    (tmp_path / "o_0001.png").write_bytes(b"x")
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / "o.png", *SMALL, "--frames", "3")
    assert_one_line_error(code, err, "o_0001.png: exists")
    assert not (tmp_path / "o_0000.png").exists()


def _raw(tmp_path, nbytes, name="v.raw", compress=False):
    path = tmp_path / name
    blob = bytes(range(256)) * (nbytes // 256) + bytes(nbytes % 256)
    path.write_bytes(gzip.compress(blob)[:-8] if compress else blob)
    return path


def _scene(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


BAD_INPUTS = {
    "size mismatch": (lambda t: ["--volume", _raw(t, 1000), "--dims", 10, 10, 11, "--dtype", "uint8"],
                      ["holds 1000 bytes", "needs 1100"]),
    "unknown dtype": (lambda t: ["--volume", _raw(t, 1000), "--dims", 10, 10, 10, "--dtype", "uint12"],
                      ["unknown dtype 'uint12'"]),
    "truncated gzip": (lambda t: ["--volume", _raw(t, 1000, "v.raw.gz", compress=True), "--dims", 10, 10, 10,
                                  "--dtype", "uint8"], ["truncated or corrupt"]),
    "zero dims": (lambda t: ["--volume", _raw(t, 0), "--dims", 10, 0, 10, "--dtype", "uint8"],
                  ["volume.dims must be at least 1"]),
    "nan in data": (lambda t: ["--volume", _nan_npy(t)], ["NaN or Inf", "--nan-value"]),
    "unsorted tf": (lambda t: [_scene(t, '[volume]\ndemo = "shepp-logan"\n[transfer_function]\n'
                                      'points = [[0.5, 0, 0, 0, 0], [0.1, 1, 1, 1, 1]]\n')],
                    ["values must increase strictly"]),
    "tf out of range": (lambda t: [_scene(t, '[volume]\ndemo = "shepp-logan"\n[transfer_function]\n'
                                          'points = [[0, 0, 0, 0, 0], [1, 1, 1, 1, 1.2]]\n')],
                        ["alpha [1.2] outside [0, 1]"]),
    "unknown key": (lambda t: ["--demo", "--set", "renderer.samples=3"], ["unknown key 'samples'", "valid keys"]),
    "unknown renderer": (lambda t: ["--demo", "--renderer", "magic"], ["unknown renderer 'magic'"]),
    "missing volume": (lambda t: ["--volume", t / "absent.nrrd"], ["file not found"]),
    "nothing to render": (lambda t: [], ["nothing to render"]),
    "demo and volume": (lambda t: ["--demo", "--volume", _nan_npy(t)], ["give --demo or --volume, not both"]),
    "bad size": (lambda t: ["--demo", "--set", "image.width=0"], ["image.width must be at least 1"]),
    "bad flag choice": (lambda t: ["--demo", "--compositing", "bogus"], ["invalid choice: 'bogus'",
                                                                         "see dvr render --help"]),
    "renderer refuses": (lambda t: ["--demo", "--renderer", NO_PREINTEGRATION, "--classification", "preintegrated"],
                         [f"{NO_PREINTEGRATION} does not support renderer.classification = 'preintegrated'",
                          f"use {DEFAULT}"]),
    "shading value": (lambda t: ["--demo", "--set", "renderer.shading.ambient=-1"],
                      ["renderer.shading.ambient must be in [0, 10], got -1.0"]),
    "huge shading value": (lambda t: ["--demo", "--set", "renderer.shading.diffuse=1e6"],
                           ["renderer.shading.diffuse must be in [0, 10], got 1000000.0"]),
    # issue 14: each of these was silently accepted, misreported or an internal error
    "zero sample distance": (lambda t: ["--demo", "--sample-distance-voxels", 0],
                             ["renderer.sample_distance_voxels must be positive, got 0.0"]),
    "negative sample distance": (lambda t: ["--demo", "--set", "renderer.sample_distance=-1"],
                                 ["renderer.sample_distance must be positive"]),
    "huge sample distance": (lambda t: ["--demo", "--sample-distance", 1e39],
                             ["renderer.sample_distance = 1e+39 is over", "world units, 1e+06 times the "
                              "volume's diagonal"]),
    "huge sample distance in voxels": (lambda t: ["--volume", _ones_npy(t), "--sample-distance-voxels", 1e308],
                                       ["renderer.sample_distance_voxels = 1e+308 (1e+308 world units) is over "
                                        "5.2e+06 world units"]),  # 1e6 diagonals of 3 voxels of 1
    "empty points": (lambda t: [_scene(t, '[volume]\ndemo = "shepp-logan"\n[transfer_function]\npoints = []\n')],
                     ["transfer_function.points must be a non-empty list"]),
    "ragged points": (lambda t: ["--demo", "--set", "transfer_function.points=[[0,1,1,1,1],[1,1]]"],
                      ["transfer_function.points must be a non-empty list of [value, r, g, b, opacity]"]),
    "zero frames": (lambda t: ["--demo", "--frames", 0], ["--frames must be in [1, 10000]"]),
    "fov zero on a volume": (lambda t: ["--volume", _ones_npy(t), "--fov", 0], ["camera.fov must be in [0.001, 180)"]),
    "fov zero on the demo": (lambda t: ["--demo", "--fov", 0], ["camera.fov must be in [0.001, 180)"]),
    "fov too narrow": (lambda t: ["--demo", "--fov", 5e-324],
                       ["camera.fov must be in [0.001, 180) degrees, got 5e-324"]),
    "huge spacing": (lambda t: ["--volume", _ones_npy(t), "--spacing", 1e300, 1, 1],
                     ["volume.spacing must be in [1e-18, 1e+18] world units, got [1e+300, 1.0, 1.0]"]),
    "tiny spacing": (lambda t: ["--volume", _ones_npy(t), "--spacing", 1e-300, 1, 1],
                     ["volume.spacing must be in [1e-18, 1e+18] world units"]),
    "huge extent": (lambda t: ["--volume", _ones_npy(t), "--spacing", 5e17, 1, 1],
                    ["volume.spacing: a voxel of 1 and a box of 1.5e+18 world units are out of range"]),
    "huge eye": (lambda t: ["--demo", "--set", "camera.eye=[1e300, 0, 0]"], ["camera.eye must be within 1e+18"]),
    "huge origin": (lambda t: ["--volume", _ones_npy(t), "--set", "volume.origin=[0,1e300,0]"],
                    ["volume.origin must be within 1e+18 of the origin"]),
    "far origin": (lambda t: ["--volume", _ones_npy(t), "--set", "volume.origin=[0,9e17,0]", "--spacing", 1e17, 1e17,
                              1e17], ["volume.origin: the box reaches 1.2e+18"]),
    "nan spacing": (lambda t: ["--volume", _ones_npy(t), "--spacing", "nan", 1, 1],
                    ["volume.spacing[0] must be a finite number"]),
    "zero spacing": (lambda t: ["--volume", _ones_npy(t), "--spacing", 1, 0, 1],
                     ["volume.spacing must be in [1e-18, 1e+18] world units"]),
    "spacing on a demo": (lambda t: ["--demo", "--spacing", 1, 1, 2], ["volume.spacing applies to volume files"]),
    "infinite distance": (lambda t: ["--demo", "--distance", "inf"], ["camera.distance must be a finite number"]),
    "non-integer width": (lambda t: ["--demo", "--set", "image.width=1.5"], ["image.width: expected an integer"]),
    "huge integer": (lambda t: ["--demo", "--set", "renderer.lut_size=100000000000000000000"],
                     ["renderer.lut_size must be an integer of at most 64 bits"]),
    "negative seed": (lambda t: ["--demo", "--jitter-seed", -1], ["renderer.jitter_seed must be in [0, 4294967295]"]),
    "zero up": (lambda t: ["--demo", "--set", "camera.up=[0,0,0]"], ["camera.up must be a non-zero vector"]),
    "glob matching nothing": (lambda t: [t / "scan[1].nrrd"], ["scan[1].nrrd: no such file", "matches no file"]),
    "deep --set": (lambda t: ["--demo", "--set", "transfer_function.points=" + "[" * 2000 + "]" * 2000],
                   ["--set value '[[[", "nested too deeply"]),
    "deep scene": (lambda t: [_scene(t, '[volume]\ndemo = "shepp-logan"\nx = ' + "[" * 2000 + "]" * 2000 + "\n")],
                   ["s.toml: arrays or tables nested too deeply"]),
    "nul in a path": (lambda t: [_scene(t, '[volume]\npath = "ok\\u0000.nrrd"\n')],
                      ["'ok\\x00.nrrd': the volume file's path holds a NUL byte"]),
    "name too long": (lambda t: [t / ("a" * 300 + ".nrrd")],
                      ["a name in the input file's path is too long (305 bytes"]),
    # a folder where the scene goes is a folder of slices (TIFF or DICOM): the reader says what it lacks
    "scene is a folder": (lambda t: [t], ["no TIFF files found (nor DICOM"]),
}


def _ones_npy(tmp_path):
    np.save(tmp_path / "ones.npy", np.ones((4, 4, 4), np.float32))
    return tmp_path / "ones.npy"


def _nan_npy(tmp_path):
    data = np.ones((4, 4, 4), np.float32)
    data[1, 2, 3] = np.nan
    np.save(tmp_path / "nan.npy", data)
    return tmp_path / "nan.npy"


@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_input_gives_one_line_and_no_output(tmp_path, capsys, case):
    args, fragments = BAD_INPUTS[case]
    out = tmp_path / "out.png"
    code, _, err = run(capsys, "render", *args(tmp_path), "-o", out, *SMALL)
    assert_one_line_error(code, err, *fragments)
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".dvr-")]  # no temporary files


def test_a_volume_named_like_a_glob_is_that_file(tmp_path, capsys):
    """``scan[1].npy`` renders that file, not ``scan1.npy`` (which the glob would match: here refused)."""
    _nan_npy(tmp_path).rename(tmp_path / "scan1.npy")
    _ones_npy(tmp_path).rename(tmp_path / "scan[1].npy")
    code, stdout, err = run(capsys, "render", tmp_path / "scan[1].npy", "-o", tmp_path / "o.png", *SMALL[:2])
    assert code == 0 and "wrote" in stdout, err
    assert (tmp_path / "o.png").exists()


def test_nan_replacement_value_makes_the_data_usable(tmp_path, capsys):
    code, _, err = run(capsys, "render", "--volume", _nan_npy(tmp_path), "--nan-value", "0", "-o",
                       tmp_path / "ok.png", "--size", "8")
    assert code == 0, err


@pytest.mark.parametrize("output, fragment", [("missing/dir/out.png", "does not exist"), ("out.bmpx", "unsupported"),
                                              (".", "is a folder"), ("x" * 300 + ".png", "longer than the 255")])
def test_unwritable_outputs(tmp_path, capsys, output, fragment):
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / output, *SMALL)
    assert_one_line_error(code, err, fragment)


@pytest.mark.parametrize("make_folder", ["read-only", "proc"])
def test_unwritable_folder(tmp_path, capsys, make_folder):
    """A read-only folder (root may write into it anyway, so also /proc, where nobody can create files)."""
    if make_folder == "read-only":
        if os.geteuid() == 0:
            pytest.skip("root writes into read-only folders; the /proc case covers root")
        folder = tmp_path / "ro"
        folder.mkdir(mode=0o555)
    else:
        folder = Path("/proc")
        if not folder.is_dir():
            pytest.skip("no /proc on this system")
    code, _, err = run(capsys, "render", "--demo", "-o", folder / "dvr_test_output.png", *SMALL)
    assert_one_line_error(code, err, "choose another output path")
    assert not (folder / "dvr_test_output.png").exists()


def test_failed_write_leaves_no_partial_file(tmp_path):
    from dvr_gl import image
    from dvr_gl.errors import DvrError

    def broken(tmp):
        tmp.write_bytes(b"half an image")
        raise OSError(28, "No space left on device")

    with pytest.raises(DvrError, match="writing failed .No space left on device.; nothing was written"):
        image.atomic_write(tmp_path / "x.png", broken)
    assert list(tmp_path.iterdir()) == []


def test_debug_shows_the_traceback(tmp_path, capsys):
    code, _, err = run(capsys, "render", "--demo", "--renderer", "magic", "-o", tmp_path / "x.png", "--debug")
    assert code == 1 and "Traceback" in err


def test_info_prints_the_gl_context(capsys):
    code, out, _ = run(capsys, "info")
    assert code == 0
    for label in ("OpenGL vendor:", "OpenGL renderer:", "OpenGL version:", "max 3D texture size:",
                  "GL self-test (shaders, float32 target, read-back): ok"):
        assert label in out


def test_unwritable_scene_path_is_refused_before_rendering(tmp_path, capsys):
    out = tmp_path / "x.png"
    code, _, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--save-scene", tmp_path / "no" / "s.toml")
    assert_one_line_error(code, err, "does not exist")
    assert not out.exists()


def test_no_gl_context_is_one_line_and_no_output(tmp_path):
    """The GPU renderer (the default) on a machine where EGL finds no driver."""
    # EGL asked for by name: the automatic choice would fall back to OSMesa (docs/backends.md)
    env = dict(os.environ, __EGL_VENDOR_LIBRARY_FILENAMES="/nonexistent/egl_vendor.json", DVR_GL_BACKEND="egl")
    out = tmp_path / "x.png"
    proc = subprocess.run([sys.executable, "-m", "dvr_gl.apps", "render", "--demo", "-o", str(out), *SMALL],
                          env=env, capture_output=True, text=True)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "apt install libegl1 libegl-mesa0" in lines[0], proc.stderr
    assert not out.exists()


@pytest.mark.parametrize("argv, fragment", [([DEFAULT, "--repeat", "0"], "argument --repeat: give a whole number"),
                                            (["accel", "--repeat", "-1"], "argument --repeat"),
                                            (["quality", "--spike-width", "nan"], "argument --spike-width"),
                                            (["quality", "--spike-width", "0"], "in (0, 1], got '0'")])
def test_bench_counts_and_fractions_are_checked(capsys, argv, fragment):
    """--repeat 0 was an internal error (no median of no frames); --spike-width 0 silently ran the defaults."""
    code, _, err = run(capsys, "bench", *argv)
    assert_one_line_error(code, err, fragment)


def test_scattering_flags(tmp_path, capsys):
    """--scattering lights the demo by single scattering instead of its gradient shading; the shadow
    demo renders with its light volume; a renderer without scattering, or --shading beside it, is one
    line and no file."""
    lit, plain = tmp_path / "lit.png", tmp_path / "plain.png"
    assert run(capsys, "render", "--demo", "blobs", "--scattering", "-o", lit, *SMALL)[0] == 0
    assert run(capsys, "render", "--demo", "blobs", "--no-shading", "-o", plain, *SMALL)[0] == 0
    assert np.abs(read_image(lit) - read_image(plain)).max() > 0.05
    shadow = tmp_path / "shadow.png"
    code, out, _ = run(capsys, "render", "--demo", "shadow", "--size", "32", "--set", "volume.size=20",
                       "--set", "renderer.scattering.light_volume_size=16", "-o", shadow)
    assert code == 0 and shadow.exists()
    assert run(capsys, "render", "--demo", "shadow", "--size", "16", "--set", "volume.size=12",
               "--scattering-method", "shadow_rays", "-o", tmp_path / "rays.png")[0] == 0
    bad = tmp_path / "bad.png"
    code, _, err = run(capsys, "render", "--demo", "blobs", "--scattering", "--renderer", NO_SCATTERING, "-o", bad,
                       *SMALL)
    assert_one_line_error(code, err, f"{NO_SCATTERING} does not support renderer.scattering")
    code, _, err = run(capsys, "render", "--demo", "blobs", "--scattering", "--shading", "-o", bad, *SMALL)
    assert_one_line_error(code, err, "turn one off")
    assert not bad.exists()


@pytest.mark.parametrize("argv", [["completion", "bash"], ["render", "--help"], ["info", "{volume}"]])
def test_a_closed_stdout_ends_quietly(tmp_path, argv):
    """``dvr info FILE | head -1``: the reader closes the pipe before dvr writes; no internal error and no
    "Exception ignored" at exit, the status of a command SIGPIPE ended (141) or 0 where nothing failed."""
    volume = tmp_path / "v.npy"
    np.save(volume, np.zeros((4, 4, 4), np.float32))
    dvr = Path(sys.executable).parent / "dvr"
    proc = subprocess.Popen([str(dvr), *(a.format(volume=volume) for a in argv)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # before the command prints anything
    err = proc.stderr.read().decode()
    code = proc.wait(timeout=60)
    assert err == "" and code in (0, 141), (code, err)
    if argv[0] != "render":  # argparse's help swallows the error itself
        assert code == 141


def test_pyramid_into_a_folder_that_cannot_be_written_is_one_line(tmp_path, capsys, monkeypatch):
    """A missing folder is refused before any work; a write the file system refuses although access() allowed
    it (/proc as root, a full disk) is one line too, not an internal error."""
    pytest.importorskip("zarr")
    from dvr_gl.multires import pyramid

    volume = tmp_path / "v.npy"
    np.save(volume, np.zeros((8, 8, 8), np.float32))
    code, _, err = run(capsys, "pyramid", volume, tmp_path / "no" / "p.zarr")
    assert_one_line_error(code, err, "does not exist")

    def refused(*args, **kwargs):
        raise FileNotFoundError(2, "No such file or directory")

    monkeypatch.setattr(pyramid, "write_pyramid", refused)
    code, _, err = run(capsys, "pyramid", volume, tmp_path / "p.zarr")
    assert_one_line_error(code, err, "cannot write the pyramid (No such file or directory)")


def test_a_sequence_stopped_part_way_leaves_no_frames(tmp_path, capsys, monkeypatch):
    """Frames of a sequence are renamed into place only when all are drawn: a time limit (or any error) at
    frame 2 leaves neither frames 0 and 1 nor temporary files (it left a half sequence with exit 1)."""
    from dvr_gl.apps import render as render_cmd
    from dvr_gl.errors import DvrError

    real, calls = render_cmd.composite_over, []

    def stop_at_the_third(*args):
        calls.append(1)
        if len(calls) == 3:
            raise DvrError("stopped at frame 2")
        return real(*args)

    monkeypatch.setattr(render_cmd, "composite_over", stop_at_the_third)
    code, _, err = run(capsys, "render", "-q", "--demo", "-o", tmp_path / "seq.png", "--frames", "4", *SMALL)
    assert_one_line_error(code, err, "stopped at frame 2")
    assert list(tmp_path.iterdir()) == []
    calls.clear()
    monkeypatch.setattr(render_cmd, "composite_over", real)
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / "seq.png", "--frames", "2", *SMALL)
    assert code == 0 and sorted(p.name for p in tmp_path.iterdir()) == ["seq_0000.png", "seq_0001.png"]


def test_negative_numbers_in_scientific_notation_are_values_not_flags():
    """argparse takes -1e3 or -inf for a flag ("expected one argument"); they reach the flag's own check."""
    from dvr_gl.apps.cli import joined_negative_axes

    assert joined_negative_axes(["--rescale-intercept", "-1e3", "--azimuth", "-inf", "--up", "-z", "--fov", "-1"]) \
        == ["--rescale-intercept=-1e3", "--azimuth=-inf", "--up=-z", "--fov", "-1"]
    assert joined_negative_axes(["--set", "a=1", "-q"]) == ["--set", "a=1", "-q"]


def test_a_huge_negative_rescale_intercept_names_the_flag(tmp_path, capsys):
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / "x.png", *SMALL,
                       "--transfer-function", "ct-bone-ivory", "--rescale-intercept", "-1e300")
    assert_one_line_error(code, err, "(--rescale-intercept)", "within +-1e+12")
    assert "points" not in err


@pytest.mark.parametrize("flag, value", [("--sandbox", "{tmp}"), ("--max-seconds", "5"), ("--max-memory", "1GiB"),
                                         ("--dask", "local:2")])
def test_view_refuses_the_flags_it_would_ignore(tmp_path, capsys, flag, value):
    """dvr view parsed the sandbox's flags (render's parser) and ignored them: a scene one did not write was
    read unconfined. Refused now, before a window or a volume."""
    code, _, err = run(capsys, "view", "--demo", flag, value.format(tmp=tmp_path))
    assert_one_line_error(code, err, f"{flag} belongs to dvr render, not dvr view")


def test_link_loops_are_one_line(tmp_path, capsys):
    """A transfer-function file that is a link to itself was an internal error (pathlib's resolve); a
    --save-scene name that is one is replaced as any link there is."""
    loop = tmp_path / "loop.vp"
    loop.symlink_to(loop)
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / "x.png", *SMALL, "--transfer-function", loop)
    assert_one_line_error(code, err, "Too many levels of symbolic links")
    saved = tmp_path / "loop.toml"
    saved.symlink_to(saved)
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / "y.png", *SMALL, "--save-scene", saved,
                       "--overwrite")
    assert code == 0 and saved.is_file() and not saved.is_symlink(), err
