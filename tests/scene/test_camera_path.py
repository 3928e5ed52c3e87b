"""Camera paths (issue 43, item 6): keyframed cameras interpolated on the sphere, from Python, a scene file
and the command line."""

import math

import numpy as np
import pytest

from conftest import run_cli
from dvr_gl.camera import Camera
from dvr_gl.camera_path import CameraPath
from dvr_gl.errors import SceneError
from dvr_gl.image import read_image

TARGET = (1.0, -2.0, 0.5)


def _orbit(azimuth, elevation, distance, fov=30.0):
    return Camera.from_orbit(TARGET, (0.0, 0.0, 1.0), azimuth, elevation, distance, fov=fov)


def _three():
    return CameraPath((_orbit(0, 0, 10), _orbit(100, 40, 20, 50), _orbit(200, -20, 5, 20)), (0.0, 1.5, 4.0))


def test_the_path_passes_through_its_keyframes():
    path = _three()
    for camera, t in zip(path.cameras, path.times):
        assert path.camera_at(t) is camera
        near = path.camera_at(t + 1e-9 if t < path.end else t - 1e-9)  # continuous into the keyframe
        assert np.allclose(near.eye, camera.eye, atol=1e-6) and abs(near.fov - camera.fov) < 1e-6


def _direction(camera):
    return camera.basis()[0]


def test_two_keyframes_at_one_distance_stay_on_the_sphere_and_turn_evenly():
    """Slerp: the view direction turns about a fixed axis at a constant rate, so its samples at even times are
    evenly spaced (equal chords); the distance is constant (rounding only: 1e-12 relative)."""
    a, b = _orbit(10, 5, 7.0), _orbit(130, 50, 7.0)
    path = CameraPath((a, b), (2.0, 5.0))
    times = np.linspace(2.0, 5.0, 13)
    cameras = [path.camera_at(t) for t in times]
    for c in cameras:
        assert np.linalg.norm(np.subtract(c.eye, TARGET)) == pytest.approx(7.0, rel=1e-12)
    chords = [np.linalg.norm(_direction(p) - _direction(q)) for p, q in zip(cameras, cameras[1:])]
    assert max(chords) - min(chords) < 1e-12
    # about an axis normal to both view directions (pure azimuth at elevation 0): the angle is linear in time
    flat = CameraPath((_orbit(0, 0, 3.0), _orbit(120, 0, 3.0)), (0.0, 1.0))
    for t in (0.25, 0.5, 0.8):
        cos = _direction(flat.camera_at(t)) @ _direction(flat.cameras[0])
        assert math.degrees(math.acos(min(1.0, cos))) == pytest.approx(120 * t, abs=1e-9)


def test_up_stays_orthogonal_to_the_view_and_distance_is_log_linear():
    a, b = _orbit(0, 0, 1.0, fov=20), _orbit(90, 60, 100.0, fov=60)
    path = CameraPath((a, b), (0.0, 1.0))
    for t in np.linspace(0.05, 0.95, 7):
        c = path.camera_at(t)
        assert abs(_direction(c) @ np.asarray(c.up)) < 1e-12
        assert np.linalg.norm(np.subtract(c.eye, c.target)) == pytest.approx(100.0 ** t, rel=1e-12)
        assert c.fov == pytest.approx(20 + 40 * t, rel=1e-12)
    for t in np.linspace(0.0, 4.0, 17):  # several keyframes: up orthogonal too
        c = _three().camera_at(t + 1e-3 * (t == 1.5 or t == 4.0 or t == 0.0))
        assert abs(_direction(c) @ np.asarray(c.up) / np.linalg.norm(c.up)) < 1e-12


@pytest.mark.parametrize("make, words", [
    (lambda: CameraPath((_orbit(0, 0, 3),), (0.0,)), "at least two keyframes"),
    (lambda: CameraPath((_orbit(0, 0, 3), _orbit(9, 0, 3)), (1.0, 1.0)), "increase"),
    (lambda: CameraPath((_orbit(0, 0, 3), Camera((0, 0, 5), (0, 0, 0), (0, 0, 1))), (0.0, 1.0)), "parallel"),
    (lambda: CameraPath((_orbit(0, 0, 3), Camera((1, 1, 1), (1, 1, 1))), (0.0, 1.0)), "non-zero"),
])
def test_bad_keyframes_are_refused(make, words):
    with pytest.raises(SceneError, match=words) as info:
        make()
    assert "\n" not in str(info.value)


SCENE = """
[volume]
demo = "shepp-logan"
size = 12

[image]
width = 24
height = 20

[camera]
distance = 4.0
{keyframes}
"""
GOOD = """
[[camera.keyframe]]
time = 0.0
azimuth = 0.0

[[camera.keyframe]]
time = 1.0
azimuth = 120.0
elevation = 30.0
"""


