"""The benchmarks across renderers run and report sensible numbers (their timings are not asserted); ``dvr bench``
lists the benches the plugins declare; the harness stays out of the core import path.

A renderer's own bench is tested in its folder (``dvr_gl/renderers/NAME/tests/test_NAME_bench.py``)."""

import math

import pytest

from conftest import SHARED_DATA
from dvr_gl.apps.cli import main
from dvr_gl.bench import format_table


def test_format_table_aligns_columns():
    text = format_table([{"a": "x", "b": 1.5}, {"a": "longer", "b": None}], [("a", "A", ""), ("b", "B", ".2f")])
    lines = text.splitlines()
    assert lines[0].startswith("A") and lines[2].endswith("1.50") and lines[3].endswith("-")
    assert len({len(line) for line in lines}) == 1


def test_bench_quality_prints_the_study(capsys):
    assert main(["bench", "quality", "--size", "16", "--volume-size", "17", "--spike-width", "0.02"]) == 0
    out = capsys.readouterr().out
    assert "pre-integration table 256x256" in out and "table build at 256x256" in out
    from dvr_gl.bench import picks, quality

    methods = quality.methods()  # the ray caster (with the fast table) and 3D slicing, by their traits
    assert len(methods) == 5 and len({name for name, _ in methods}) == 2
    rows = [line.split() for line in out.splitlines() if line.startswith(tuple(f"{n} " for n, _ in methods))]
    assert len(rows) == 5 * 8
    coarse = {(r[0], " ".join(r[1:-4])): float(r[-3]) for r in rows if r[-4] == "4"}
    # at 4 voxels between samples point sampling all but misses the spike; the table integrates it
    assert coarse[(picks.baseline(), "preintegrated")] < coarse[(picks.baseline(), "post")]
    assert "fewer samples" in out


def test_spacing_for_interpolates_log_log():
    from dvr_gl.bench.quality import spacing_for

    rows = [{"renderer": "r", "classification": "c", "spacing": d, "rms": e}
            for d, e in [(4.0, 0.4), (2.0, 0.1), (1.0, 0.025)]]
    assert spacing_for(rows, "r", "c", 0.5) == 4.0
    assert math.isclose(spacing_for(rows, "r", "c", 0.05), 2.0 / math.sqrt(2.0))  # error ~ d^2
    assert spacing_for(rows, "r", "c", 0.01) is None


def test_bench_renderers_times_whole_and_bricked(capsys):
    assert main(["bench", "renderers", "--volume-size", "24", "--size", "16", "--repeat", "1",
                 "--budget", "0.03"]) == 0
    out = capsys.readouterr().out
    from dvr_gl.bench.renderers import measured

    assert len(measured()) == 3  # the ray caster and both slicers, by their traits
    rows = [line.split() for line in out.splitlines() if line.startswith(tuple(f"{n} " for n in measured()))]
    assert len(rows) == 3 * 2 * 2
    bricks = [int(r[2]) for r in rows]
    assert bricks[0::2] == [1] * 6 and min(bricks[1::2]) > 1  # the budget run really is bricked
    assert all(float(r[3]) > 0 and float(r[4]) >= float(r[3]) for r in rows)  # a frame includes its draws


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
    from dvr_gl.bench.datasets import REGULAR

    assert set(SCATTERING_DATASETS) == {name for name, _, _ in REGULAR}
    if not (SHARED_DATA / "regular" / "bucky.nhdr").exists():
        pytest.skip("the shared datasets are absent")
    assert main(["bench", "scattering", "--demo-size", "8", "--size", "12", "--error-size", "8", "--repeat", "1",
                 "--paths", "0", "--light-volume-sizes", "8", "--shadow-ray-distances", "2,1",
                 "--datasets", "bucky", "--data-dir", str(SHARED_DATA), "--tolerance", "1e-2"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if " | " not in line and ":" in line]
    assert sum(r[0] == "bucky" and r[2] == "shadow_rays" for r in rows) == 2
    assert sum(r[0] == "bucky" and r[2] == "light_volume" for r in rows) == 6


def test_every_declared_bench_is_a_subcommand():
    """``dvr bench NAME`` for each bench a registered plugin declares, beside the harness's own."""
    from dvr_gl.apps import bench
    from dvr_gl.renderers import registry
    from dvr_gl.renderers.bench_command import commands

    declared = [c.name for p in registry.plugins().values() if p.bench is not None for c in commands(p.bench)]
    assert len(declared) >= 7 and len(set(declared)) == len(declared)  # the ray caster declares two
    assert [c.name for c in bench.renderer_benches()] == declared
    help_text = "\n".join(c.help for c in bench.renderer_benches())
    assert "GPU ray caster" in help_text and "projected tetrahedra" in help_text
    assert not set(declared) & set(bench.HARNESS)  # a renderer's bench never shadows the harness's


def test_a_plugins_bench_is_generated_from_the_registry(monkeypatch, capsys, caplog, tmp_path):
    """A third-party plugin's bench gets its subcommand, flags, table and ``--markdown`` with no edit to dvr."""
    import dataclasses

    from dvr_gl.renderers import registry
    from dvr_gl.renderers.bench_command import BenchCommand

    def arguments(parser):
        parser.add_argument("--frames", type=int, default=2)

    def run(args):
        args.report.table([{"frame": i} for i in range(args.frames)], [("frame", "frame", "d")])
        return 0

    plugin = dataclasses.replace(next(iter(registry.plugins().values())), name="toy",
                                 bench=(BenchCommand("toy", "a toy bench", arguments, run),))
    monkeypatch.setattr(registry, "plugins", lambda: {"toy": plugin})
    md = tmp_path / "toy.md"
    assert main(["bench", "toy", "--frames", "3", "--markdown", str(md)]) == 0
    assert capsys.readouterr().out.split("\n")[:5] == ["frame", "-----", "0    ", "1    ", "2    "]
    assert "| frame |" in md.read_text()
    broken = dataclasses.replace(plugin, bench="dvr_gl.no_such_module:COMMANDS")
    monkeypatch.setattr(registry, "plugins", lambda: {"toy": broken})
    from dvr_gl.apps.cli import build_parser

    benches = build_parser()._subparsers._group_actions[0].choices["bench"]._subparsers._group_actions[0].choices
    assert "toy" not in benches and "quality" in benches  # a bench that does not load leaves dvr working
    assert "toy: its bench dvr_gl.no_such_module:COMMANDS failed to load" in caplog.text


def test_the_harness_stays_out_of_the_core_import_path(tmp_path):
    """``import dvr_gl``, ``dvr_gl.render(...)`` and ``dvr render`` import neither the bench harness nor a
    renderer's measurement (only its light command module, for the flags), nor matplotlib."""
    import subprocess
    import sys

    script = f"""
import sys
import numpy as np
import dvr_gl
dvr_gl.render(np.zeros((4, 4, 4), np.float32), size=(8, 8), renderer="reference")
from dvr_gl.apps.cli import main
assert main(["render", "--demo", "blobs", "--set", "volume.size=8", "--size", "8",
             "--output", {str(tmp_path / "blobs.png")!r}]) == 0
harness = [m for m in sys.modules if m == "dvr_gl.bench" or m.startswith("dvr_gl.bench.")
           or (".bench." in m and m.startswith("dvr_gl.renderers.")) or m.split(".")[0] == "matplotlib"]
print("imported:", harness)
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "imported: []" in out.stdout
    assert (tmp_path / "blobs.png").stat().st_size > 0
