"""The renderers a bench measures, picked by what their plugins declare (never by name), so that a bench
serves a renderer installed from another package the same way.

The two CPU judges (``reference = True``) tell themselves apart by their sampling grid: the
same-discretization reference declares a sample distance (it samples where the GPU renderers sample), the
converged reference does not (it integrates the continuous model to a per-pixel tolerance).  The baseline a
bench sets another renderer beside ("the ray caster at equal error") is the default renderer of grids.
"""

from __future__ import annotations

from ..renderers import registry


def renderers(setting: str | None = None, value=None, kind: str | None = None, gl: bool | None = None,
              fixed_planes: bool | None = None) -> list[str]:
    """The registered renderers, not judges, that declare ``setting`` (with ``value`` among its choices, when
    given), render fields of ``kind`` and draw with GL (``gl``) and sample fixed planes (``fixed_planes``),
    when those are given; in the registry's order."""
    out = []
    for name, p in registry.plugins().items():
        if p.reference or (setting is not None and p.declared(setting) is None):
            continue
        if value is not None and value not in p.choices(setting):
            continue
        if kind is not None and p.data_kinds is not None and kind not in p.data_kinds:
            continue
        if (gl is not None and p.needs_gl != gl) or (fixed_planes is not None and p.fixed_planes != fixed_planes):
            continue
        out.append(name)
    return out


def _judge(samples: bool) -> str:
    found = [n for n, p in registry.plugins().items()
             if p.reference and (p.declared("sample_distance") is not None) == samples]
    if len(found) != 1:
        raise LookupError(f"expected one judge {'with' if samples else 'without'} a sample distance, found {found}")
    return found[0]


def converged() -> str:
    """The converged reference: float64, the continuous model's integral to a per-pixel tolerance."""
    return _judge(False)


def discrete() -> str:
    """The same-discretization reference: float64 at the GPU renderers' samples."""
    return _judge(True)


def baseline(kind: str = "grid") -> str:
    """The renderer another is set beside (at equal error, or as the frame time to beat): the default
    renderer of ``kind``."""
    return registry.default_for(kind)