def test_cli_renders_a_three_frame_gif_and_saves_the_keyframes(tmp_path, capsys):
    scene = tmp_path / "path.toml"
    scene.write_text(SCENE.format(keyframes=GOOD))
    code, out, err = run_cli(capsys, "render", scene, "-o", tmp_path / "p.gif", "--frames", 3,
                             "--save-scene", tmp_path / "saved.toml")
    assert code == 0, err
    import OpenImageIO as oiio

    frames = oiio.ImageInput.open(str(tmp_path / "p.gif"))
    count = 0
    while frames.seek_subimage(count, 0):
        count += 1
    frames.close()
    assert count == 3
    code, _, err = run_cli(capsys, "render", tmp_path / "saved.toml", "-o", tmp_path / "f.png", "--frames", 3)
    assert code == 0, err
    first, last = read_image(tmp_path / "f_0000.png"), read_image(tmp_path / "f_0002.png")
    code, _, _ = run_cli(capsys, "render", scene, "-o", tmp_path / "k.png", "--azimuth", 120, "--elevation", 30)
    assert np.array_equal(read_image(tmp_path / "k.png"), last)  # the last frame is the last keyframe's view
    assert not np.array_equal(first, last)


@pytest.mark.parametrize("keyframes, words", [
    ("[[camera.keyframe]]\ntime = 0.0\n", "at least two"),
    (GOOD.replace("time = 1.0", "time = -1.0"), "increase"),
    (GOOD.replace("azimuth = 120.0", "eye = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 0.0]"), "keyframe[1]"),
    (GOOD.replace("azimuth = 120.0\nelevation = 30.0", "eye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]"),
     "parallel"),
    (GOOD.replace("time = 1.0", ""), "give its time"),
])
def test_cli_refuses_bad_keyframes_in_one_line(tmp_path, capsys, keyframes, words):
    scene = tmp_path / "bad.toml"
    scene.write_text(SCENE.format(keyframes=keyframes))
    code, _, err = run_cli(capsys, "render", scene, "-o", tmp_path / "p.gif", "--frames", 3)
    assert code == 1 and len(err.strip().splitlines()) == 1 and words in err, err
    assert not (tmp_path / "p.gif").exists()


def test_a_recorded_path_is_saved_in_the_scene_and_read_back(tmp_path):
    """What a viewer or a notebook that records keyframes does: Scene.with_camera_path, then the scene file."""
    import dvr_gl

    scene = dvr_gl.load_scene(_write(tmp_path, SCENE.format(keyframes="")))
    path = CameraPath((_orbit(0, 0, 10), _orbit(100, 40, 20, 50), _orbit(200, -20, 5, 20)), (0.0, 1.5, 4.0))
    saved = tmp_path / "saved.toml"
    saved.write_text(scene.with_camera_path(path).to_toml(relative_to=tmp_path))
    back = dvr_gl.load_scene(saved).camera_path()
    assert back.times == path.times
    for t in (0.0, 0.7, 1.5, 3.2, 4.0):
        a, b = back.camera_at(t), path.camera_at(t)
        assert np.allclose(a.eye, b.eye, atol=1e-9) and np.allclose(a.target, b.target, atol=1e-12)
        assert np.allclose(a.basis()[2], b.basis()[2], atol=1e-9) and a.fov == pytest.approx(b.fov)


def _write(folder, text):
    (folder / "s.toml").write_text(text)
    return folder / "s.toml"


def test_keyframe_steps_choose_each_frames_time_step(tmp_path, capsys):
    """Steps 0 and 4 at times 0 and 2: frame i of 5 (time i / 2) shows step floor(2 t) = i; each step is a
    constant volume of value k, so the frames brighten step by step."""
    path = CameraPath((_orbit(0, 0, 10), _orbit(90, 0, 10)), (0.0, 2.0), (0, 4))
    assert [path.step_at(t) for t in path.frame_times(5)] == [0, 1, 2, 3, 4]
    for k in range(3):
        np.save(tmp_path / f"step_{k}.npy", np.full((6, 6, 6), float(k), np.float32))
    keyframes = "\n".join(f"[[camera.keyframe]]\ntime = {t}\nazimuth = {a}\nstep = {s}\n"
                          for t, a, s in ((0.0, 0.0, 0), (1.0, 40.0, 2)))
    scene = tmp_path / "series.toml"
    scene.write_text(f'[volume]\npath = "step_*.npy"\n[transfer_function]\npoints = [[0, 1, 1, 1, 0], '
                     f'[2, 1, 1, 1, 0.9]]\n[image]\nwidth = 16\nheight = 16\n[camera]\ndistance = 30.0\n{keyframes}')
    code, _, err = run_cli(capsys, "render", scene, "-o", tmp_path / "f.png", "--frames", 3)
    assert code == 0, err
    means = [read_image(tmp_path / f"f_{i:04d}.png")[..., :3].mean() for i in range(3)]
    assert means[0] < means[1] < means[2]
    code, _, err = run_cli(capsys, "render", scene, "-o", tmp_path / "g.png", "--frames", 3,
                           "--set", "camera.keyframe=[{time=0.0, step=0}, {time=1.0, step=3}]")
    assert code == 1 and "beyond the time series' 3 steps" in err and len(err.strip().splitlines()) == 1, err
