"""What a renderer declares about itself: :class:`RendererPlugin`, the type every renderer's package
exports as ``PLUGIN`` and registers in the entry-point group ``dvr_gl.renderers``.

The declaration belongs to the scene contract: it is written in the scene's words (its settings, data
kinds, projections, sweeps) and is read by everything above the renderers through
:mod:`dvr_gl.renderers.registry`, which loads the registered plugins.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Optional

from .model import SCATTERING_METHODS
from .settings import MODEL_SETTINGS, Setting


@dataclass(frozen=True)
class RendererPlugin:
    """What a renderer declares about itself.

    name, description: as listed by ``dvr info`` and chosen with ``renderer.name``.
    renderer: the :class:`~dvr_gl.renderers.base.Renderer` subclass, or ``"module:Class"``
        (imported when first created, so that reading the registry stays cheap).
    settings: the :class:`~dvr_gl.scene.settings.Setting` s it reads beyond its ``name``:
        the model settings it supports (narrowed to its choices) and its own.
    data_kinds: the field kinds it renders (:mod:`dvr_gl.fields`); None: any field.
    needs_gl: it draws with OpenGL (it takes a moderngl context: ``ctx=``).
    fixed_planes: it samples fixed planes (the voxel planes), not a sample distance.
    check: ``check(scene)`` raises SceneError with the reason it cannot render a scene,
        beyond what its settings say (e.g. an eye inside the volume); or ``"module:function"``.
    oracle: ``"PACKAGE.oracle:oracle"`` (the built-ins': ``dvr_gl.renderers.NAME.oracle``), every
        renderer's in the same place and shape: ``oracle(scene) -> np.ndarray``, the float64 image
        ``(H, W, 4)`` (premultiplied linear RGBA, rows from the top) of the same discretization that it
        must match to float32 rounding; where a shared judge of :mod:`dvr_gl.reference` serves, the
        module is the adapter that says which and why.  None for the references, which are the judges.
    resolve: ``resolve(scene) -> scene``: resolves settings of its own when a scene is read
        (the ray caster turns a tolerance into settings); or ``"module:function"``.
    resolve_unless: the settings whose request makes ``resolve`` keep what the scene asked for: where a
        scene asks for none of them, its settings were chosen by the scene, and ``Scene.with_renderer``
        and ``Scene.replace(transfer_function=...)`` choose them again (``resolve`` run afresh).
    sweeps: the trade-off families (:mod:`dvr_gl.scene.sweeps`) that vary something it reads.
    tolerances: what it promises against the conformance tests' closed forms: the largest
        absolute error outside the exact bounds, per closed form (``"box"``, ``"ramp"``,
        ``"sphere"``, ``"analytic sphere"``) or per closed form and mode (``("ramp", "mip")``), at
        the tests' resolution (``tests/renderers/test_conformance.py``, ``tests/closed_forms.py``).
    reference: a CPU float64 reference (a judge: no oracle, slow).
    projections: the camera projections it renders (one built on the projection-slice theorem:
        parallel projections only).
    out_of_core: it renders a volume read out of core (:mod:`dvr_gl.out_of_core`), reading bricks
        as it needs them; the others need the voxels in memory.
    order: its place where the renderers are listed (``dvr info``, ``--renderer``'s choices, the viewer's
        number keys, the default renderer of a data kind): lower first, equal ones by name.
    sort_last: it renders a subset of a volume's bricks as a compositing state (``brick_plan(scene)``,
        ``render_state(scene, bricks)``), which :mod:`dvr_gl.distributed` composites across workers.
    view_aligned_slices: its sample distance is the spacing of slices facing the eye (the viewer calls
        it the slice spacing and counts the slices).
    scattering_methods: the ways it finds ``renderer.scattering``'s transmittance toward the lights
        (:data:`dvr_gl.scene.model.SCATTERING_METHODS`), where it declares scattering.
    field_roles: with ``"fields"`` among its data kinds (several fields composited per sample:
        :mod:`dvr_gl.fields.layers`), the roles of fields it classifies (``"scalar"``, ``"label"``, ``"rgb"``;
        default: scalars only).
    transfer_function_2d: the data kinds it classifies by value and gradient magnitude with a 2D transfer
        function (:mod:`dvr_gl.transfer_function_2d`); with any other, a 2D transfer function is refused.
    depth_output: it draws a depth image beside the colour when asked (``Renderer.want_depth``; the depth
        :mod:`dvr_gl.reference.depth` defines; docs/picking.md).
    bench: its ``dvr bench`` subcommands, ``"module:attribute"`` naming a
        :class:`~dvr_gl.renderers.bench_command.BenchCommand` or a tuple of them (imported when ``dvr``
        builds its flags: keep that module light; the measurement imports the bench harness when run).
    """

    name: str
    description: str
    renderer: Any
    settings: tuple[Setting, ...] = ()
    data_kinds: Optional[tuple[str, ...]] = ("grid",)
    needs_gl: bool = False
    fixed_planes: bool = False
    check: Any = None
    oracle: Any = None
    resolve: Any = None
    resolve_unless: tuple[str, ...] = ()
    sweeps: tuple = ()
    tolerances: Any = None
    reference: bool = False
    projections: tuple[str, ...] = ("perspective", "orthographic")
    out_of_core: bool = False
    order: int = 1000
    sort_last: bool = False
    view_aligned_slices: bool = False
    scattering_methods: tuple[str, ...] = SCATTERING_METHODS
    bench: Any = None
    field_roles: tuple[str, ...] = ("scalar",)
    transfer_function_2d: tuple[str, ...] = ()
    depth_output: bool = False

    def declared(self, name: str) -> Optional[Setting]:
        return next((s for s in self.settings if s.name == name), None)

    @property
    def setting_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.settings)

    def choices(self, name: str) -> tuple:
        """The values of a setting with choices that this renderer supports (none if it does not
        declare the setting: then only the default)."""
        own = self.declared(name)
        if own is not None:
            return own.choices
        shared = next((s for s in MODEL_SETTINGS if s.name == name), None)
        return (shared.default_value(),) if shared is not None else ()

    def renderer_class(self):
        return load(self.renderer)

    def create(self, **kwargs):
        return self.renderer_class()(**kwargs)

    def oracle_image(self, scene):
        return load(self.oracle)(scene)


def load(obj):
    """An object, or the one a ``"module:attribute"`` string names."""
    if not isinstance(obj, str):
        return obj
    module, _, attribute = obj.partition(":")
    return getattr(importlib.import_module(module), attribute)
