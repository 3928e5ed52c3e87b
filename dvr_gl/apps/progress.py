"""What the ``dvr`` command tells while it works, on stderr: log lines (logger ``dvr_gl``) and progress bars.

* default: what was chosen or skipped (``INFO``), warnings, and a bar for any task that runs longer
  than :data:`dvr_gl.progress.DELAY` seconds;
* ``-q``/``--quiet``: warnings and errors only, no bars (results such as ``wrote x.png`` are not printed);
* ``-v``/``--verbose``: also ``DEBUG``: timings of loading, the first frame (compiling included) and
  each frame, the frame rate a GIF stores.

Data (``dvr info``'s report, a bench's table) goes to stdout whatever the level.  Log lines are written
with :func:`dvr_gl.progress.write`, so that they do not tear a bar that is being drawn.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import time

from dvr_gl import progress

LOGGER = "dvr_gl"
QUIET, NORMAL, VERBOSE = -1, 0, 1


def add_arguments(p: argparse.ArgumentParser):
    """``-q`` and ``-v``, before or after the subcommand (``dvr -q render`` or ``dvr render -q``); their
    defaults are suppressed so that a subcommand's parser does not reset what the main one read."""
    p.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                   help="print nothing but warnings and errors (no progress bars, no 'wrote ...')")
    p.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                   help="also print timings and details (loading, the first frame with compiling, each frame)")


class _Handler(logging.Handler):
    """One line per record on the stderr of the moment (``dvr COMMAND: warning: ...`` for warnings)."""

    def __init__(self, command: str):
        super().__init__()
        self.command = command

    def emit(self, record):
        try:
            text = record.getMessage()
            if record.levelno >= logging.WARNING:
                text = f"dvr {self.command}: {record.levelname.lower()}: {text}"
            progress.write(text)
        except Exception:  # a broken stderr must not end the render
            self.handleError(record)


@contextlib.contextmanager
def feedback(command: str, verbosity: int = NORMAL):
    """Within this block, the ``dvr_gl`` logger writes to stderr at the level ``verbosity`` asks
    (:data:`QUIET`, :data:`NORMAL`, :data:`VERBOSE`), and long tasks draw bars unless quiet."""
    logger = logging.getLogger(LOGGER)
    level = logging.WARNING if verbosity <= QUIET else logging.INFO if verbosity == NORMAL else logging.DEBUG
    saved = logger.level, logger.propagate
    handler = _Handler(command)
    logger.setLevel(level)
    logger.addHandler(handler)
    logger.propagate = False  # one line each, not again through the root logger's handlers
    try:
        with progress.reporting(verbosity > QUIET):
            yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(saved[0])
        logger.propagate = saved[1]


def process_seconds() -> float | None:
    """Seconds since this process started (what the user has waited, interpreter start-up and imports
    included), from ``/proc`` on Linux; None elsewhere."""
    try:
        with open("/proc/self/stat", "rb") as f:
            # field 22, after the command name in parentheses (which may hold spaces)
            start_ticks = int(f.read().rsplit(b")", 1)[1].split()[19])
        with open("/proc/uptime", "rb") as f:
            uptime = float(f.read().split()[0])
        seconds = uptime - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None
    return seconds if 0.0 <= seconds < 86400.0 else None


def started(whole_process: bool) -> float:
    """The ``time.perf_counter()`` value at which the command began: the process's start for a command
    run from the shell (``whole_process``), else now (``main(argv)`` called in a running process)."""
    now = time.perf_counter()
    seconds = process_seconds() if whole_process else None
    return now - seconds if seconds is not None else now
