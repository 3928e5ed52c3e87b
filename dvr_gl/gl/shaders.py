"""GLSL sources: found on disk, composed from snippets, specialized with defines.

Each renderer keeps its GLSL in the ``shaders/`` folder of its own package (a kit shared by several
renderers, in its own: :mod:`dvr_gl.renderers.grid`, :mod:`dvr_gl.renderers.mesh`), and passes that folder
as ``roots``; what every renderer shares is the common library, this package's ``shaders/`` folder
(``common/*.glsl``, ``fullscreen.vert``, ``geometry/``, ``scattering/``).  A name, of a program's source or
of an ``#include "snippet.glsl"``, is looked up in the caller's roots in order and then in the library (each
file included once, as VTK composes its volume shaders from snippets), so a renderer from another package
brings its shaders the same way (docs/plugins.md).  ``#define`` lines for the features a scene
uses are inserted after ``#version``, so one source specializes into many
programs, each compiled once per context and feature set (the cache belongs to the context:
:func:`program_cache`).  Compiler messages
are mapped back to the file and line that caused them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import moderngl

from ..errors import ShaderError

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')


#: The common GLSL library: searched after every caller's own roots.
LIBRARY = Path(__file__).resolve().parent / "shaders"


def shader_root(module_file: str) -> Path:
    """The ``shaders/`` folder beside a module (``shader_root(__file__)``): a renderer's own root."""
    return Path(module_file).resolve().parent / "shaders"


def _find(name: str, roots: tuple) -> Path:
    for root in (*roots, LIBRARY):
        path = Path(root) / name
        if path.is_file():
            return path
    where = ", ".join(str(r) for r in (*roots, LIBRARY))
    raise ShaderError(f"shader file {name} not found in {where}; reinstall dvr-gl")


@dataclass(frozen=True)
class ShaderSource:
    text: str
    origins: tuple[tuple[str, int], ...]  # (file, line) of each line of text

    def where(self, line: int) -> str:
        if 1 <= line <= len(self.origins):
            f, n = self.origins[line - 1]
            return f"{f} line {n}"
        return f"line {line}"


def _expand(name: str, roots: tuple, seen: set, lines: list, origins: list):
    path = _find(name, roots)
    if path in seen:
        return
    seen.add(path)
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        m = _INCLUDE.match(line)
        if m:
            _expand(m.group(1), roots, seen, lines, origins)
        else:
            lines.append(line)
            origins.append((name, number))


def define_lines(defines: dict | None) -> list[str]:
    out = []
    for key, value in sorted((defines or {}).items()):
        if value is False or value is None:
            continue
        out.append(f"#define {key}" if value is True else f"#define {key} {value}")
    return out


def load_shader(name: str, defines: dict | None = None, roots: tuple = ()) -> ShaderSource:
    """The expanded source of ``name`` with ``defines`` after its ``#version`` line.

    ``defines`` maps names to values; ``True`` defines a flag, ``False``/``None`` omits it.
    ``roots``: folders searched, in order, before the common library (:data:`LIBRARY`).
    """
    lines: list[str] = []
    origins: list[tuple[str, int]] = []
    _expand(name, tuple(roots), set(), lines, origins)
    if not lines or not lines[0].lstrip().startswith("#version"):
        raise ShaderError(f"shader {name} must start with a #version line")
    extra = define_lines(defines)
    lines[1:1] = extra
    origins[1:1] = [("(defines)", i + 1) for i in range(len(extra))]
    return ShaderSource("\n".join(lines) + "\n", tuple(origins))


_MESA_LINE = re.compile(r"\b\d+:(\d+)\(\d+\)")       # Mesa: 0:12(5): error: ...
_NVIDIA_LINE = re.compile(r"\b\d+\((\d+)\)\s*:")     # NVIDIA: 0(12) : error C1008: ...


def _first_error(message: str, sources: dict[str, ShaderSource]) -> str:
    stage = None
    for raw in message.splitlines():
        line = raw.strip()
        if line in ("vertex_shader", "fragment_shader", "geometry_shader"):
            stage = line.split("_")[0]
        if "error" in line.lower() and line.lower() != "glsl compiler failed":
            m = _MESA_LINE.search(line) or _NVIDIA_LINE.search(line)
            src = sources.get(stage or "", None)
            where = src.where(int(m.group(1))) if (m and src) else "?"
            text = line[m.end():].lstrip(" :") if m else line
            return f"{where}: {text}"
    return " ".join(message.split())[:300]


_CACHE_KEY = "dvr_gl.programs"


def program_cache(ctx: moderngl.Context) -> dict:
    """The context's own program cache (in ``ctx.extra``, moderngl's slot for its user's objects): it
    lives and dies with the context, so no program can outlive it or be found by another context that
    reuses its address."""
    if ctx.extra is None:
        ctx.extra = {}
    return ctx.extra.setdefault(_CACHE_KEY, {})


def create_program(ctx: moderngl.Context, vertex: str, fragment: str, defines: dict | None = None,
                   geometry: str | None = None, roots: tuple = ()) -> moderngl.Program:
    """Compile (or fetch from the context's cache) the program of these sources and defines, the names
    looked up in ``roots`` and then the common library."""
    cache = program_cache(ctx)
    roots = tuple(Path(r) for r in roots)
    key = (vertex, fragment, geometry, roots, tuple(sorted((defines or {}).items())))
    program = cache.get(key)
    if program is not None:
        return program
    sources = {"vertex": load_shader(vertex, defines, roots), "fragment": load_shader(fragment, defines, roots)}
    if geometry is not None:
        sources["geometry"] = load_shader(geometry, defines, roots)
    try:
        program = ctx.program(vertex_shader=sources["vertex"].text, fragment_shader=sources["fragment"].text,
                              geometry_shader=sources["geometry"].text if geometry else None)
    except moderngl.Error as exc:
        raise ShaderError(f"GLSL compile failed in {_first_error(str(exc), sources)} "
                          f"(renderer {ctx.info['GL_RENDERER']}); the shader sources are "
                          f"in {', '.join(str(r) for r in (*roots, LIBRARY))}") from exc
    cache[key] = program
    return program


def release_programs(ctx: moderngl.Context):
    """Release the cached programs of a context being released."""
    for program in program_cache(ctx).values():
        program.release()
    program_cache(ctx).clear()
