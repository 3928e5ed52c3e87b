"""The ray caster's benches (``dvr bench raycast``, ``dvr bench accel``, ``dvr bench channels``) run and
report sensible numbers (their timings are not asserted)."""

import numpy as np

from conftest import small_scene
from dvr_gl.apps.cli import main
from dvr_gl.renderers.raycast.renderer import RayCastRenderer


def test_minimal_shader_renders_the_emission_only_image():
    """The benchmark's hand-written shader does the same work as the specialized program."""
    scene = small_scene({"renderer.ert_threshold": 1.0})
    with RayCastRenderer() as ours, RayCastRenderer(fragment_shader="minimal_raycast.frag") as minimal:
        a, b = ours.render(scene), minimal.render(scene)
    assert a[..., 3].max() > 0.3
    assert np.abs(a - b).max() <= 1e-5  # the same arithmetic but 1 - exp(-tau) for small tau


def test_bench_raycast_prints_a_table(capsys, tmp_path):
    """It prints the table, and with --markdown writes it for the docs (never over a file unasked)."""
    md = tmp_path / "raycast.md"
    assert main(["bench", "raycast", "--volume-size", "16", "--size", "16", "--repeat", "1",
                 "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    assert "samples/ray" in out and "minimal hand-written shader" in out and "16x16x16" in out
    text = md.read_text()
    assert text.startswith("<!-- written by `dvr bench raycast --volume-size 16")
    assert "| case | volume | image | samples/ray | frame ms (median) | Msamples/s | of the minimal loop |" in text
    assert text.count("| emission") == 9
    assert main(["bench", "raycast", "--volume-size", "16", "--markdown", str(md)]) == 1  # exists: refused first
    assert "exists" in capsys.readouterr().err


def test_bench_accel_prints_a_table(shared_data, capsys):
    assert main(["bench", "accel", "--data-dir", str(shared_data), "--size", "24", "--repeat", "1",
                 "--only", "hydrogen", "--part", "datasets"]) == 0
    out = capsys.readouterr().out
    assert "empty-space skipping" in out and "block classes" in out and "hydrogen" in out
    skipping = next(line for line in out.splitlines() if "empty-space skipping" in line)
    assert skipping.split()[-1] == "0.0e+00"  # skipping leaves the image unchanged


def test_bench_accel_overhead_on_the_phantoms(tmp_path, capsys):
    """The alternating comparison runs on the phantoms without the datasets; on the dense phantom
    nothing is skippable (estimate and count 0) and auto does not skip."""
    assert main(["bench", "accel", "--data-dir", str(tmp_path / "absent"), "--part", "overhead", "--only",
                 "marschner-lobb", "--volume-size", "24", "--size", "16", "--views", "1"]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if line.startswith("marschner-lobb")]
    assert len(rows) == 2  # composite and MIP
    composite = rows[0]
    # outside bounds and skippable estimates, samples saved
    assert composite[3:6] == ["0.00", "0.00", "0.00"], composite


def test_bench_accel_needs_the_data(tmp_path, capsys):
    assert main(["bench", "accel", "--data-dir", str(tmp_path / "absent"), "--part", "datasets"]) == 1
    assert "shared datasets folder was not found" in capsys.readouterr().err


def test_bench_channels_prints_a_table(capsys):
    """One field, 1 to 4 channels on one grid and 2 on separate grids, each with its ratio to one field."""
    assert main(["bench", "channels", "--volume-size", "16", "--size", "16", "--repeat", "1"]) == 0
    out = capsys.readouterr().out
    assert "of one field" in out and "4 channels, one grid" in out and "2 fields, separate grids" in out
    rows = [line.split() for line in out.splitlines() if "grid" in line or line.startswith("one field")]
    assert len(rows) == 6 and rows[0][-1] == "1.00"
    assert rows[-1][4] == "2"  # separate grids: two textures
