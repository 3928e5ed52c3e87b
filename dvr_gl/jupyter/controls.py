"""The widget's controls (ipywidgets), beside the picture: the transfer function of the chosen field (a preset,
window and level in data units, an opacity scale, and the drawn editor of its control points,
:mod:`.tf_canvas`: an edit turns the preset box to "custom"), the renderer (those whose declared data kinds take the
scene's data) and its main settings (compositing, sample distance in voxels, shading), a clipping plane (facing
the view when switched on, moved along its normal by a fraction of the box's diagonal), the time step, and a
status line (the frame's level and time, what lies under the resting pointer, or why a setting was refused);
annotations (colour bar, scale bar, axes, a caption) drawn on the full-quality frames; and camera-path
recording (a keyframe of the current camera, one a second; clear).

Every change goes through :mod:`dvr_gl.viewer.settings` (checked as a scene file's would be and refused, in the
status line, when the renderer cannot render it).  A slider moved continuously renders coarse frames, and the
full image once it rests, as a drag does.
"""

from __future__ import annotations

import dataclasses
import html
import math

import ipywidgets as w

from ..annotations import Annotations
from ..renderers import registry
from ..transfer_function import PRESETS, TransferFunction
from ..viewer import settings
from ..viewer.tf_editor import CUSTOM
from ..viewer.timeline import editable, with_transfer_function
from .looks import Look, preset_look
from .tf_canvas import TransferFunctionCanvas

AS_GIVEN = "(as given)"
CLIP_RANGE = 0.5  # the clipping plane moves up to half the box's diagonal either way from the centre


def renderers_for(scene) -> list[str]:
    """The registered renderers whose declared data kinds take the scene's data, in the registry's order."""
    kind = getattr(scene.field, "kind", None)
    return registry.renderers_with(lambda p: p.data_kinds is None or kind in p.data_kinds)


