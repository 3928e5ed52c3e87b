"""The time per test folder that every run prints (tests/folder_times.py, loaded by conftest.py)."""

import os
import subprocess
import sys

import conftest
import folder_times
from conftest import REPO


def test_the_root_conftest_loads_the_plugin():
    assert "folder_times" in conftest.pytest_plugins


def test_folder_of_a_node_id():
    assert folder_times.folder_of("tests/apps/test_cli.py::test_x[a/b::c]") == "tests/apps"
    assert folder_times.folder_of("dvr_gl/renderers/NAME/tests/test_x.py::t") == "dvr_gl/renderers/NAME/tests"
    assert folder_times.folder_of("test_top.py::t") == "."


def test_a_run_prints_each_folder_its_tests_and_the_total(tmp_path):
    """Two folders (one slow test, two fast ones) in a run of their own: the table lists each folder
    with its test count, the slower first, and the total."""
    (tmp_path / "slow").mkdir()
    (tmp_path / "fast").mkdir()
    (tmp_path / "slow" / "test_slow.py").write_text("import time\n\ndef test_a():\n    time.sleep(0.3)\n")
    (tmp_path / "fast" / "test_fast.py").write_text("def test_b():\n    pass\n\ndef test_c():\n    pass\n")
    # only our plugin: the third-party ones the extras install (napari's, npe2's) set up in seconds on the
    # first test, which would land in the fast folder's time
    env = {**os.environ, "PYTHONPATH": str(REPO / "tests"), "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"}
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "folder_times"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    table = run.stdout.split("time per test folder", 1)[1].splitlines()[1:]
    rows = {line.split()[0]: line.split()[1:] for line in table if line.strip()}
    assert rows["slow"][0] == "1" and float(rows["slow"][1]) >= 0.3
    assert rows["fast"][0] == "2" and float(rows["fast"][1]) < 0.3
    assert rows["total"][0] == "3" and float(rows["total"][1]) >= 0.3
    names = [line.split()[0] for line in table if line.strip()]
    assert names.index("slow") < names.index("fast") < names.index("total")
