"""A headless OpenGL context through Mesa's OSMesa (``libOSMesa``), for machines where EGL cannot give one.

OSMesa renders on the CPU (Mesa's llvmpipe, the driver EGL uses on a machine without a GPU), into a buffer
in this process's memory.  :class:`OSMesaContext` is the loader moderngl takes for a context it did not
create (``moderngl.create_context(context=...)``): it makes the context current and hands moderngl the
address of each GL function (``OSMesaGetProcAddress``).  Every image the renderers make goes to their own
framebuffers, so the context's own buffer is one RGBA pixel.
"""

from __future__ import annotations

import ctypes
import functools

OSMESA_PACKAGE = "libosmesa6"
LIBRARIES = ("libOSMesa.so.8", "libOSMesa.so")  # the runtime's name, then the development package's

# OSMesa's attribute names and values (GL/osmesa.h)
_OSMESA_FORMAT, _OSMESA_RGBA = 0x22, 0x1908
_OSMESA_DEPTH_BITS, _OSMESA_STENCIL_BITS, _OSMESA_ACCUM_BITS = 0x30, 0x31, 0x32
_OSMESA_PROFILE, _OSMESA_CORE_PROFILE = 0x33, 0x34
_OSMESA_CONTEXT_MAJOR_VERSION, _OSMESA_CONTEXT_MINOR_VERSION = 0x36, 0x37
_GL_UNSIGNED_BYTE = 0x1401


class OSMesaError(Exception):
    """libOSMesa is missing or refused a context; the message is one line."""


@functools.cache
def library() -> ctypes.CDLL:
    """libOSMesa with the prototypes this module calls (OSMesaError, naming the Debian package, when absent)."""
    for name in LIBRARIES:
        try:
            lib = ctypes.CDLL(name)
            break
        except OSError:
            continue
    else:
        raise OSMesaError(f"{LIBRARIES[0]} could not be loaded; install Mesa's OSMesa "
                          f"(Debian: apt install {OSMESA_PACKAGE})")
    lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
    lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
    lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_int]
    lib.OSMesaMakeCurrent.restype = ctypes.c_ubyte
    lib.OSMesaGetCurrentContext.argtypes = []
    lib.OSMesaGetCurrentContext.restype = ctypes.c_void_p
    lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
    lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
    lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
    lib.OSMesaDestroyContext.restype = None
    return lib


_BUFFERS: dict[int, ctypes.Array] = {}  # each live context's buffer, by handle: __exit__ rebinds another's


class OSMesaContext:
    """An OSMesa context of OpenGL ``major.minor`` core profile, current on this thread once created.

    The methods are those moderngl calls on a context loader: ``load_opengl_function(name)`` (the
    function's address, 0 when absent), ``__enter__`` / ``__exit__`` (make current, then restore what
    was current) and ``release``."""

    def __init__(self, major: int = 3, minor: int = 3):
        self.lib = library()
        attribs = [_OSMESA_FORMAT, _OSMESA_RGBA, _OSMESA_DEPTH_BITS, 24, _OSMESA_STENCIL_BITS, 8,
                   _OSMESA_ACCUM_BITS, 0, _OSMESA_PROFILE, _OSMESA_CORE_PROFILE,
                   _OSMESA_CONTEXT_MAJOR_VERSION, major, _OSMESA_CONTEXT_MINOR_VERSION, minor, 0]
        self.handle = self.lib.OSMesaCreateContextAttribs((ctypes.c_int * len(attribs))(*attribs), None)
        if not self.handle:
            raise OSMesaError(f"OSMesa refused an OpenGL {major}.{minor} core context; update Mesa "
                              f"(Debian: apt install {OSMESA_PACKAGE})")
        _BUFFERS[self.handle] = (ctypes.c_ubyte * 4)()  # one RGBA pixel: nothing is drawn into it
        self._previous = []
        self._bind(self.handle)

    def _bind(self, handle) -> None:
        """Make ``handle`` (a live context's) current with its buffer; None: leave no OSMesa context current."""
        size = 1 if handle else 0
        if not self.lib.OSMesaMakeCurrent(handle, _BUFFERS.get(handle), _GL_UNSIGNED_BYTE, size, size):
            raise OSMesaError("OSMesa could not make its context current")

    def load_opengl_function(self, name: str) -> int:
        return self.lib.OSMesaGetProcAddress(name.encode()) or 0

    def __enter__(self):
        self._previous.append(self.lib.OSMesaGetCurrentContext())
        self._bind(self.handle)
        return self

    def __exit__(self, *args) -> None:
        previous = self._previous.pop() if self._previous else None
        if previous != self.handle:
            self._bind(previous if previous in _BUFFERS else None)

    def release(self) -> None:
        """Destroy the context (once; it is no longer current afterwards)."""
        if self.handle:
            if self.lib.OSMesaGetCurrentContext() == self.handle:
                self._bind(None)
            self.lib.OSMesaDestroyContext(self.handle)
            del _BUFFERS[self.handle]
            self.handle = None
