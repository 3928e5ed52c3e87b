"""The renderers a test outside a renderer's folder picks, by what they declare, never by name.

No file outside ``dvr_gl/renderers/NAME/`` names a renderer (``tests/project/test_layout.py``), so a
generic test asks the registry.  The two CPU judges (``reference = True``) tell themselves apart by
their sampling grid: the same-discretization reference declares a sample distance (it samples where
the GPU renderers sample: the judge of "is the GPU code right?"); the converged reference declares
none (it integrates the continuous model to a per-pixel tolerance: the judge of "how accurate?").
"""

from __future__ import annotations

from dvr_gl.renderers import registry


def judges() -> list[str]:
    """The CPU float64 references, in the registry's order."""
    return [n for n, p in registry.plugins().items() if p.reference]


def _judge(samples: bool) -> str:
    found = [n for n in judges() if (registry.plugin(n).declared("sample_distance") is not None) == samples]
    if len(found) != 1:
        raise LookupError(f"expected one judge {'with' if samples else 'without'} a sample distance, found {found}")
    return found[0]


#: the same-discretization reference (float64, the GPU renderers' samples)
DISCRETE = _judge(True)
#: the converged reference (float64, the continuous model's integral to a tolerance)
CONVERGED = _judge(False)


def renderers(setting: str | None = None, value=None, kind: str | None = None, gl: bool | None = None,
              reference: bool | None = None) -> list[str]:
    """The registered renderers that declare ``setting`` (with ``value`` among its choices, when given),
    render fields of ``kind`` (None: any), draw with GL (``gl``) and are judges (``reference``), when
    those are given; in the registry's order."""
    out = []
    for name, p in registry.plugins().items():
        if setting is not None and p.declared(setting) is None:
            continue
        if value is not None and value not in p.choices(setting):
            continue
        if kind is not None and p.data_kinds is not None and kind not in p.data_kinds:
            continue
        if gl is not None and p.needs_gl != gl:
            continue
        if reference is not None and p.reference != reference:
            continue
        out.append(name)
    return out
