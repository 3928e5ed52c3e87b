"""dvr render and dvr info on several fields and time steps: several files as fields of one scene, --channel,
--time, --animate time (docs/cli.md, "Several fields and time").

Images are compared as float32 EXR (the renderer's own values, background composited) with equality: the same
scene rendered by the same renderer must give the same bits, whichever way it was given."""

import numpy as np
import pytest

import dvr_gl
from conftest import run_cli
from dvr_gl.image import composite_over, read_image

SIZE = ["--size", "24x20"]
STEPS = 4
#: a transfer function in data units (points), so that every frame of an animation classifies as its step alone
POINTS = ["--set", "transfer_function.points=[[0, 1, 1, 1, 0], [1, 1, 0.5, 0.2, 0.5]]"]


def blob(cx: float, n: int = 12) -> np.ndarray:
    z, y, x = np.mgrid[0:n, 0:n, 0:n]
    return np.exp(-((x - cx) ** 2 + (y - n / 2) ** 2 + (z - n / 2) ** 2) / 8.0).astype(np.float32)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Two 12^3 fields (a.npy, b.npy), a label map of both, and a series of STEPS steps (a glob of .npy files)."""
    folder = tmp_path_factory.mktemp("fields")
    a, b = blob(4.0), blob(8.0)
    np.save(folder / "a.npy", a)
    np.save(folder / "b.npy", b)
    np.save(folder / "seg.npy", ((a > 0.5) + 2 * (b > 0.5)).astype(np.uint8))
    (folder / "series").mkdir()
    steps = np.stack([blob(3.0 + 2 * k) for k in range(STEPS)])
    for k in range(STEPS):
        np.save(folder / "series" / f"step_{k}.npy", steps[k])
    return folder, a, b, steps


def render(capsys, *argv):
    code, out, err = run_cli(capsys, "render", *map(str, argv), *SIZE, "--overwrite")
    assert code == 0, err
    return out


def one_line_error(capsys, *argv) -> str:
    code, _, err = run_cli(capsys, "render", *map(str, argv), *SIZE)
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    return err


def test_two_files_render_as_the_apis_two_fields(files, tmp_path, capsys):
    """dvr render a.npy b.npy: one scene of two fields, each with its channel colour, the image the API makes
    of the two arrays (equal bits)."""
    folder, a, b, _ = files
    render(capsys, folder / "a.npy", folder / "b.npy", "-o", tmp_path / "two.exr")
    image = dvr_gl.render([a, b], size=(24, 20))
    assert image.scene.field.kind == "fields"
    expected = composite_over(image.rgba, image.scene.image.background)
    cli = read_image(tmp_path / "two.exr")
    assert np.array_equal(cli, expected[..., :cli.shape[-1]])
    assert cli[..., :3].max() > 0.05  # not an empty picture


def test_one_transfer_function_per_file_and_the_saved_scene(files, tmp_path, capsys):
    """--transfer-function twice: the k-th for the k-th file; the saved scene ([[volume]] tables) renders
    the same image."""
    folder, *_ = files
    render(capsys, folder / "a.npy", folder / "b.npy", "--transfer-function", "inferno", "--transfer-function",
           "viridis", "-o", tmp_path / "tf.exr", "--save-scene", tmp_path / "tf.toml")
    saved = (tmp_path / "tf.toml").read_text()
    assert saved.count("[[volume]]") == 2 and saved.count("[volume.transfer_function]") == 2
    render(capsys, tmp_path / "tf.toml", "-o", tmp_path / "again.exr")
    assert np.array_equal(read_image(tmp_path / "tf.exr"), read_image(tmp_path / "again.exr"))
    render(capsys, folder / "a.npy", folder / "b.npy", "-o", tmp_path / "default.exr")
    assert not np.array_equal(read_image(tmp_path / "tf.exr"), read_image(tmp_path / "default.exr"))


def test_labels_flag_adds_a_label_field(files, tmp_path, capsys):
    """--labels FILE: a label map beside the image; the saved scene gives it role label."""
    from dvr_gl.apps import render as render_cmd
    from dvr_gl.apps.cli import build_parser

    folder, *_ = files
    args = build_parser().parse_args(["render", str(folder / "a.npy"), "--labels", str(folder / "seg.npy"),
                                      "-o", "x.png"])
    render_cmd.positional_volume(args)
    source = render_cmd.source_of(args)
    tables = source.base["volume"]
    assert [t["role"] for t in tables] == ["scalar", "label"] and tables[1]["path"].endswith("seg.npy")
    scene = source.load()
    assert [layer.role for layer in scene.layers] == ["scalar", "label"]


def test_a_label_maps_colour_table_from_the_command_line(files, tmp_path):
    """--transfer-function per file: the label map's is its colour table file (Slicer .ctbl); the CT's a
    preset."""
    from dvr_gl.apps import render as render_cmd
    from dvr_gl.apps.cli import build_parser

    folder, *_ = files
    (tmp_path / "seg.ctbl").write_text("0 Background 0 0 0 0\n1 one 255 0 0 255\n2 two 0 255 0 255\n")
    args = build_parser().parse_args(["render", str(folder / "a.npy"), "--labels", str(folder / "seg.npy"),
                                      "--transfer-function", "ct-bone-ivory", "--transfer-function",
                                      str(tmp_path / "seg.ctbl"), "-o", "x.png"])
    render_cmd.positional_volume(args)
    scene = render_cmd.source_of(args).load()
    rows = {int(r[0]): list(r[1:]) for r in scene.layers[1].transfer_function.to_table()["labels"]}
    assert rows[1] == [1.0, 0.0, 0.0, 1.0] and rows[2] == [0.0, 1.0, 0.0, 1.0]
    assert scene.layers[0].transfer_function is scene.transfer_function


def test_time_k_renders_step_k_alone(files, tmp_path, capsys):
    """--time K on a series (a glob of 3D files) is step K's file rendered alone, bit for bit; and the API's
    time_axis/time is that step's array alone."""
    folder, _, _, steps = files
    render(capsys, folder / "series" / "step_*.npy", "--time", 2, "-o", tmp_path / "t2.exr")
    render(capsys, folder / "series" / "step_2.npy", "-o", tmp_path / "alone.exr")
    assert np.array_equal(read_image(tmp_path / "t2.exr"), read_image(tmp_path / "alone.exr"))
    stepped = dvr_gl.render(steps, time_axis=0, time=2, size=(24, 20))
    alone = dvr_gl.render(steps[2], size=(24, 20))
    assert np.array_equal(stepped.rgba, alone.rgba)


