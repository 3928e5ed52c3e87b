"""``dvr bench splatting``: every scheme's row against its oracle, and the 45-degree study."""

from dvr_gl.apps.cli import main


def test_bench_splatting_prints_the_schemes_and_the_study(tmp_path, capsys):
    md = tmp_path / "splatting.md"
    assert main(["bench", "splatting", "--volume-size", "12", "--size", "16", "--repeat", "1", "--study-size", "16",
                 "--particles", "8", "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    table, study = out.split("the 45-degree study")
    rows = [line.split() for line in table.splitlines() if line.startswith("Shepp-Logan") and ":" not in line]
    assert [(r[2], r[3]) for r in rows] == [("image_aligned", "post"), ("image_aligned", "pre"),
                                            ("axis_aligned", "post"), ("none", "pre"), ("image_aligned", "post-shaded")]
    assert all(float(r[9]) < 1e-4 for r in rows)          # against its oracle: float32
    assert float(rows[0][-1]) > 0  # the ratio to the ray caster at equal RMS (interleaved)
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


def test_bench_splatting_cuts_the_kernel_where_asked(capsys):
    """``--kernel-radius``: the grid's kernel cut at 4 standard deviations, against its own oracle; the header says
    so; a radius outside 3-6 is refused in one line."""
    assert main(["bench", "splatting", "--volume-size", "8", "--size", "8", "--repeat", "1", "--study-size", "0",
                 "--particles", "0", "--no-shaded", "--kernel-radius", "4"]) == 0
    out = capsys.readouterr().out
    assert "cut at 4 standard deviations" in out
    rows = [line.split() for line in out.splitlines() if line.startswith("Shepp-Logan") and ":" not in line]
    assert len(rows) == 4 and all(float(r[9]) < 1e-4 for r in rows)  # against its oracle (of the same cut)
    assert main(["bench", "splatting", "--volume-size", "8", "--size", "8", "--particles", "0",
                 "--kernel-radius", "2"]) == 1
    assert "renderer.kernel_radius must be in [3, 6]" in capsys.readouterr().err
