"""-q and -v, log lines on stderr, results on stdout, and the printed time of dvr render."""

import logging
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import run_cli
from dvr_gl.apps import progress as feedback

SMALL = ["--size", "24", "--set", "volume.size=16"]


run = run_cli


@pytest.mark.parametrize("where", ["before", "after", "long"])
def test_quiet_before_or_after_the_subcommand(tmp_path, capsys, where):
    render = ["render", "--demo", "-o", tmp_path / "x.png", *SMALL, "--frames", 2]
    argv = {"before": ["-q", *render], "after": [*render, "-q"], "long": [*render, "--quiet"]}[where]
    assert run(capsys, *argv) == (0, "", "")  # no 'wrote', no bar
    assert (tmp_path / "x_0001.png").exists()


def test_verbose_tells_the_timings_on_stderr(tmp_path, capsys):
    code, out, err = run(capsys, "-v", "render", "--demo", "-o", tmp_path / "x.png", *SMALL)
    assert code == 0 and out.startswith("wrote ")
    assert re.search(r"scene loaded and resolved in \d+\.\d\d s", err)
    assert re.search(r"frame 0 rendered in \d+\.\d\d s \(compiling the shaders included\)", err)
    code, _, err = run(capsys, "render", "--demo", "-o", tmp_path / "y.png", *SMALL)
    assert code == 0 and err == ""  # the default: no details


def test_quiet_and_verbose_together_are_refused(capsys):
    code, _, err = run(capsys, "-q", "render", "-v", "--demo", "-o", "x.png")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "give -q or -v, not both" in err


def test_warnings_name_the_command_and_the_logger_is_restored(capsys):
    logger = logging.getLogger("dvr_gl")
    level = logger.level
    with feedback.feedback("render", feedback.NORMAL):
        logging.getLogger("dvr_gl.apps.render").warning("something to know")
        logging.getLogger("dvr_gl.apps.render").debug("a detail")
    assert capsys.readouterr().err == "dvr render: warning: something to know\n"
    with feedback.feedback("render", feedback.QUIET):
        logging.getLogger("dvr_gl.io").info("chosen")
        logging.getLogger("dvr_gl.io").warning("kept")
    assert capsys.readouterr().err == "dvr render: warning: kept\n"
    assert logger.level == level and not any(isinstance(h, feedback._Handler) for h in logger.handlers)


def test_printed_times(tmp_path, capsys):
    code, out, _ = run(capsys, "render", "--demo", "-o", tmp_path / "x.png", *SMALL)
    m = re.search(r"render (\d+\.\d\d) s, total (\d+\.\d\d) s\)", out)
    assert code == 0 and m and float(m[2]) >= float(m[1])


def test_the_total_is_what_the_user_waits_for(tmp_path):
    """From a shell, the printed total includes the interpreter's start and the imports: it is close to
    the wall time measured outside the process (which adds only the spawn and the exit)."""
    if feedback.process_seconds() is None:
        pytest.skip("no /proc: the total counts from main()'s start")
    dvr = Path(sys.executable).parent / "dvr"
    start = time.perf_counter()
    done = subprocess.run([str(dvr), "render", "--demo", "-o", str(tmp_path / "x.png"), *map(str, SMALL)],
                          capture_output=True, text=True, timeout=300)
    wall = time.perf_counter() - start
    assert done.returncode == 0, done.stderr
    total = float(re.search(r"total (\d+\.\d\d) s\)", done.stdout)[1])
    # /proc counts in clock ticks (10 ms); the exit (GL context, interpreter) comes after the print
    assert 0.6 * wall - 0.05 <= total <= wall + 0.02