def test_time_applies_to_the_files_with_steps(files, tmp_path, capsys):
    """A series beside a file without time: --time K steps the series, the other stays as it is."""
    folder, *_ = files
    render(capsys, folder / "series" / "step_*.npy", folder / "b.npy", "--time", 3, "-o", tmp_path / "t3.exr")
    render(capsys, folder / "series" / "step_3.npy", folder / "b.npy", "-o", tmp_path / "alone.exr")
    assert np.array_equal(read_image(tmp_path / "t3.exr"), read_image(tmp_path / "alone.exr"))


def test_animate_time_writes_a_frame_per_step(files, tmp_path, capsys):
    """--animate time: one frame per step without --frames; --frames N: frame i shows step floor(i S / N),
    the image --time of that step makes (a transfer function in data units: POINTS)."""
    folder, *_ = files
    series = folder / "series" / "step_*.npy"
    out = render(capsys, series, "--animate", "time", "-o", tmp_path / "steps.png", *POINTS)
    assert f"{STEPS} frames" in out
    frames = sorted(tmp_path.glob("steps_*.png"))
    assert len(frames) == STEPS
    for k in (1, 3):
        render(capsys, series, "--time", k, "-o", tmp_path / f"t{k}.png", *POINTS)
        assert np.array_equal(read_image(frames[k]), read_image(tmp_path / f"t{k}.png"))
    render(capsys, series, "--animate", "time", "--frames", 6, "-o", tmp_path / "six.png", *POINTS)
    six = sorted(tmp_path.glob("six_*.png"))
    assert len(six) == 6
    for i in range(6):  # steps 0 0 1 2 2 3
        k = i * STEPS // 6
        assert np.array_equal(read_image(six[i]), read_image(frames[k])), (i, k)


