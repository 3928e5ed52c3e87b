"""dvr view on a time series and on two fields in a real window under Xvfb, driven by X key events (XTEST
through ctypes, as a person's keys reach GLFW): Right and Left step, Space plays and pauses, N moves the
transfer-function editor to the next field.  The frame log (JSON lines) says what the viewer did; a screenshot's
scene names the step it shows.  Skips, saying why, without Xvfb or libXtst (.ci/run installs both)."""

import ctypes
import json
import os
import subprocess
import sys
import time

import numpy as np

from dvr_gl.scene.resolve import load_scene

TIMEOUT = 60.0
SIZE = 96


class Keys:
    """Key presses over the window's render area (the pointer there gives it the keyboard without a window
    manager)."""

    def __init__(self, display: str):
        self.x11, self.xtst = ctypes.CDLL("libX11.so.6"), ctypes.CDLL("libXtst.so.6")
        p, ul = ctypes.c_void_p, ctypes.c_ulong
        self.x11.XOpenDisplay.restype, self.x11.XOpenDisplay.argtypes = p, [ctypes.c_char_p]
        self.x11.XStringToKeysym.restype, self.x11.XStringToKeysym.argtypes = ul, [ctypes.c_char_p]
        self.x11.XKeysymToKeycode.restype, self.x11.XKeysymToKeycode.argtypes = ctypes.c_ubyte, [p, ul]
        self.x11.XSync.argtypes = [p, ctypes.c_int]
        self.xtst.XTestFakeKeyEvent.argtypes = [p, ctypes.c_uint, ctypes.c_int, ul]
        self.xtst.XTestFakeMotionEvent.argtypes = [p, ctypes.c_int, ctypes.c_int, ctypes.c_int, ul]
        self.display = self.x11.XOpenDisplay(display.encode())
        assert self.display, f"cannot open X display {display}"

    def press(self, name: str):
        self.xtst.XTestFakeMotionEvent(self.display, -1, SIZE // 2, SIZE // 2, 0)
        code = self.x11.XKeysymToKeycode(self.display, self.x11.XStringToKeysym(name.encode()))
        for down in (1, 0):
            self.xtst.XTestFakeKeyEvent(self.display, code, down, 0)
        self.x11.XSync(self.display, 0)


class Viewer:
    def __init__(self, display: str, folder, *args):
        self.log, self.folder = folder / "frames.jsonl", folder
        self.out = open(folder / "viewer.out", "w")
        self.proc = subprocess.Popen([sys.executable, "-m", "dvr_gl.apps.cli", "view", *map(str, args), "--size",
                                      f"{SIZE}x{SIZE}", "--frame-log", str(self.log), "--passes", "1",
                                      "--screenshot-dir", str(folder), "--screenshot-format", "exr"],
                                     env=dict(os.environ, DISPLAY=display), cwd=folder, stdout=self.out,
                                     stderr=subprocess.STDOUT)
        self.keys = Keys(display)

    def records(self) -> list[dict]:
        text = self.log.read_text() if self.log.exists() else ""
        return [json.loads(line) for line in text.splitlines() if line.endswith("}")]

    def wait(self, predicate, what: str):
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            assert self.proc.poll() is None, (self.folder / "viewer.out").read_text()[-2000:]
            found = predicate(self.records())
            if found:
                return found
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {what}; last records: {self.records()[-5:]}")

    def events(self, name: str) -> list[dict]:
        return [r for r in self.records() if r.get("event") == name]

    def close(self):
        if self.proc.poll() is None:
            self.keys.press("q")
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        self.out.close()


def blob(cx: float, n: int = 12) -> np.ndarray:
    z, y, x = np.mgrid[0:n, 0:n, 0:n]
    return np.exp(-((x - cx) ** 2 + (y - n / 2) ** 2 + (z - n / 2) ** 2) / 8.0).astype(np.float32)


def test_time_keys_step_play_and_pause(xvfb, tmp_path):
    for k in range(3):
        np.save(tmp_path / f"step_{k}.npy", blob(3.0 + 3 * k))
    v = Viewer(xvfb, tmp_path, tmp_path / "step_*.npy", "--no-gui")
    try:
        v.wait(lambda rs: any("frame" in r for r in rs), "the first frame")
        v.keys.press("Right")
        v.wait(lambda rs: any(r.get("event") == "time_step" and r["step"] == 1 for r in rs), "step 1")
        v.keys.press("Left")
        v.wait(lambda rs: [r["step"] for r in rs if r.get("event") == "time_step"][-1:] == [0], "step 0")
        v.keys.press("Left")  # wraps to the last step
        v.wait(lambda rs: [r["step"] for r in rs if r.get("event") == "time_step"][-1:] == [2], "step 2")
        v.keys.press("s")
        shot = v.wait(lambda rs: next((r for r in rs if r.get("event") == "screenshot"), None), "a screenshot")
        assert load_scene(shot["scene"]).volume_source.time == 2  # the screenshot's scene names its step
        before = len(v.events("time_step"))
        v.keys.press("space")
        v.wait(lambda rs: len([r for r in rs if r.get("event") == "time_step"]) >= before + 3, "playing")
        v.keys.press("space")
        v.wait(lambda rs: any(r.get("event") == "pause" for r in rs), "the pause")
        paused = len(v.events("time_step"))
        time.sleep(1.0)
        assert len(v.events("time_step")) == paused  # paused: no step moves on
        steps = [r["step"] for r in v.events("time_step")]
        assert all((b - a) % 3 == 1 for a, b in zip(steps[before - 1:], steps[before:]))  # one step at a time
    finally:
        v.close()
    assert v.proc.returncode == 0, (tmp_path / "viewer.out").read_text()[-2000:]


def test_n_edits_the_next_fields_transfer_function(xvfb, tmp_path):
    np.save(tmp_path / "a.npy", blob(4.0))
    np.save(tmp_path / "b.npy", blob(8.0))
    v = Viewer(xvfb, tmp_path, tmp_path / "a.npy", tmp_path / "b.npy", "--no-gui")
    try:
        v.wait(lambda rs: any("frame" in r for r in rs), "the first frame")
        v.keys.press("n")
        message = v.wait(lambda rs: next((r for r in rs if r.get("event") == "message"), None), "the message")
        assert "editing field 2 of 2" in message["text"] and not message["error"]
    finally:
        v.close()
    assert v.proc.returncode == 0, (tmp_path / "viewer.out").read_text()[-2000:]


def test_the_panel_on_a_series_and_on_a_label_map_alone(xvfb, tmp_path):
    """With the side panel: a series (its play and step buttons) and a label map alone (no curve to edit: the
    panel says so) open, refine and close (--benchmark)."""
    from dvr_gl.renderers import registry

    labels = next(n for n, p in registry.plugins().items() if "label" in p.field_roles
                  and (p.data_kinds is None or "fields" in p.data_kinds))
    for k in range(2):
        np.save(tmp_path / f"step_{k}.npy", blob(4.0 + 3 * k))
    np.save(tmp_path / "seg.npy", (blob(6.0) > 0.5).astype(np.uint8))
    for argv in ([tmp_path / "step_*.npy"], ["--labels", tmp_path / "seg.npy", "--renderer", labels]):
        out = subprocess.run([sys.executable, "-m", "dvr_gl.apps.cli", "view", *map(str, argv), "--size", "64x64",
                              "--benchmark", "0.3"], env=dict(os.environ, DISPLAY=xvfb), capture_output=True,
                             text=True, cwd=tmp_path, timeout=120)
        assert out.returncode == 0, out.stderr
        assert "dvr view benchmark: " in out.stdout and "interactive: " in out.stdout
