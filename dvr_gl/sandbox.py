"""Bounds on what rendering may touch: which files, how much memory, how much time.

Every file dvr-gl opens for reading (scene files, volume headers, the data files a
header names) goes through :func:`check_input_path`: it must be a regular file
(never a FIFO, a device or a socket, which could block or never end) and, inside a
:class:`Sandbox` with roots, it must resolve (symlinks followed) to a path under
one of them.  Readers and renderers ask :func:`memory_budget` before they
allocate what a header or a setting promises.

Outside a sandbox (the default) any regular file may be read and the memory budget
is half the machine's physical memory.

Time (``max_seconds``) is bounded twice, since no Python code runs while a single GL call
(llvmpipe drawing a frame) or numpy call is under way:

* a wall-clock timer (``signal.setitimer``, main thread only) raises :class:`SandboxError` at
  the deadline, between Python operations: the usual way a render stops, with one line;
* a hard backstop, the process's CPU-time limit (``RLIMIT_CPU``, soft limit only, restored
  after): a render stuck in one call is killed by the kernel (``SIGXCPU``) once it has used
  ``max_seconds`` per core plus :data:`CPU_GRACE_SECONDS` of CPU time.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import re
import signal
import stat
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from .errors import DvrError


class SandboxError(DvrError):
    """A path, size or duration the active sandbox (or the machine) does not allow."""


#: The longest time limit (seconds, a year): the timer takes no more.
MAX_SECONDS = 3.2e7


@dataclass(frozen=True)
class Sandbox:
    """Limits for rendering scenes one did not write.

    Attributes:
        roots: folders every file read must lie in (resolved, symlinks followed); empty: anywhere.
        max_bytes: memory budget in bytes for volumes, tables and images; None: the default.
        max_seconds: wall-clock budget in seconds for one render; None: unbounded.
    """

    roots: tuple[Path, ...] = ()
    max_bytes: int | None = None
    max_seconds: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "roots", tuple(Path(r) for r in self.roots))
        for root in self.roots:
            if not root.is_dir():
                raise SandboxError(f"{root}: a sandbox root (--sandbox) must be an existing folder")
        if self.max_bytes is not None and not 1 <= self.max_bytes < 2**63:
            raise SandboxError(f"the memory budget (--max-memory) must be at least 1 byte, got {self.max_bytes}")
        if self.max_seconds is not None and not 0 < self.max_seconds <= MAX_SECONDS:
            raise SandboxError(f"the time limit (--max-seconds) must be in (0, {MAX_SECONDS:g}] seconds, "
                               f"got {self.max_seconds}")

    def allows(self, path: Path) -> bool:
        if not self.roots:
            return True
        resolved = Path(os.path.realpath(path))
        return any(resolved == root or root in resolved.parents for root in self._resolved_roots())

    def _resolved_roots(self):
        return [Path(os.path.realpath(r)) for r in self.roots]


_CURRENT: contextvars.ContextVar[Sandbox] = contextvars.ContextVar("dvr_gl_sandbox", default=Sandbox())


def current() -> Sandbox:
    """The sandbox in force (the unbounded default outside :func:`active`)."""
    return _CURRENT.get()


@contextlib.contextmanager
def active(sandbox: Sandbox):
    """Run the body under ``sandbox``: its roots and memory budget, and its time limit (see the module
    doc; ``max_seconds`` needs the main thread)."""
    token = _CURRENT.set(sandbox)
    try:
        with _time_limit(sandbox.max_seconds):
            yield sandbox
    finally:
        _CURRENT.reset(token)


#: CPU seconds beyond ``max_seconds`` per core before the kernel stops a render stuck in one call.
CPU_GRACE_SECONDS = 5


class _Expired(BaseException):
    """The timer's interruption: a BaseException, as KeyboardInterrupt, so that no ``except Exception``
    on the way (a reader's, the GL context's) turns it into another message; :func:`active` turns it
    into a :class:`SandboxError`."""


def time_limit_error(seconds: float, done: str = "") -> SandboxError:
    """The one message for a render stopped at the time limit, by the timer or by a renderer's own
    check between steps (``done``: how far it got)."""
    return SandboxError(f"the render ran past the time limit of {seconds:g} s (--max-seconds){done}; stopped. "
                        f"Render less (a smaller image, a longer sample distance) or allow more time")


@contextlib.contextmanager
def _time_limit(seconds: float | None):
    if seconds is None:
        yield
        return
    if threading.current_thread() is not threading.main_thread():
        raise SandboxError("a time limit (max_seconds) needs the main thread (a timer signal); render there, "
                           "or in a subprocess")

    def expired(signum, frame):
        raise _Expired()

    # The timer may fire anywhere from setting it to clearing it, even before the body is entered (a
    # deadline of 1e-9 s passes inside setitimer): the outer try catches it there too.
    previous = signal.signal(signal.SIGALRM, expired)
    outer = signal.getitimer(signal.ITIMER_REAL)[0]  # an enclosing limit's time left
    start = time.monotonic()
    try:
        try:
            signal.setitimer(signal.ITIMER_REAL, seconds)
            with _cpu_backstop(seconds):
                yield
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
    except _Expired:
        raise time_limit_error(seconds) from None
    finally:
        signal.signal(signal.SIGALRM, previous)
        if outer:  # an enclosing limit (a nested sandbox): its timer goes on with what is left of it
            signal.setitimer(signal.ITIMER_REAL, max(outer - (time.monotonic() - start), 1e-3))


@contextlib.contextmanager
def _cpu_backstop(seconds: float):
    """Lower the soft CPU-time limit to what ``seconds`` of wall time on every core could use, plus the
    grace; the soft limit only, so that it can be restored after (a process may raise it again)."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_CPU)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    limit = int(usage.ru_utime + usage.ru_stime + seconds * (os.cpu_count() or 1) + CPU_GRACE_SECONDS) + 1
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    if soft != resource.RLIM_INFINITY and soft <= limit:  # already tighter
        yield
        return
    resource.setrlimit(resource.RLIMIT_CPU, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_CPU, (soft, hard))


