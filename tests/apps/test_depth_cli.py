"""dvr render --depth: the depth image in an EXR's Z channel, beside other images in NAME.depth.exr, refused in one
line (before any work, nothing written) where the renderer, the mode or the output cannot give or hold it."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import run_cli
from dvr_gl import render, scene_of
from dvr_gl.depth_image import read_z
from dvr_gl.renderers import registry

# the CPU judge draws depth images and needs no GL: found by what it declares
JUDGE = next(n for n, p in registry.plugins().items() if p.reference and p.depth_output)


@pytest.fixture
def scene_file(tmp_path):
    z, y, x = np.meshgrid(*(np.arange(n) for n in (10, 10, 10)), indexing="ij")
    np.save(tmp_path / "blob.npy", np.exp(-((z - 5) ** 2 + (y - 4) ** 2 + (x - 5) ** 2) / 6.0).astype(np.float32))
    path = tmp_path / "blob.toml"
    path.write_text(f'[volume]\npath = "blob.npy"\n[transfer_function]\nopacity_model = "extinction"\n'
                    f'points = [[0.0, 1.0, 0.8, 0.6, 0.0], [1.0, 1.0, 0.8, 0.6, 4.0]]\n'
                    f'[image]\nwidth = 16\nheight = 12\n[renderer]\nname = "{JUDGE}"\n')
    return path


def test_exr_gets_a_z_channel(capsys, tmp_path, scene_file):
    import OpenImageIO as oiio

    out = tmp_path / "out.exr"
    code, _, err = run_cli(capsys, "render", scene_file, "-o", out, "--depth", "-q")
    assert code == 0, err
    spec = oiio.ImageBuf(str(out)).spec()
    assert list(spec.channelnames) == ["R", "G", "B", "A", "Z"] and spec.z_channel == 4
    z = read_z(out)
    expected = render(scene_file, depth=True).depth
    np.testing.assert_array_equal(z, expected)  # the same float32 values; inf where no depth
    assert np.isfinite(z).any() and np.isposinf(z).any()


def test_png_gets_a_side_file(capsys, tmp_path, scene_file):
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "render", scene_file, "-o", out, "--depth", "-q")
    assert code == 0, err
    assert out.exists()
    np.testing.assert_array_equal(read_z(tmp_path / "out.depth.exr"), render(scene_file, depth=True).depth)


@pytest.mark.parametrize("args, words", [
    (["-o", "out.gif"], "hold no depth"),
    (["-o", "out.exr", "--compositing", "average"], "has no depth"),
    (["-o", "out_.png", "--frames", "2"], "write the frames as .exr"),
])
def test_refusals_write_nothing(capsys, tmp_path, scene_file, args, words):
    args = [str(tmp_path / a) if a.startswith("out") else a for a in args]
    code, _, err = run_cli(capsys, "render", scene_file, "--depth", "-q", *args)
    assert code != 0 and words in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blob.npy", "blob.toml"]


def test_a_renderer_without_depth_is_refused(capsys, tmp_path, scene_file):
    scene = scene_of(scene_file)
    others = [n for n, p in registry.plugins().items() if not p.depth_output and registry.refusal(scene, n) is None]
    if not others:
        pytest.skip("every renderer that renders this scene draws depth")
    code, _, err = run_cli(capsys, "render", scene_file, "--depth", "-o", tmp_path / "o.exr", "--renderer", others[0])
    assert code != 0 and "draws no depth image" in err and not (tmp_path / "o.exr").exists()


def test_an_existing_side_file_is_kept(capsys, tmp_path, scene_file):
    (tmp_path / "out.depth.exr").write_bytes(b"mine")
    code, _, err = run_cli(capsys, "render", scene_file, "-o", tmp_path / "out.png", "--depth", "-q")
    assert code != 0 and "--overwrite" in err
    assert (tmp_path / "out.depth.exr").read_bytes() == b"mine" and not (tmp_path / "out.png").exists()