class Controls:
    """The panel (``panel``, an ipywidgets VBox) of one :class:`~dvr_gl.jupyter.canvas.VolumeWidget`."""

    def __init__(self, view):
        self.view = view
        self._quiet = False
        scene = view.scene
        self.fields = editable(scene.layers)
        self.given = {i: scene.layers[i].transfer_function for i in self.fields}
        self.looks = {i: Look.of(tf) for i, tf in self.given.items()}
        self.presets = dict.fromkeys(self.fields, AS_GIVEN)
        self.field_index = self.fields[0] if self.fields else None
        self._plane = None
        style = {"description_width": "110px"}
        self.field = w.Dropdown(options=[(scene.layers[i].name, i) for i in self.fields], description="field",
                                style=style)
        self.preset = w.Dropdown(options=[AS_GIVEN, *PRESETS, CUSTOM], description="preset", style=style)
        self.window = w.FloatSlider(description="window", style=style, readout_format=".4g")
        self.level = w.FloatSlider(description="level", style=style, readout_format=".4g")
        self.opacity = w.FloatLogSlider(value=1.0, base=10, min=-2, max=2, step=0.05, description="opacity scale",
                                        style=style)
        self.renderer = w.Dropdown(options=renderers_for(scene), description="renderer", style=style)
        self.compositing = w.Dropdown(options=settings.choices("compositing"), description="compositing",
                                      style=style)
        self.sample = w.FloatLogSlider(base=10, min=math.log10(settings.MIN_SAMPLE_VOXELS),
                                       max=math.log10(settings.MAX_SAMPLE_VOXELS), step=0.05,
                                       description="sample (voxel)", style=style)
        self.shading = w.Checkbox(description="shading", style=style)
        self.clip = w.Checkbox(description="clip plane", style=style)
        self.clip_at = w.FloatSlider(value=0.0, min=-CLIP_RANGE, max=CLIP_RANGE, step=0.01, description="clip at",
                                     style=style)
        self.time = w.IntSlider(value=0, min=0, max=max(0, view.steps - 1), description="time", style=style)
        self.home = w.Button(description="reset view")
        self.marks = {name: w.Checkbox(description=label, indent=False, layout=w.Layout(width="auto"))
                      for name, label in (("colorbar", "colour bar"), ("scalebar", "scale bar"), ("axes", "axes"))}
        self.caption = w.Text(description="caption", placeholder="(none)", continuous_update=False, style=style)
        self.keyframe = w.Button(description="keyframe", tooltip="record the current camera (one a second)")
        self.clear = w.Button(description="clear", tooltip="forget the recorded keyframes")
        self.status = w.HTML()
        self.editor = TransferFunctionCanvas(self)
        self.panel = w.VBox(self._rows(scene), layout=w.Layout(min_width="340px"))
        self.sync()
        self._observe()
        self.show_status()

    def _rows(self, scene) -> list:
        rows = [self.field] if len(self.fields) > 1 else []
        if self.fields:
            rows += [self.preset, self.window, self.level, self.opacity, self.editor]
        rows += [self.renderer, self.compositing, self.sample, self.shading]
        if hasattr(scene.renderer, "clipping"):
            rows += [self.clip, self.clip_at]
        if self.view.steps > 1:
            rows.append(self.time)
        return rows + [self.home, w.HBox(list(self.marks.values())), self.caption, w.HBox([self.keyframe, self.clear]),
                       self.status]

    def _observe(self):
        handlers = {self.field: self._on_field, self.preset: self._on_preset, self.window: self._on_look,
                    self.level: self._on_look, self.opacity: self._on_look, self.renderer: self._on_renderer,
                    self.compositing: self._on_compositing, self.sample: self._on_sample,
                    self.shading: self._on_shading, self.clip: self._on_clip, self.clip_at: self._on_clip,
                    self.time: self._on_time}
        for control in (*self.marks.values(), self.caption):
            handlers[control] = self._on_annotations
        for control, handler in handlers.items():
            control.observe(self._guarded(handler), names="value")
        self.home.on_click(lambda _: self.view.reset_view())
        self.keyframe.on_click(lambda _: self.view.add_keyframe())
        self.clear.on_click(lambda _: self.view.clear_keyframes())

    def _guarded(self, handler):
        def run(change):
            if not self._quiet:
                handler(change)
        return run

    # --- from the scene to the controls ---

    def sync(self):
        """Every control as the scene is now (no change is sent back)."""
        self._quiet = True
        try:
            r = self.view.scene.renderer
            self.renderer.value = r.name
            self.compositing.value = r.compositing
            self.sample.value = settings.sample_distance_voxels(self.view.scene)
            self.shading.value = bool(r.shading.enabled)
            self.clip.value = bool(getattr(getattr(r, "clipping", None), "planes", None))
            if self.field_index is not None:
                self.field.value = self.field_index
                self.preset.value = self.presets[self.field_index]
                self._show_look(self.looks[self.field_index])
                self.editor.show_scene()
        finally:
            self._quiet = False

    def _show_look(self, look: Look):
        lo, hi = self.view.scene.layers[self.field_index].field.value_range
        span = max(hi - lo, look.window, 1e-12)
        self.window.min, self.window.max = 0.0, 0.0
        self.window.max = max(2.0 * span, 1.5 * look.window)
        self.window.min, self.window.step = span / 1000.0, span / 1000.0
        self.window.value = look.window
        self.level.min, self.level.max = -1e300, 1e300
        self.level.min, self.level.max = min(lo - span, look.level), max(hi + span, look.level)
        self.level.step = span / 1000.0
        self.level.value = look.level
        self.opacity.value = look.opacity

    def show_status(self):
        view, plan = self.view, self.view.last_plan
        if plan is None:
            text = "no frame yet"
        elif plan.level.full:
            text = f"full quality, {1e3 * view.render_seconds:.0f} ms"
        else:
            text = (f"1/{plan.level.block} resolution, {plan.level.distance_factor:g}x sample distance, "
                    f"{1e3 * view.render_seconds:.0f} ms")
        message = f"<br><span style='color:#c00'>{html.escape(view.message)}</span>" if view.message else ""
        picked = f"<br>{html.escape(view.pick_text)}" if view.pick_text else ""
        n = len(view.keyframes)
        path = f"<br>camera path: {n} keyframe{'s' * (n != 1)}, {max(n - 1, 0)} s" if n else ""
        self.status.value = f"<small>{settings.describe(view._scene)}<br>{text}{picked}{path}{message}</small>"

    # --- from the controls to the scene ---

    def _change(self, change, interactive: bool = False, costs: bool = True):
        if not self.view.apply(change, interactive=interactive, costs=costs):
            self.sync()

    def _on_field(self, change):
        self.field_index = change["new"]
        self.sync()

    def _on_preset(self, change):
        i, name = self.field_index, change["new"]
        if name == CUSTOM:   # the function as edited stays
            self.presets[i] = name
            return
        if name == AS_GIVEN:
            look = Look.of(self.given[i])
        else:
            layer = self.view.scene.layers[i]
            look = preset_look(name, layer.field, layer.transfer_function.unit_distance, self.view.rescale_intercept)
        self.presets[i] = name
        self._set_look(look)
        self.sync()

    def _on_look(self, change):
        look = self.looks[self.field_index].with_(window=self.window.value, level=self.level.value,
                                                  opacity=self.opacity.value)
        self._set_look(look, interactive=True)

    def _set_look(self, look: Look, interactive: bool = False):
        i = self.field_index
        tf: TransferFunction = look.transfer_function()
        self.looks[i] = look
        self._change(lambda s: with_transfer_function(s, i, tf), interactive, costs=False)
        self.editor.show_scene()

    def edited(self, tf: TransferFunction, interactive: bool = False):
        """The drawn editor's new function for the chosen field: the preset box says "custom", window, level
        and opacity scale start again from it (window and level its own span, scale 1); ``interactive``: a point
        being dragged (coarse frames until it rests)."""
        self.presets[self.field_index] = CUSTOM
        self._set_look(Look.of(tf), interactive)
        self.sync()

    def _on_renderer(self, change):
        self._change(lambda s: settings.change(s, name=change["new"]))
        self.sync()

    def _on_compositing(self, change):
        self._change(lambda s: settings.change(s, compositing=change["new"]))

    def _on_sample(self, change):
        self._change(lambda s: settings.set_sample_distance_voxels(s, change["new"]), interactive=True)

    def _on_shading(self, change):
        self._change(lambda s: settings.change(s, shading=dataclasses.replace(s.renderer.shading,
                                                                               enabled=change["new"])))

    def _on_clip(self, change):
        self._change(self._clipped, interactive=change["owner"] is self.clip_at)

    def _clipped(self, scene):
        """``scene`` with the clipping plane the controls say: none, or the plane facing the view when it was
        switched on, moved by ``clip_at`` of the diagonal."""
        clipping = scene.renderer.clipping
        if not self.clip.value:
            self._plane = None
            return settings.change(scene, clipping=dataclasses.replace(clipping, planes=[]))
        if self._plane is None:
            bare = scene.replace(renderer=dataclasses.replace(scene.renderer,
                                                              clipping=dataclasses.replace(clipping, planes=[])))
            self._plane = settings.toggle_clip_plane(bare).renderer.clipping.planes[0]
        placed = settings.change(scene, clipping=dataclasses.replace(clipping, planes=[self._plane]))
        return settings.move_clip_plane(placed, self.clip_at.value) if self.clip_at.value else placed

    def _on_annotations(self, change):
        caption = self.caption.value.strip() or None
        self.view.set_annotations(Annotations(**{n: c.value for n, c in self.marks.items()}, caption=caption))

    def _on_time(self, change):
        self.view.go_to_time(change["new"])
        self.editor.show_scene()   # the new step's histogram
