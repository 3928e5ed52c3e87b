"""Progress of long work (loading, the tolerance search, the CPU references, benches), told to whoever asked.

Library code wraps a long piece of work in :func:`task`, which yields ``step(done, total)``; a
step costs nothing when nobody listens.  Who listens is chosen with :func:`reporting`:

* ``None`` or ``False``: nobody (the default);
* ``True``: a `tqdm <https://tqdm.github.io>`_ bar per task on stderr (``tqdm.auto``: a widget in
  Jupyter), shown only once the task has run :data:`DELAY` seconds, so short work prints nothing;
* a callable ``callback(done, total)``: called after each step of each task; ``done`` starts again
  from 0 when the next task (loading, then the search, then the frame) begins, ``total`` may be
  ``None`` where the amount of work is not known in advance.

``dvr`` listens with bars unless ``-q``; ``dvr_gl.render(..., progress=...)`` takes the same values.
The choice is held in a context variable, so threads and notebooks' tasks do not see each other's.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
import time
import weakref
from collections.abc import Callable, Iterator

DELAY = 1.0  # seconds a task runs before its bar appears

Step = Callable[[int, "int | None"], None]

# a factory: (label, total, unit) -> (step, close), or None: nobody listens
_listener: contextvars.ContextVar = contextvars.ContextVar("dvr_gl_progress", default=None)


_live: weakref.WeakSet = weakref.WeakSet()  # the Bars not yet closed


def write(line: str):
    """Print ``line`` on stderr without tearing a bar: through ``tqdm.write`` while a bar is shown (it
    clears and redraws them; it would also draw bars still within their delay, so not otherwise)."""
    if any(bar.shown() for bar in list(_live)):
        from tqdm import tqdm

        tqdm.write(line, file=sys.stderr)
    else:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()


def _ignore(done: int, total: int | None = None):
    pass


def _tqdm():
    """tqdm's bar class: its notebook widget in a Jupyter kernel with ipywidgets, its text bar elsewhere.
    Without (a usable) ipywidgets, tqdm.auto falls back to the text bar but warns "IProgress not found":
    the text bar is a fine bar, so the fallback is silent."""
    import warnings

    from tqdm import TqdmWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TqdmWarning)
        from tqdm.auto import tqdm
    return tqdm


class Bar:
    """A tqdm bar on stderr, drawn after ``delay`` seconds; ``bar(done, total)`` moves it."""

    def __init__(self, label: str, total: int | None = None, unit: str = "step", delay: float | None = None,
                 leave: bool = False):
        delay = DELAY if delay is None else delay
        tqdm = _tqdm()
        stream = sys.stderr
        tty = getattr(stream, "isatty", lambda: False)()
        # Not a terminal (a log, a pipe): redraws become lines, so fewer of them.
        self.bar = tqdm(total=total, desc=label, unit=unit, delay=delay, file=stream, leave=leave,
                        dynamic_ncols=True, mininterval=0.1 if tty else 5.0,
                        unit_scale=unit == "B", unit_divisor=1024 if unit == "B" else 1000)
        self.start, self.delay = time.monotonic(), delay
        _live.add(self)

    def shown(self) -> bool:
        return time.monotonic() - self.start >= self.delay

    def __call__(self, done: int, total: int | None = None):
        if total is not None and total != self.bar.total:
            self.bar.total = total
        self.bar.update(done - self.bar.n)

    def close(self):
        _live.discard(self)
        self.bar.close()


def _bars(label: str, total: int | None, unit: str, delay: float, leave: bool):
    bar = Bar(label, total, unit, delay, leave)
    return bar, bar.close


def _callback(callback: Callable) -> Callable:
    def factory(label: str, total: int | None, unit: str, delay: float, leave: bool):
        return callback, None
    return factory


@contextlib.contextmanager
def reporting(progress=True) -> Iterator[None]:
    """Within this block, tasks report to ``progress`` (``None``/``False``, ``True`` or a callable
    ``callback(done, total)``; see the module doc)."""
    if progress is None or progress is False:
        factory = None
    elif progress is True:
        factory = _bars
    elif callable(progress):
        factory = _callback(progress)
    else:
        raise TypeError(f"progress: give True, False, None or a callable(done, total), "
                        f"got {type(progress).__name__}")
    token = _listener.set(factory)
    try:
        yield
    finally:
        _listener.reset(token)


def listening() -> bool:
    """Whether anybody listens (so that work done only to report can be skipped)."""
    return _listener.get() is not None


@contextlib.contextmanager
def task(label: str, total: int | None = None, unit: str = "step", delay: float | None = None,
         leave: bool = False) -> Iterator[Step]:
    """A long piece of work: yields ``step(done, total=None)`` to call after each step (``done``
    counts from the task's start, in ``unit``s: ``"B"`` shows bytes with binary prefixes).  A bar
    appears after ``delay`` seconds (default :data:`DELAY`) and stays when the task ends only if ``leave``."""
    factory = _listener.get()
    if factory is None:
        yield _ignore
        return
    report, close = factory(label, total, unit, delay, leave)

    def step(done: int, new_total: int | None = None):
        nonlocal total
        total = new_total if new_total is not None else total
        report(done, total)

    try:
        yield step
    finally:
        if close is not None:
            close()
