"""The renderer registry: every renderer is a plugin, found through Python entry points.

A renderer declares everything about itself in one :class:`RendererPlugin`, in its own
package, and registers it in the entry-point group ``dvr_gl.renderers``, the same way
for the built-in renderers (``pyproject.toml``) and for a renderer in another package::

    [project.entry-points."dvr_gl.renderers"]
    myrenderer = "my_package:PLUGIN"

Everything else reads the registry: the scene file's ``[renderer]`` keys (the union of
the declared settings), the CLI's ``--renderer`` choices and setting flags, ``dvr info``,
the viewer's renderer list and greyed-out options, ``dvr bench tradeoff``'s sweeps, and
the conformance and extremes tests.  :func:`refusal` tells, before rendering, why a
renderer cannot render a scene.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from importlib import metadata
from typing import Callable, Optional

from ..errors import DvrError, SceneError
from ..scene.model import DEPTH_MODES
from ..scene.plugin import RendererPlugin
from ..scene.plugin import load as _load
from ..scene.settings import MODEL_SETTINGS, Setting
from ..transfer_function_2d import check_scene as check_transfer_function_2d
from ..transfer_function_2d import is_2d

ENTRY_POINT_GROUP = "dvr_gl.renderers"


# --- loading -----------------------------------------------------------------------------------

@dataclass
class _Registry:
    plugins: dict
    broken: dict       # name -> one-line reason it could not be loaded
    settings: tuple    # the union, in declaration order


def _entry_points():
    seen = {}
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        # the same distribution may be visible twice (an editable install and a target directory)
        if ep.name in seen and seen[ep.name].value != ep.value:
            raise DvrError(f"two packages register a renderer named {ep.name!r} ({seen[ep.name].value} and "
                           f"{ep.value}); uninstall one of them")
        seen.setdefault(ep.name, ep)
    return list(seen.values())


@functools.lru_cache(maxsize=1)
def _registry() -> _Registry:
    plugins, broken = {}, {}
    for ep in _entry_points():
        try:
            plugin = ep.load()
        except Exception as exc:  # a broken third-party plugin must not take the others down
            broken[ep.name] = f"{ep.value} failed to import ({type(exc).__name__}: {exc})"
            continue
        if not isinstance(plugin, RendererPlugin) or plugin.name != ep.name:
            broken[ep.name] = (f"{ep.value} is not a RendererPlugin named {ep.name!r} "
                               f"(see dvr_gl.renderers.registry)")
            continue
        plugins[ep.name] = plugin
    if not plugins and not broken:
        raise DvrError("no renderers are registered: dvr-gl's entry points are missing; install it "
                       "(pip install -e . in the repository) rather than running it from the source tree")
    return _Registry(_in_order(plugins), broken, _union(plugins))


def _in_order(plugins: dict) -> dict:
    """The renderers in their declared order (``RendererPlugin.order``: the viewer's number keys), equal
    ones by name."""
    return {n: plugins[n] for n in sorted(plugins, key=lambda n: (plugins[n].order, n))}


def _union(plugins: dict) -> tuple:
    """Every declared setting once, in declaration order (the renderers in their order), then the model
    settings no renderer declares; a name declared differently by two plugins (or differently from
    the model's) is an error: rename one."""
    model = {s.name: s for s in MODEL_SETTINGS}
    out: dict[str, Setting] = {}
    owner: dict[str, str] = {}
    for plugin in _in_order(plugins).values():
        for s in plugin.settings:
            known = out.get(s.name) or model.get(s.name)
            if known is not None and known.base != s.base:
                raise DvrError(f"renderer {plugin.name!r} declares setting {s.name!r}, which "
                               f"{owner.get(s.name, 'dvr_gl.scene.settings')} declares differently; "
                               f"give it another name")
            if s.name not in out:
                out[s.name], owner[s.name] = s.base, plugin.name
    for s in MODEL_SETTINGS:
        out.setdefault(s.name, s)
    return tuple(out.values())


# --- queries -----------------------------------------------------------------------------------

def plugins() -> dict[str, RendererPlugin]:
    """The registered renderers by name, in their declared order."""
    return dict(_registry().plugins)


def names() -> list[str]:
    return list(_registry().plugins)


def broken() -> dict[str, str]:
    """Registered renderers that failed to load, with the reason."""
    return dict(_registry().broken)


def plugin(name: str) -> RendererPlugin:
    reg = _registry()
    if name in reg.plugins:
        return reg.plugins[name]
    if name in reg.broken:
        raise SceneError(f"renderer {name!r} cannot be used: {reg.broken[name]}")
    raise SceneError(f"unknown renderer {name!r}; available: {', '.join(reg.plugins)}")


def all_settings() -> tuple[Setting, ...]:
    """The union of the declared settings (the ``[renderer]`` table's keys besides ``name``)."""
    return _registry().settings


def setting(name: str) -> Setting:
    return next(s for s in all_settings() if s.name == name)


@functools.lru_cache(maxsize=1)
def renderer_spec_class():
    """The ``[renderer]`` table as a dataclass: ``name`` and every registered setting."""
    fields = [("name", Optional[str], dataclasses.field(default=None, metadata={
        "doc": f"the renderer (default: the first that renders the data: `{default_for('grid')}` for grids, "
               f"`{default_for('mesh')}` for meshes)"}))]
    for s in all_settings():
        default = (dataclasses.field(default_factory=s.default_factory, metadata=_meta(s)) if s.default_factory
                   else dataclasses.field(default=s.default, metadata=_meta(s)))
        fields.append((s.name, s.type, default))
    cls = dataclasses.make_dataclass("RendererSpec", fields)
    cls.__module__ = __name__
    cls.__doc__ = "The renderer and its settings: the union of what the registered renderers declare."
    cls.__reduce__ = _reduce_renderer_spec  # made at run time: pickle cannot find it by name (Dask ships scenes)
    return cls


def _reduce_renderer_spec(spec):
    """Pickle a RendererSpec as its fields, rebuilt by :func:`renderer_spec_of` from the registered settings."""
    return renderer_spec_of, ({f.name: getattr(spec, f.name) for f in dataclasses.fields(spec)},)


def renderer_spec_of(values: dict):
    """A RendererSpec with ``values`` (an unpickled one)."""
    return renderer_spec_class()(**values)


def _meta(s: Setting) -> dict:
    meta = {"choices": s.choices, "doc": s.doc} if s.choices else {"doc": s.doc}
    if s.aliases:
        meta["aliases"] = s.aliases
    if s.excludes:  # read by dvr_gl.scene.model.exclusive_keys, as the other tables' exclusions
        meta["excludes"] = s.excludes
    if s.owner:  # a renderer's own key, also written [renderer.OWNER] (dvr_gl.scene.schema.owned_keys)
        meta["owner"] = s.owner
    return meta


def default_for(kind: str) -> str:
    """The renderer a scene of data ``kind`` gets when it names none: the first registered one made for
    that kind (not one that renders any field, such as the slow CPU references), else the first that
    renders it."""
    made = renderers_with(lambda q: q.data_kinds is not None and kind in q.data_kinds)
    anyone = renderers_with(lambda q: q.data_kinds is None)
    if not made and not anyone:
        raise SceneError(f"no renderer renders {kind} data")
    return (made or anyone)[0]


def renderers_with(predicate: Callable[[RendererPlugin], bool]) -> list[str]:
    return [n for n, p in plugins().items() if predicate(p)]


# --- refusals ----------------------------------------------------------------------------------

def refusal(scene, name: str | None = None) -> str | None:
    """Why renderer ``name`` (default: the scene's) cannot render ``scene``, in one line; None if it can."""
    try:
        check(scene, name)
    except SceneError as exc:
        return str(exc)
    return None


def depth_refusal(scene, name: str | None = None) -> str | None:
    """Why renderer ``name`` (default: the scene's) cannot draw a depth image of ``scene`` beside its colour
    (``RendererPlugin.depth_output``; the compositing mode must have a depth), in one line; None if it can
    (the renderer may still refuse a combination of its own when it draws)."""
    p = plugin(name or scene.renderer.name)
    if not p.depth_output:
        others = renderers_with(lambda q: q.depth_output and refusal(scene, q.name) is None)
        return (f"{p.name} draws no depth image" + (f"; render with {_either(others)}" if others else "")
                + ", or ask for no depth")
    mode = scene.renderer.compositing
    if mode not in DEPTH_MODES:
        return (f"renderer.compositing = {mode!r} has no depth (a mean along the whole ray has no place); depth "
                f"is defined for {_either(DEPTH_MODES)}")
    return None


def _kinds_text(kinds) -> str:
    """Data kinds in words: ``grid data or several fields``."""
    words = [f"{k} data" for k in kinds if k != "fields"] + (["several fields"] if "fields" in kinds else [])
    return " or ".join(words)


def check(scene, name: str | None = None):
    """Raise SceneError with the reason renderer ``name`` (default: the scene's) cannot render
    ``scene``: a data kind it does not render, a setting it does not support, or its own check."""
    p = plugin(name or scene.renderer.name)
    kind = getattr(scene.field, "kind", "?")
    if p.data_kinds is not None and kind not in p.data_kinds:
        others = renderers_with(lambda q: q.data_kinds is None or kind in q.data_kinds)
        raise SceneError(f"{p.name} renders {_kinds_text(p.data_kinds)}, not {_kinds_text((kind,))}"
                         + (f"; use {_either(others)}" if others else ""))
    roles = {m.role for m in getattr(scene.field, "members", ())}
    if roles - set(p.field_roles):
        role = sorted(roles - set(p.field_roles))[0]
        others = renderers_with(lambda q: (q.data_kinds is None or kind in q.data_kinds) and role in q.field_roles)
        raise SceneError(f"{p.name} does not classify {role} fields" + (f"; use {_either(others)}" if others else ""))
    if any(is_2d(tf) for tf in scene.transfer_functions or (scene.transfer_function,)):
        if kind not in p.transfer_function_2d:
            others = renderers_with(lambda q: kind in q.transfer_function_2d)
            raise SceneError(f"{p.name} classifies {kind} data by value alone, not with a 2D transfer function "
                             f"(value and gradient magnitude)" + (f"; use {_either(others)}" if others else ""))
        check_transfer_function_2d(scene)
    if getattr(scene.field, "out_of_core", False) and not p.out_of_core:
        others = renderers_with(lambda q: q.out_of_core)
        budget = getattr(scene.renderer, "memory_budget_mb", None)
        over = budget is not None and scene.field.nbytes > budget * 2 ** 20
        raise SceneError(f"{p.name} needs the voxels in memory, and {scene.field.name} "
                         f"({scene.field.nbytes / 2 ** 20:.0f} MB) is read out of core"
                         + (f" (over renderer.memory_budget_mb = {budget:g})" if over
                            else " (volume.out_of_core = true)")
                         + (f"; use {_either(others)}" if others else "")
                         + ", or set volume.out_of_core = false to load it whole")
    projection = scene.camera.projection
    if projection not in p.projections:
        raise SceneError(f"{p.name} renders {_either(p.projections)} views, not {projection}: set "
                         f"camera.projection = {p.projections[0]}")
    spec = scene.renderer
    # alternatives: renderers of this data that support every model setting the scene uses
    renders = lambda q: (q.data_kinds is None or kind in q.data_kinds) and not _unsupported(q, spec)  # noqa: E731
    problem = _unsupported(p, spec)
    if problem is not None:
        s, value, own = problem
        others = renderers_with(renders)
        if own is None:
            raise SceneError(f"{p.name} does not support {_describe(s, value)}; turn it off"
                             + (f" or use {_either(others)}" if others else ""))
        raise SceneError(f"{p.name} does not support renderer.{s.name} = {value!r} (it takes "
                         f"{_either(own.choices)})" + (f"; use {_either(others)}" if others else ""))
    _check_scattering(p, spec, renders)
    if p.check is not None:
        _load(p.check)(scene)


def _check_scattering(p: RendererPlugin, spec, renders):
    """Scattering's transmittance found in a way ``p`` implements (``RendererPlugin.scattering_methods``)."""
    sc = getattr(spec, "scattering", None)
    if sc is None or not sc.enabled or sc.method in p.scattering_methods or p.declared("scattering") is None:
        return
    others = renderers_with(lambda q: renders(q) and q.declared("scattering") is not None
                            and sc.method in q.scattering_methods)
    raise SceneError(f"{p.name} finds scattering's transmittance by {_either(p.scattering_methods)}, not by "
                     f"renderer.scattering.method = {sc.method!r}: set method = "
                     f"{_either(repr(m) for m in p.scattering_methods)}"
                     + (f", or use {_either(others)}" if others else ""))


def _unsupported(p: RendererPlugin, spec):
    """The first model setting the scene uses that renderer ``p`` does not support: ``(setting, value,
    p's declaration or None)``; None if it supports them all."""
    for s in all_settings():
        if not s.must_support or not s.matters(spec):
            continue
        value = getattr(spec, s.name)
        own = p.declared(s.name)
        if (own is None and s.used(value)) or (own is not None and own.choices and value not in own.choices):
            return s, value, own
    return None


def _describe(s: Setting, value) -> str:
    """The setting in use, as a refusal names it: a switch or a table by name, a value with it."""
    if isinstance(value, bool) or s.in_use is not None:
        return f"renderer.{s.name}"
    return f"renderer.{s.name} = {value!r}"


def _either(items) -> str:
    items = [str(i) for i in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " or " + items[-1]
