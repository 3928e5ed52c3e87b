"""The benchmarks run and report sensible numbers (their timings are not asserted)."""

import math

import numpy as np
import pytest

from conftest import SHARED_DATA, small_scene
from dvr_gl.apps.cli import main
from dvr_gl.bench import format_table
from dvr_gl.renderers.raycast.renderer import RayCastRenderer


def test_minimal_shader_renders_the_emission_only_image():
    """The benchmark's hand-written shader does the same work as the specialized program."""
    scene = small_scene({"renderer.ert_threshold": 1.0})
    with RayCastRenderer() as ours, RayCastRenderer(fragment_shader="bench/minimal_raycast.frag") as minimal:
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


def test_format_table_aligns_columns():
    text = format_table([{"a": "x", "b": 1.5}, {"a": "longer", "b": None}], [("a", "A", ""), ("b", "B", ".2f")])
    lines = text.splitlines()
    assert lines[0].startswith("A") and lines[2].endswith("1.50") and lines[3].endswith("-")
    assert len({len(line) for line in lines}) == 1


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


def test_bench_quality_prints_the_study(capsys):
    assert main(["bench", "quality", "--size", "16", "--volume-size", "17", "--spike-width", "0.02"]) == 0
    out = capsys.readouterr().out
    assert "pre-integration table 256x256" in out and "table build at 256x256" in out
    rows = [line.split() for line in out.splitlines() if line.startswith(("raycast ", "slicing3d "))]
    assert len(rows) == 5 * 8
    coarse = {(r[0], " ".join(r[1:-4])): float(r[-3]) for r in rows if r[-4] == "4"}
    # at 4 voxels between samples point sampling all but misses the spike; the table integrates it
    assert coarse[("raycast", "preintegrated")] < coarse[("raycast", "post")]
    assert "fewer samples" in out


def test_spacing_for_interpolates_log_log():
    from dvr_gl.bench.quality import spacing_for

    rows = [{"renderer": "r", "classification": "c", "spacing": d, "rms": e}
            for d, e in [(4.0, 0.4), (2.0, 0.1), (1.0, 0.025)]]
    assert spacing_for(rows, "r", "c", 0.5) == 4.0
    assert math.isclose(spacing_for(rows, "r", "c", 0.05), 2.0 / math.sqrt(2.0))  # error ~ d^2
    assert spacing_for(rows, "r", "c", 0.01) is None


