"""A one-line progress bar on stderr (redrawn in place on a terminal).

Drawn only once ``delay`` seconds have passed, so short work prints nothing; a renderer's
:attr:`~dvr_gl.renderers.base.Renderer.progress` may be one (it is called with ``(done, total)``).
"""

from __future__ import annotations

import sys
import time

DELAY = 1.0  # seconds before the bar appears


class Progress:
    def __init__(self, total: int, label: str, stream=None, width: int = 30, delay: float = 0.0):
        self.total, self.label, self.width, self.delay = total, label, width, delay
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self.drawn = False

    def __call__(self, done: int, total: int):
        self.total = total
        self.update(done)

    def update(self, done: int):
        elapsed = time.perf_counter() - self.start
        if elapsed < self.delay:
            return
        filled = int(self.width * done / max(self.total, 1))
        eta = elapsed / done * (self.total - done) if done else 0.0
        line = (f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {done}/{self.total} "
                f"{elapsed:.1f}s elapsed, {eta:.1f}s left")
        self.stream.write(("\r" + line) if self.tty else (line + "\n"))
        self.stream.flush()
        self.drawn = True

    def close(self):
        if self.tty and self.drawn:
            self.stream.write("\n")
            self.stream.flush()
