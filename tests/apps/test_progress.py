"""Progress of long work: the callback of the Python API, bars on stderr after a delay, silence with -q."""

import bz2
import gzip

import numpy as np
import pytest

import dvr_gl
from dvr_gl import progress
from dvr_gl.apps.cli import main
from dvr_gl.io import compression
from dvr_gl.renderers import registry
from judges import DISCRETE

#: the renderer of a grid that names none (its bench measures frames)
DEFAULT = registry.default_for("grid")

SMALL = ["--size", "12", "--set", "volume.size=12"]


def calls_of(work):
    """The (done, total) calls a callback receives while ``work()`` runs."""
    calls = []
    with progress.reporting(lambda done, total: calls.append((done, total))):
        work()
    return calls


def test_nobody_listens_by_default():
    with progress.task("work", 3) as step:
        step(1)  # costs nothing, tells nobody
    assert not progress.listening()
    with progress.reporting(lambda *a: None):
        assert progress.listening()


def test_a_bad_progress_value_is_refused():
    with pytest.raises(TypeError, match="callable"):
        with progress.reporting("yes"):
            pass


@pytest.mark.parametrize("compress, encoding", [(gzip.compress, "gzip"), (bz2.compress, "bzip2")])
def test_decompressing_reports_the_bytes(tmp_path, compress, encoding):
    data = np.random.default_rng(0).integers(0, 255, 3 << 20, dtype=np.uint8).tobytes()  # 3 MiB: several reads
    path = tmp_path / "v.raw.gz"
    path.write_bytes(compress(data))
    calls = calls_of(lambda: compression.read_data(path, len(data), name=str(path), encoding=encoding))
    assert len(calls) >= 2 and calls[-1] == (len(data), len(data))
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)  # it only moves forward


def test_api_render_tells_the_reference_steps():
    volume = np.linspace(0, 1, 8 ** 3, dtype=np.float32).reshape(8, 8, 8)
    calls = []
    image = dvr_gl.render(volume, size=16, renderer=DISCRETE, progress=lambda d, t: calls.append((d, t)))
    assert image.shape == (16, 16, 4)
    assert calls and calls[-1][0] == calls[-1][1]  # the last step: all done


def test_tolerance_search_reports_its_renders():
    volume = np.linspace(0, 1, 12 ** 3, dtype=np.float32).reshape(12, 12, 12)
    calls = []
    dvr_gl.render(volume, size=16, tolerance=3e-3, shading=False, progress=lambda d, t: calls.append((d, t)))
    renders = [c for c in calls if c[1] is not None and c[1] >= 3]
    # the a-posteriori check renders at d, d/2 and d/4 at least, then says it is done
    assert len(renders) >= 3 and renders[-1][0] == renders[-1][1]


def test_short_work_prints_no_bar(tmp_path, capsys):
    assert main(["render", "--demo", "-o", str(tmp_path / "x.png"), *SMALL, "--renderer", DISCRETE]) == 0
    assert capsys.readouterr().err == ""  # done within progress.DELAY: nothing drawn


def test_long_work_shows_a_bar_unless_quiet(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(progress, "DELAY", 0.0)  # every task is "long"
    argv = ["render", "--demo", "-o", str(tmp_path / "x.png"), *SMALL, "--renderer", DISCRETE]
    assert main(argv) == 0
    assert "rendering" in capsys.readouterr().err
    assert main(["-q", *argv, "--overwrite"]) == 0
    assert capsys.readouterr() == ("", "")


def test_every_bench_has_a_bar(capsys, monkeypatch):
    monkeypatch.setattr(progress, "DELAY", 0.0)
    assert main(["bench", DEFAULT, "--volume-size", "12", "--size", "12", "--repeat", "1"]) == 0
    out, err = capsys.readouterr()
    assert f"dvr bench {DEFAULT}" in err and "frame" in err  # the bar counts the frames measured
    assert f"dvr bench {DEFAULT}" in out  # the table stays on stdout
    assert main(["bench", DEFAULT, "-q", "--volume-size", "12", "--size", "12", "--repeat", "1"]) == 0
    assert capsys.readouterr().err == ""


def test_a_notebook_without_ipywidgets_gets_the_text_bar_silently():
    """In a Jupyter kernel without ipywidgets, tqdm.auto warns "IProgress not found" and falls back to
    its text bar; ours falls back without the warning (a fresh interpreter: tqdm decides on import)."""
    import os
    import subprocess
    import sys

    code = """
import sys, types, warnings
warnings.simplefilter("always")   # shown on stderr (as error, tqdm would catch it)
shell = type("ZMQInteractiveShell", (), {})()
sys.modules["ipykernel.zmqshell"] = types.ModuleType("ipykernel.zmqshell")
ipython = types.ModuleType("IPython"); ipython.get_ipython = lambda: shell
sys.modules["IPython"] = ipython
sys.modules["ipywidgets"] = None          # import ipywidgets raises ImportError
from dvr_gl import progress
bar = progress.Bar("work", 3, delay=0.0)
bar(2); bar.close()
print(type(bar.bar).__module__)
"""
    env = {k: v for k, v in os.environ.items() if k != "QT_API" and not k.startswith("SPYDER")}  # tqdm: a console
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() in ("tqdm.std", "tqdm.asyncio") and "IProgress" not in run.stderr