#: The longest name (one part of a path) and path, in bytes, that Linux allows (a name: macOS and Windows too).
NAME_MAX, PATH_MAX = 255, 4095


def check_path_name(path, what: str = "file") -> Path:
    """``path`` if the system could name it: no NUL byte and no name over :data:`NAME_MAX` bytes.  Either
    makes every look-up fail (``ValueError``, ``OSError`` ENAMETOOLONG) wherever it first comes, even in
    ``Path.is_dir``: refused here, in one line, where a user's path enters."""
    text = os.fsdecode(os.fspath(path))
    if "\x00" in text:
        raise SandboxError(f"{text!r}: the {what}'s path holds a NUL byte, which no file name can; check the path")
    longest = max([len(os.fsencode(part)) for part in Path(text).parts] or [0])
    if longest > NAME_MAX:
        raise SandboxError(f"{text[:40]}...: a name in the {what}'s path is too long ({longest} bytes, over the "
                           f"{NAME_MAX} a file system allows); check the path")
    if len(os.fsencode(text)) > PATH_MAX:
        raise SandboxError(f"{text[:40]}...: the {what}'s path is too long ({len(os.fsencode(text))} bytes, over "
                           f"{PATH_MAX}); check the path")
    return Path(text)


def check_input_path(path, what: str = "file") -> Path:
    """``path`` if it may be read: a regular file (FIFOs, devices and sockets refused) inside the
    sandbox's roots.  ``what`` names it in the message ("volume file", "NRRD data file", ...)."""
    path = check_path_name(path, what)
    box = current()
    if not box.allows(path):
        roots = ", ".join(str(r) for r in box.roots)
        raise SandboxError(f"{path}: the {what} lies outside the allowed folders ({roots}); "
                           f"move it into one of them")
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise SandboxError(f"{path}: {what} not found") from None
    except OSError as exc:
        raise SandboxError(f"{path}: cannot read the {what} ({exc.strerror})") from None
    if stat.S_ISDIR(mode):
        raise SandboxError(f"{path}: the {what} is a folder; give a file")
    if not stat.S_ISREG(mode):
        raise SandboxError(f"{path}: the {what} is not a regular file (a FIFO, device or socket "
                           f"could block); give a regular file")
    return path


def check_output_path(path, what: str = "output file") -> Path:
    """``path`` if it may be written: inside the sandbox's roots, judged by where it will be created
    (its folder, symlinks followed), and by the target of a link already at that name (stricter than
    needed: the rename that writes it would replace the link, not follow it)."""
    path = check_path_name(path, what)
    box = current()
    folder = os.path.realpath(path.parent if str(path.parent) else ".")
    if not box.allows(Path(folder) / path.name):
        roots = ", ".join(str(r) for r in box.roots)
        raise SandboxError(f"{path}: the {what} lies outside the allowed folders ({roots}); write it into "
                           f"one of them")
    return path


_UNITS = {"": 1, "b": 1, "kb": 10**3, "mb": 10**6, "gb": 10**9, "tb": 10**12,
          "kib": 2**10, "mib": 2**20, "gib": 2**30, "tib": 2**40}


def parse_bytes(text: str, what: str = "--max-memory") -> int:
    """Bytes from ``"2GiB"``, ``"512MB"``, ``"1e9"`` (decimal kB, MB, GB, TB; binary KiB, MiB, GiB, TiB)."""
    match = re.fullmatch(r"\s*([0-9.]+(?:e[+-]?[0-9]+)?)\s*([a-z]*)\s*", str(text), re.IGNORECASE)
    unit = match and match.group(2).lower()
    try:
        value = float(match.group(1)) * _UNITS[unit] if match else None
    except (KeyError, ValueError):
        value = None
    if value is None or not 1 <= value < 2**63:
        raise SandboxError(f"{what} {text!r}: give a size from 1 byte to 8 EiB, e.g. 2GiB, 512MB or 1e9 (units: B, kB, "
                           f"MB, GB, TB, KiB, MiB, GiB, TiB)")
    return int(value)


def physical_memory() -> int:
    """Bytes of physical memory (a conservative 4 GiB where the system does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 4 << 30


def memory_budget() -> int:
    """Bytes that one render may allocate for volumes, tables and images."""
    box = current()
    return box.max_bytes if box.max_bytes is not None else physical_memory() // 2


def check_bytes(nbytes: float, what: str, fix: str) -> None:
    """Refuse an allocation of ``nbytes`` over the memory budget, naming ``what`` and the ``fix``."""
    budget = memory_budget()
    if nbytes > budget:
        raise SandboxError(f"{what} would take {_gib(nbytes)}, over the memory budget of {_gib(budget)}; {fix}")


def _gib(nbytes: float) -> str:
    return f"{nbytes / (1 << 30):.3g} GiB" if nbytes >= 1 << 30 else f"{nbytes / (1 << 20):.3g} MiB"
