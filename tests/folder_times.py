"""A pytest plugin: the run's time per test folder, printed after the summary.

A test's time is its setup, call and teardown together (wall seconds, as pytest reports them), so a
module- or session-scoped fixture counts in the folder of the first test that needs it.  A folder is
the test file's folder relative to the rootdir (``tests/apps``, ``dvr_gl/renderers/NAME/tests``).
``conftest.py`` loads it for every run; ``.ci/run`` runs the README's command, which shows the table.
"""

from __future__ import annotations

from collections import defaultdict

_seconds: dict[str, float] = defaultdict(float)
_tests: dict[str, set[str]] = defaultdict(set)


def folder_of(nodeid: str) -> str:
    """``tests/apps/test_cli.py::test_x[a/b]`` -> ``tests/apps``; a file at the rootdir -> ``.``."""
    path = nodeid.split("::", 1)[0]
    return path.rsplit("/", 1)[0] if "/" in path else "."


def pytest_runtest_logreport(report):
    folder = folder_of(report.nodeid)
    _seconds[folder] += report.duration
    _tests[folder].add(report.nodeid)


def folder_table(seconds: dict[str, float], tests: dict[str, set[str]]) -> list[str]:
    """The table's lines: one per folder, slowest first, then the total."""
    width = max([len(f) for f in seconds] + [len("total")])
    lines = [f"{'folder':<{width}}  {'tests':>5}  {'seconds':>8}"]
    for folder in sorted(seconds, key=lambda f: (-seconds[f], f)):
        lines.append(f"{folder:<{width}}  {len(tests[folder]):>5}  {seconds[folder]:>8.1f}")
    total_tests = sum(len(t) for t in tests.values())
    lines.append(f"{'total':<{width}}  {total_tests:>5}  {sum(seconds.values()):>8.1f}")
    return lines


def pytest_terminal_summary(terminalreporter):
    if not _seconds:
        return
    terminalreporter.write_sep("-", "time per test folder (setup + call + teardown)")
    for line in folder_table(_seconds, _tests):
        terminalreporter.write_line(line)
