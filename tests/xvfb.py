"""A running Xvfb for the tests that open windows (the viewer, the renderers' viewer checks)."""

import contextlib
import ctypes
import os
import shutil
import subprocess

import pytest


@contextlib.contextmanager
def xvfb_display():
    """A running Xvfb's display name (skips the test, saying why, without Xvfb or libXtst)."""
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.skip("Xvfb not installed (Debian: apt install xvfb; .ci/run installs it)")
    try:
        ctypes.CDLL("libXtst.so.6")
        ctypes.CDLL("libX11.so.6")
    except OSError as exc:
        pytest.skip(f"libX11/libXtst not found ({exc}; Debian: apt install libxtst6)")
    read, write = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(write), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                            pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as fh:
        number = fh.readline().strip()
    if not number:
        proc.kill()
        pytest.skip("Xvfb did not start")
    try:
        yield f":{number}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)
