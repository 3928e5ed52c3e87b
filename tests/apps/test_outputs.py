"""Animations (``--frames N -o orbit.gif``, ``.mp4``, ``.webm``, ``.webp``), their refusals, and output folders."""

import numpy as np
import pytest

from conftest import run_cli
from dvr_gl import image
from dvr_gl.errors import DvrError
from dvr_gl.image import Movie, encode_8bit, read_image

SMALL = ["--size", "40x32", "--set", "volume.size=24"]


run = run_cli


def one_line_error(code, err, *fragments):
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1, err
    for f in fragments:
        assert f in lines[0], lines[0]


def gif_frames(path):
    """(frames as uint8 RGB(A) arrays, frames per second) of a GIF, read back with OpenImageIO."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    frames, fps = [], None
    try:
        while inp.seek_subimage(len(frames), 0):
            spec = inp.spec()
            num, den = spec.getattribute("FramesPerSecond")
            fps = num / den
            frames.append(np.asarray(inp.read_image(oiio.UINT8)))
    finally:
        inp.close()
    return frames, fps


def test_frames_into_one_gif(tmp_path, capsys):
    out = tmp_path / "orbit.gif"
    code, stdout, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", 4, "--fps", 20)
    assert code == 0, err
    assert "4 frames at 20 fps" in stdout
    frames, fps = gif_frames(out)
    assert len(frames) == 4 and all(f.shape[:2] == (32, 40) for f in frames)
    assert fps == pytest.approx(20.0)  # a delay of 5 hundredths of a second: exact in GIF
    # the orbit turns: consecutive frames differ
    assert np.abs(frames[0][..., :3].astype(int) - frames[1][..., :3]).max() > 20
    assert [p.name for p in tmp_path.iterdir()] == ["orbit.gif"]  # no numbered frames, no temporary file


def test_gif_frame_is_the_png_in_256_colours(tmp_path, capsys):
    """A single-frame GIF holds one frame: the PNG's sRGB pixels, up to the GIF palette's quantization."""
    gif, png = tmp_path / "one.gif", tmp_path / "one.png"
    assert run(capsys, "render", "--demo", "-o", gif, *SMALL)[0] == 0
    assert run(capsys, "render", "--demo", "-o", png, *SMALL)[0] == 0
    frames, _ = gif_frames(gif)
    assert len(frames) == 1
    want = np.round(read_image(png)[..., :3] * 255)
    diff = np.abs(frames[0][..., :3].astype(float) - want).max(axis=2)
    # Metric: mean absolute difference in 8-bit sRGB levels, and the share of pixels off by more than 4.
    # OpenImageIO's GIF encoder builds a 256-colour median-cut palette that misplaces a few edge colours
    # even of this 22-colour frame (measured: mean 0.22 levels; 21 of 1280 pixels off, by up to 54);
    # a lost background or a linear/sRGB mix-up moves most pixels by tens of levels.
    assert diff.mean() < 2.0 and (diff > 4).mean() < 0.05


def test_mp4_and_webm_frames(tmp_path, capsys):
    av = pytest.importorskip("av", reason="PyAV (the optional extra 'video') writes MP4 and WebM")
    for suffix in (".mp4", ".webm"):
        out = tmp_path / f"orbit{suffix}"
        code, _, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", 5)
        assert code == 0, err
        with av.open(str(out)) as container:
            stream = container.streams.video[0]
            frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
            rate = float(stream.average_rate)
        assert len(frames) == 5 and frames[0].shape == (32, 40, 3)
        assert rate == pytest.approx(image.DEFAULT_FPS)
        png = tmp_path / "first.png"
        run(capsys, "render", "--demo", "-o", png, *SMALL, "--overwrite")
        want = np.round(read_image(png)[..., :3] * 255)
        # Metric: mean absolute difference, 8-bit levels.  Lossy 4:2:0 coding (chroma at half resolution)
        # at quality 18 (H.264) or 24 (VP9) of a 40x32 frame with sharp edges: measured 0.32 (MP4) and
        # 0.19 (WebM); swapped channels or a wrong range would cost tens of levels.
        assert np.abs(frames[0].astype(float) - want).mean() < 2.0


def test_animated_webp(tmp_path, capsys):
    pytest.importorskip("av", reason="PyAV (the optional extra 'video') writes animated WebP")
    out = tmp_path / "orbit.webp"
    code, _, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", 3)
    assert code == 0, err
    data = out.read_bytes()
    # FFmpeg reads no animated WebP back, so the file's own chunks: RIFF/WEBP with an animation and a frame
    # chunk (ANMF) per frame.
    assert data[:4] == b"RIFF" and data[8:12] == b"WEBP" and b"ANIM" in data
    assert data.count(b"ANMF") == 3


def test_video_without_the_extra_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(image, "have_video", lambda: False)
    out = tmp_path / "orbit.mp4"
    code, _, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", 2)
    one_line_error(code, err, "pip install -e '.[video]'")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("output, extra, fragment", [
    ("o.gif", ["--fps", "60"], "use --fps 50 or less"),
    ("o.gif", ["--fps", "0"], "positive number of frames per second"),
    ("o.gif", ["--background", "0,0,0,0.5"], "opaque background"),
    ("o.mp4", ["--size", "41x32"], "even width and height"),
    ("missing/o.gif", [], "does not exist"),
])
def test_refused_animations(tmp_path, capsys, output, extra, fragment):
    if output.endswith(".mp4"):
        pytest.importorskip("av", reason="the size check follows the check for PyAV")
    args = ["render", "--demo", "-o", tmp_path / output, "--set", "volume.size=24", "--size", "40x32", *extra,
            "--frames", 2]
    code, _, err = run(capsys, *args)
    one_line_error(code, err, fragment)
    assert not any(tmp_path.rglob("*.*"))  # nothing written, no temporary file left


def test_an_existing_animation_is_replaced_only_with_overwrite(tmp_path, capsys):
    out = tmp_path / "keep.gif"
    out.write_bytes(b"precious")
    code, _, err = run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", 2)
    one_line_error(code, err, "exists; pass --overwrite")
    assert out.read_bytes() == b"precious"
    assert run(capsys, "render", "--demo", "-o", out, *SMALL, "--frames", 2, "--overwrite")[0] == 0
    assert len(gif_frames(out)[0]) == 2


def test_a_failed_animation_leaves_no_file(tmp_path):
    """An error between frames (a render failing, Ctrl-C) and too few frames both leave nothing."""
    frame = np.full((8, 8, 4), 0.5, np.float32)
    with pytest.raises(KeyboardInterrupt):
        with Movie(tmp_path / "a.gif", 3) as movie:
            movie.add(frame)
            raise KeyboardInterrupt
    with pytest.raises(DvrError, match="1 of 3 frames"):
        with Movie(tmp_path / "b.gif", 3) as movie:
            movie.add(frame)
    assert list(tmp_path.iterdir()) == []
    with Movie(tmp_path / "c.gif", 1) as movie:
        movie.add(frame)
    assert [p.name for p in tmp_path.iterdir()] == ["c.gif"]
    assert gif_frames(tmp_path / "c.gif")[0][0][0, 0, 0] == encode_8bit(frame)[0, 0, 0]


@pytest.mark.parametrize("flag", ["--save-scene", "bench"])
def test_missing_output_folders_are_refused_in_one_line(tmp_path, capsys, flag):
    """One behaviour for every output: a folder that does not exist is refused before any work."""
    if flag == "bench":
        argv = ["bench", "tradeoff", "--demo", "blobs", "--output", tmp_path / "no" / "x"]
    else:
        argv = ["render", "--demo", "-o", tmp_path / "x.png", *SMALL, "--save-scene", tmp_path / "no" / "s.toml"]
    code, _, err = run(capsys, *argv)
    one_line_error(code, err, "does not exist; create it first")
    assert list(tmp_path.iterdir()) == []


def test_image_save_as_gif_is_srgb(tmp_path):
    """``Image.save("x.gif")`` writes the same 8-bit sRGB pixels as a PNG (not linear values)."""
    import dvr_gl

    picture = dvr_gl.render(np.linspace(0, 1, 8 ** 3, dtype=np.float32).reshape(8, 8, 8), size=16,
                            transfer_function="grayscale")
    picture.save(tmp_path / "x.gif")
    picture.save(tmp_path / "x.png")
    frames, _ = gif_frames(tmp_path / "x.gif")
    want = np.round(read_image(tmp_path / "x.png")[..., :3] * 255)
    # Metric: mean absolute difference in 8-bit levels, as for the CLI's GIF above (palette quantization);
    # linear values written as if sRGB would darken the mid-greys by tens of levels.
    assert len(frames) == 1 and np.abs(frames[0][..., :3] - want).mean() < 2.0


@pytest.mark.parametrize("kind", ["dangling", "loop"])
def test_an_output_name_that_is_a_link_is_replaced_only_with_overwrite(tmp_path, kind):
    """A dangling or looping link at the output's name is something there: the rename would replace it."""
    out = tmp_path / "out.png"
    out.symlink_to(tmp_path / "missing.png" if kind == "dangling" else out)
    with pytest.raises(DvrError, match="exists; pass --overwrite"):
        image.check_output_path(out)
    assert out.is_symlink()
    assert image.check_output_path(out, overwrite=True) == out