def test_animate_time_and_orbit_into_one_gif(files, tmp_path, capsys):
    folder, *_ = files
    out = render(capsys, folder / "series" / "step_*.npy", "--animate", "time,orbit", "--frames", 5,
                 "-o", tmp_path / "both.gif")
    assert "5 frames" in out and (tmp_path / "both.gif").stat().st_size > 0


@pytest.mark.parametrize("argv, fragment", [
    (["{a}", "--transfer-function", "inferno", "--transfer-function", "viridis"], "given 2 times for 1 file"),
    (["{a}", "{b}", "--time", "1"], "none of the files has time steps"),
    (["{a}", "--animate", "time"], "a.npy has one time step"),
    (["{a}", "{b}", "--animate", "time"], "none of the files has more than one time step"),
    (["--rgb", "{a}"], "role scalar"),
    (["{series}", "--animate", "orbit"], "needs --frames"),
    (["{series}", "--animate", "time", "--time", "1"], "give one"),
    (["{series}", "--animate", "spin"], "give orbit, time, or time,orbit"),
    (["{series}", "{short}", "--animate", "time"], "different numbers"),
    (["{a}", "--demo"], "give it once"),
    (["--labels", "{a}", "--demo"], "not both"),
    (["{a}", "--channel", "1"], "no channels"),
])
def test_bad_flags_are_one_line(files, tmp_path, capsys, argv, fragment):
    folder, *_ = files
    short = tmp_path / "short"
    short.mkdir()
    for k in range(2):
        np.save(short / f"s_{k}.npy", blob(5.0))
    names = {"a": folder / "a.npy", "b": folder / "b.npy", "series": folder / "series" / "step_*.npy",
             "short": short / "s_*.npy"}
    err = one_line_error(capsys, *[a.format(**names) for a in argv], "-o", tmp_path / "x.png")
    assert fragment in err, err


def test_a_scene_file_with_volume_files_is_one_line(files, tmp_path, capsys):
    folder, *_ = files
    render(capsys, folder / "a.npy", "-o", tmp_path / "a.png", "--save-scene", tmp_path / "a.toml")
    err = one_line_error(capsys, tmp_path / "a.toml", "--labels", folder / "seg.npy", "-o", tmp_path / "x.png")
    assert "[[volume]] tables" in err


def test_info_lists_time_steps(files, capsys):
    folder, *_ = files
    code, out, err = run_cli(capsys, "info", str(folder / "series" / "step_*.npy"))
    assert code == 0, err
    assert f"time steps: {STEPS}" in out and "--time K" in out


def test_info_lists_channels_with_names(shared_data, capsys):
    """The two-channel confocal/widefield nucleus (ImageJ hyperstack): both channels, each summarised."""
    path = shared_data / "microscopy" / "xyzc_16bit__dna_conf_wf.tif"
    if not path.is_file():
        pytest.skip(f"{path.name} not in the shared data")
    code, out, err = run_cli(capsys, "info", str(path))
    assert code == 0, err
    assert "channels: 2" in out and "channel 0 (" in out and "channel 1 (" in out and "--channel 1" in out


def test_one_transfer_function_per_channel_of_one_file(shared_data, tmp_path, capsys):
    """One file with C channels and C --transfer-function: a [[volume]] table per channel (volume.channel = k),
    the k-th function channel k's (the two-channel nucleus, ImageJ hyperstack)."""
    from dvr_gl.apps import render as render_cmd
    from dvr_gl.apps.cli import build_parser

    path = shared_data / "microscopy" / "xyzc_16bit__dna_conf_wf.tif"
    if not path.is_file():
        pytest.skip(f"{path.name} not in the shared data")
    args = build_parser().parse_args(["render", str(path), "--transfer-function", "inferno",
                                      "--transfer-function", "viridis", "-o", "x.png"])
    render_cmd.positional_volume(args)
    source = render_cmd.source_of(args)
    assert [(t["channel"], t["transfer_function"]) for t in source.base["volume"]] == [
        (0, {"preset": "inferno"}), (1, {"preset": "viridis"})]
    scene = source.load()
    assert len(scene.layers) == 2 and scene.sources[1].channel == 1
    err = one_line_error(capsys, path, *["--transfer-function", "inferno"] * 3, "-o", tmp_path / "x.png")
    assert "one per channel" in err