def test_bench_slicing_shows_the_stack_switch(tmp_path, capsys):
    args = ["bench", "slicing", "--size", "24", "--volume-size", "16", "--pictures", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    sweep, jump = out.split("image change")
    jumps = {float(line.split()[0]): [float(x) for x in line.split()[1:]] for line in jump.splitlines()
             if line.startswith(("30 ", "45 "))}
    stacks = {line.split()[0]: line.split()[1] for line in sweep.splitlines() if line[:3] in ("44 ", "46 ")}
    assert stacks == {"44": "y", "46": "x"}
    # the 2D stack's image jumps where it switches; view-aligned slices do not care
    assert jumps[45.0][0] > 5 * jumps[30.0][0]
    assert jumps[45.0][2] < 3 * jumps[30.0][2]
    for name in ("slicing_sweep.png", "slicing_jump.png"):
        assert (tmp_path / name).stat().st_size > 0
    before = (tmp_path / "slicing_jump.png").read_bytes()
    assert main(args) == 1                                   # no --overwrite: refused before any work
    assert "exists; pass --overwrite" in capsys.readouterr().err
    assert (tmp_path / "slicing_jump.png").read_bytes() == before


def test_bench_renderers_times_whole_and_bricked(capsys):
    assert main(["bench", "renderers", "--volume-size", "24", "--size", "16", "--repeat", "1",
                 "--budget", "0.03"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith(("raycast ", "slicing3d ", "slicing2d "))]
    assert len(rows) == 3 * 2 * 2
    bricks = [int(r[2]) for r in rows]
    assert bricks[0::2] == [1] * 6 and min(bricks[1::2]) > 1  # the budget run really is bricked
    assert all(float(r[3]) > 0 and float(r[4]) >= float(r[3]) for r in rows)  # a frame includes its draws


def test_bench_shearwarp_prints_a_table(shared_data, capsys):
    from dvr_gl.bench import shearwarp

    rows, notes = shearwarp.run(shared_data, size=24, repeat=1, datasets=shearwarp.DATASETS[1:2], fractions=(0.9,))
    assert not notes and len(rows) == 1
    row = rows[0]
    # the ramp starts at the 90 % quantile: about 90 % of the lobster's voxels are transparent (ties in
    # uint8 data move it), and at least those are never read
    assert 0.85 <= row["transparent"] <= 0.95 and row["skipped"] >= row["transparent"] - 1e-12
    assert row["build_s"] > 0 and row["ms"] > 0 and row["raycast_ms"] > 0 and row["rle_mb"] > 0
    assert row["normals_s"] > 0 and row["shaded_ms"] > 0


def test_bench_shearwarp_needs_the_data(tmp_path, capsys):
    assert main(["bench", "shearwarp", "--data-dir", str(tmp_path / "absent")]) == 1
    assert "shared datasets folder was not found" in capsys.readouterr().err


def test_bench_splatting_prints_the_schemes_and_the_study(tmp_path, capsys):
    md = tmp_path / "splatting.md"
    assert main(["bench", "splatting", "--volume-size", "12", "--size", "16", "--repeat", "1", "--study-size", "16",
                 "--particles", "216", "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    table, study = out.split("the 45-degree study")
    rows = [line.split() for line in table.splitlines() if line.startswith("Shepp-Logan") and ":" not in line]
    assert [(r[2], r[3]) for r in rows] == [("image_aligned", "post"), ("image_aligned", "pre"),
                                            ("axis_aligned", "post"), ("none", "pre"), ("image_aligned", "post-shaded")]
    assert all(float(r[9]) < 1e-4 for r in rows)          # against its oracle: float32
    particles = [line.split() for line in table.splitlines() if line.startswith("Plummer,") and ":" not in line]
    assert [(r[4], r[5]) for r in particles] == [("image_aligned", "post"), ("image_aligned", "pre"), ("none", "pre"),
                                                 ("image_aligned", "post-shaded")]
    assert all(float(r[11]) < 1e-4 for r in particles)
    changes = {line.split()[0]: [float(x) for x in line.split()[1:]] for line in study.splitlines()
               if line.startswith(("30 ", "45 "))}
    # axis-aligned sheets jump where their axis switches; image-aligned ones follow the converged image
    assert changes["45"][1] > 5 * changes["45"][2] and changes["45"][0] < 3 * changes["45"][2]
    assert "| dataset |" in md.read_text()
    assert main(["bench", "splatting", "--shared", "--data-dir", str(tmp_path / "absent")]) == 1
    assert "no such folder" in capsys.readouterr().err


def test_bench_splatting_leaves_the_shaded_row_out(capsys):
    assert main(["bench", "splatting", "--volume-size", "8", "--size", "8", "--repeat", "1", "--study-size", "0",
                 "--particles", "0", "--no-shaded"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("Shepp-Logan") and ":" not in line]
    assert [r[3] for r in rows] == ["post", "pre", "post", "pre"]
    assert "the shaded row left out" in out


def test_bench_scattering_prints_methods_equal_error_and_multiple_scattering(tmp_path, capsys):
    md = tmp_path / "scattering.md"
    assert main(["bench", "scattering", "--demo-size", "12", "--size", "16", "--error-size", "8", "--repeat", "1",
                 "--paths", "8", "--paths-size", "6", "--light-volume-sizes", "8,16,32", "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("shadow demo ") and ":" not in line]
    methods = [r[3] for r in rows[:42]]
    assert methods.count("shadow_rays") == 6 and methods.count("light_volume") == 18
    assert methods.count("half_angle") == 18
    assert "at equal error" in out and "what single scattering leaves out" in out
    assert "| scene |" in md.read_text()
    assert main(["bench", "scattering", "--paths", "-1"]) == 1
    assert "--paths" in capsys.readouterr().err
    assert main(["bench", "scattering", "--light-volume-sizes", "8,x"]) == 1
    assert "--light-volume-sizes" in capsys.readouterr().err
    assert main(["bench", "scattering", "--datasets", "bucky,nosuch"]) == 1
    assert "no shared dataset named nosuch" in capsys.readouterr().err
    assert main(["bench", "scattering", "--shadow-ray-distances", "0.5,0"]) == 1
    assert "--shadow-ray-distances must be" in capsys.readouterr().err


def test_bench_scattering_datasets_and_shadow_ray_distances(tmp_path, capsys):
    """``--datasets`` names any shared dataset the other benches know (the larger ones too), and the
    shadow rays' distances are chosen (a large dataset's 0.25-voxel rows take minutes a frame)."""
    from dvr_gl.apps.bench import SCATTERING_DATASETS
    from dvr_gl.bench.splatting import DATASETS

    assert set(SCATTERING_DATASETS) == {name for name, _, _ in DATASETS}
    if not (SHARED_DATA / "regular" / "bucky.nhdr").exists():
        pytest.skip("the shared datasets are absent")
    assert main(["bench", "scattering", "--demo-size", "8", "--size", "12", "--error-size", "8", "--repeat", "1",
                 "--paths", "0", "--light-volume-sizes", "8", "--shadow-ray-distances", "2,1",
                 "--datasets", "bucky", "--data-dir", str(SHARED_DATA), "--tolerance", "1e-2"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if " | " not in line and ":" in line]
    assert sum(r[0] == "bucky" and r[2] == "shadow_rays" for r in rows) == 2
    assert sum(r[0] == "bucky" and r[2] == "light_volume" for r in rows) == 6


def test_bench_fourier_prints_times_and_errors(tmp_path, capsys):
    md = tmp_path / "fourier.md"
    assert main(["bench", "fourier", "--sizes", "16", "--size", "24", "--error-size", "16", "--repeat", "1",
                 "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("16 ")]
    assert [r[1] for r in rows] == ["average", "xray"]
    for r in rows:
        assert float(r[2]) >= 0 and float(r[5]) > 0 and float(r[6]) > 0   # pre-processing, ms per view, ray caster
        assert 0 < float(r[8]) < 1e-2                                      # RMS against the converged reference
    assert "| N |" in md.read_text()
    assert main(["bench", "fourier", "--sizes", "16,x"]) == 1
    assert "--sizes" in capsys.readouterr().err


def test_bench_fourier_shared_accuracy_study(shared_data, capsys):
    assert main(["bench", "fourier", "--shared", "--data-dir", str(shared_data), "--only", "nucleon",
                 "--error-size", "16"]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()
            if line.startswith("nucleon ") and ":" not in line]
    assert [r[1] for r in rows] == ["average", "xray"]
    assert all(0 < float(r[4]) < 1e-2 for r in rows)  # RMS over the image's maximum
    assert main(["bench", "fourier", "--shared", "--data-dir", str(shared_data), "--only", "nothing-like-this"]) == 1
