"""``dvr bench fourier``: times and errors against N, and the accuracy study on the shared datasets."""

from dvr_gl.apps.cli import main
from dvr_gl.renderers.fourier.bench.measure import BASELINE  # the ray caster, asked of the registry


def test_bench_fourier_prints_times_and_errors(tmp_path, capsys):
    md = tmp_path / "fourier.md"
    assert main(["bench", "fourier", "--sizes", "16", "--size", "24", "--error-size", "16", "--repeat", "1",
                 "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("16 ")]
    assert [r[1] for r in rows] == ["average", "xray"]
    for r in rows:
        channels, transform, ready, first = (float(v) for v in r[2:6])
        assert channels >= 0 and transform >= 0 and ready >= channels + transform - 0.015  # rounded to 0.01 s
        assert ready > 0 and first >= ready                                 # the spectrum, the first frame
        assert float(r[7]) > 0 and float(r[8]) > 0 and float(r[9]) > 0    # ms a view of both, their ratio
        assert 0 < float(r[10]) < 1e-2                                     # RMS against the converged reference
        assert float(r[12]) > 0                                            # the first frame's CPU time
    front = [line.split() for line in out.splitlines() if line.startswith(("average ", "xray "))]
    assert {r[1] for r in front} == {"fourier", BASELINE} and len(front) == 2 * (1 + 8 + 1 + 7)
    assert sum(line.startswith(("average: ", "xray: ")) and line.split()[1] in ("dominates:", "dominated:", "crossing:")
               for line in out.splitlines()) == 2
    assert "| N |" in md.read_text()
    assert main(["bench", "fourier", "--sizes", "16,x"]) == 1
    assert "--sizes" in capsys.readouterr().err


def test_dominance_compares_the_fronts_in_the_band():
    from dvr_gl.renderers.fourier.bench.measure import dominance

    ray = [{"renderer": BASELINE, "rms": 5e-3, "ms": 10.0}, {"renderer": BASELINE, "rms": 1e-5, "ms": 100.0}]
    fast = [{"renderer": "fourier", "rms": 2e-5, "ms": 5.0}]
    assert dominance(ray + fast).startswith("dominates: fourier's front is below")
    slow = [{"renderer": "fourier", "rms": 2e-5, "ms": 50.0}]  # faster from 1e-4 (100 ms), slower from 5e-3 (10)
    assert dominance(ray + slow).startswith("crossing: fourier faster at 1 of 3 error levels (at RMS 5.00e-03 the "
                                            "ray caster takes 10 ms, fourier 50 ms)")
    middle = [{"renderer": BASELINE, "rms": 2e-4, "ms": 80.0}]  # fourier faster at 1e-4 and 2e-4
    assert dominance(ray + middle + slow).startswith("crossing: fourier faster at 2 of 4 error levels (at RMS 5.00e-03")
    slowest = [{"renderer": "fourier", "rms": 2e-5, "ms": 500.0}]  # slower at every level
    assert dominance(ray + slowest).startswith("dominated: fourier is nowhere faster from 0.0001 to 0.01 RMS (at RMS "
                                               "1.00e-04 the ray caster takes 100 ms, fourier 500 ms)")
    rough = [{"renderer": "fourier", "rms": 2e-2, "ms": 1.0}]  # fast, but never within the band
    assert "fourier never reaches it" in dominance(ray + rough)


def test_bench_fourier_shared_accuracy_study(shared_data, capsys):
    assert main(["bench", "fourier", "--shared", "--data-dir", str(shared_data), "--only", "nucleon",
                 "--error-size", "16"]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()
            if line.startswith("nucleon ") and ":" not in line]
    assert [r[1] for r in rows] == ["average", "xray"]
    assert all(0 < float(r[4]) < 1e-2 for r in rows)  # RMS over the image's maximum
    assert main(["bench", "fourier", "--shared", "--data-dir", str(shared_data), "--only", "nothing-like-this"]) == 1
