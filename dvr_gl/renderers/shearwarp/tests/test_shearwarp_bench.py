"""``dvr bench shearwarp``: the run-length encoding skips the transparent voxels it promises."""

from dvr_gl.apps.cli import main


def test_bench_shearwarp_prints_a_table(shared_data, capsys):
    from dvr_gl.renderers.shearwarp.bench import measure

    rows, notes = measure.run(shared_data, size=24, repeat=1, datasets=measure.DATASETS[1:2], fractions=(0.9,))
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
