"""Bounds on what rendering may touch: which files, how much memory, how much time.

Every file dvr-gl opens for reading (scene files, volume headers, the data files a
header names) goes through :func:`check_input_path`: it must be a regular file
(never a FIFO, a device or a socket, which could block or never end) and, inside a
:class:`Sandbox` with roots, it must resolve (symlinks followed) to a path under
one of them.  Readers and renderers ask :func:`memory_budget` before they
allocate what a header or a setting promises.

Outside a sandbox (the default) any regular file may be read and the memory budget
is half the machine's physical memory.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from .errors import DvrError


class SandboxError(DvrError):
    """A path, size or duration the active sandbox (or the machine) does not allow."""


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
    """Run the body under ``sandbox``."""
    token = _CURRENT.set(sandbox)
    try:
        yield sandbox
    finally:
        _CURRENT.reset(token)


def check_input_path(path, what: str = "file") -> Path:
    """``path`` if it may be read: a regular file (FIFOs, devices and sockets refused) inside the
    sandbox's roots.  ``what`` names it in the message ("volume file", "NRRD data file", ...)."""
    path = Path(path)
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
