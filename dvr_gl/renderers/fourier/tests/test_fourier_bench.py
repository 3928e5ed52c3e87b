"""``dvr bench fourier``: times and errors against N, and the accuracy study on the shared datasets."""

from dvr_gl.apps.cli import main


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
