"""The viewer's panels, HUD and help overlay, in Dear ImGui (imgui-bundle).

* **Side panel** (right, above the status bar; it scrolls when its sections do not fit, and its
  transfer-function canvas is lower in a low window): the renderer settings (every registered renderer, compositing,
  classification, filter, shading, jitter and passes, sample distance, projection, frame-time
  budget; what the current renderer refuses is greyed out, the reason in a tooltip), the view
  (reset, screenshot), and the **transfer-function editor**: the data histogram (log counts), the
  opacity curve with its control points, the colour bar; click to add a point, drag to move,
  right-click to delete; the selected point's value, opacity and colour; presets (the box names the
  current function's preset, or "custom"); save and load.  Where the renderer declares a 2D transfer
  function for the data (trait ``transfer_function_2d``), a 1D/2D switch, and the **2D editor**: the
  log histogram of value x gradient magnitude, the boxes over it (click: add; drag inside: move;
  drag an edge or corner: resize; right-click or Delete: delete), the selected box's colour and opacity.
* **Status bar** (the HUD, across the bottom of the window, never over the image; rest the cursor
  on it for all of it, where it is cut): the settings or the last message (errors in red), then the
  refinement state, the last frame's times and samples per second.
* **Help** (F1): the key and mouse bindings of :mod:`.keys`, inside the window at any size
  (:func:`.layout.help_rect`; descriptions wrap beside their keys, and it scrolls when too tall).
"""

from __future__ import annotations

import numpy as np

from ..errors import DvrError
from ..fields import value_sample
from ..renderers import registry
from ..transfer_function import PRESETS, linear_to_srgb, preset, srgb_to_linear
from . import navigation, settings
from .imgui_backend import ImGuiInput, ImGuiRenderer
from .keys import help_rows
from .layout import help_rect
from .tf_editor import CUSTOM, CanvasMapping, load_points, nice_opacity_max, preset_name
from .tf_editor_2d import Canvas2D

CANVAS_HEIGHT = 150       # window pixels of the transfer-function canvas (at most; see canvas_height)
MIN_CANVAS_HEIGHT = 80
COLOUR_BAR_HEIGHT = 14
HISTOGRAM_BINS = 128
STATUS_TOOLTIP_SECONDS = 0.4  # the cursor rests this long on a status bar whose lines are cut: they show whole
HELP_KEY_CHARS = 12       # a help row's input at most this long goes in the key column (longer: a line of its own)
OPACITY_AXES = ("auto", "0.01", "0.05", "0.2", "0.5", "1")


def _linear(c):
    return srgb_to_linear(np.clip(c, 0.0, 1.0))


def _col32(r, g, b, a=1.0) -> int:
    """Packed ABGR colour from components in [0, 1] (already display-encoded)."""
    r, g, b, a = (int(round(min(1.0, max(0.0, float(x))) * 255)) for x in (r, g, b, a))
    return (a << 24) | (b << 16) | (g << 8) | r


def canvas_height(panel_height: float) -> int:
    """The transfer-function canvas's height for a panel ``panel_height`` window pixels high: 30 %
    of it, within [MIN_CANVAS_HEIGHT, CANVAS_HEIGHT], so that a low panel keeps room for the rest."""
    return int(min(CANVAS_HEIGHT, max(MIN_CANVAS_HEIGHT, 0.3 * panel_height)))


def histogram(data: np.ndarray, value_range: tuple[float, float], bins: int = HISTOGRAM_BINS) -> np.ndarray:
    """Heights in [0, 1] of the data's histogram over ``value_range``: log(1 + count), scaled to the
    highest bin (a strided subset of at most about 2^24 voxels; of a mesh's values, any shape)."""
    if data.ndim == 3:
        step = max(1, int(round((data.size / 2 ** 24) ** (1 / 3))))
        data = data[::step, ::step, ::step]
    else:
        data = np.ravel(data)[::max(1, data.size // 2 ** 24)]
    counts, _ = np.histogram(data, bins=bins, range=value_range)
    heights = np.log1p(counts.astype(np.float64))
    return heights / heights.max() if heights.max() > 0 else heights


class ViewerGui:
    """ImGui context, input and renderer for one viewer window, and what it draws each frame."""

    def __init__(self, imgui, glfw, ctx, viewer):
        self.imgui, self.glfw, self.viewer = imgui, glfw, viewer
        self.context = imgui.create_context()
        io = imgui.get_io()
        io.set_ini_filename(None)
        imgui.style_colors_dark()
        self.input = ImGuiInput(imgui, glfw)
        self.renderer = ImGuiRenderer(imgui, ctx)
        self.tf_canvas: tuple[float, float, float, float] | None = None
        self.dragging: int | None = None
        self.axis_choice = 0
        self.axis_max: float | None = None
        self._preset = (None, -1, CUSTOM)   # (editor, its version, the preset box's name)
        self.grab: tuple | None = None      # the 2D editor's box dragged: (index, part, row, x, y, last position)
        self.switch_2d: tuple | None = None  # the 1D/2D switch's "2D" button (window pixels), when shown
        self.help_box: tuple | None = None   # where the help overlay was drawn (window pixels)
        self._hover_since: float | None = None   # when the cursor came to rest on the status bar (GLFW seconds)
        self.tf_path = "transfer_function.toml"
        self._histogram_key = None
        self._heights = None
        self._last_time = glfw.get_time()
        self.any_active = False
        self._refusal_cache: dict = {}
        self._refusal_version = -1
        self.canvas_height = CANVAS_HEIGHT
        self.panel_scroll: dict = {}
        self._logged_layout: dict | None = None

    @property
    def busy(self) -> bool:
        """A gesture in the panel is going on: a point or a slider is being dragged."""
        return self.dragging is not None or self.grab is not None or self.any_active

    # --- frame ---

    def frame(self):
        imgui, glfw, v = self.imgui, self.glfw, self.viewer
        io = imgui.get_io()
        win_w, win_h = glfw.get_window_size(v.window)
        fb_size = glfw.get_framebuffer_size(v.window)
        io.display_size = imgui.ImVec2(win_w, win_h)
        if win_w:
            io.display_framebuffer_scale = imgui.ImVec2(fb_size[0] / win_w, fb_size[1] / max(win_h, 1))
        now = glfw.get_time()
        io.delta_time = max(now - self._last_time, 1e-4)
        self._last_time = now
        imgui.new_frame()
        parts = v.window_layout()
        if parts.panel is not None:
            self.panel(parts.panel)
        else:
            self._set_canvas(None)
        if parts.status is not None:
            self.status_bar(parts.status)
        self.help_box = None
        if v.show_help:
            self.help(parts.window, parts.image)
        self.any_active = imgui.is_any_item_active()
        imgui.render()
        self.renderer.render(imgui.get_draw_data(), fb_size)
        self._log_layout()

    def _set_canvas(self, rect):
        """Where the transfer-function canvas is (window pixels)."""
        self.tf_canvas = rect

    def _log_layout(self):
        """A change of the window's parts, the canvas or the panel's scrolling goes to the frame log."""
        now = self.viewer.layout()
        if now != self._logged_layout:
            self._logged_layout = now
            self.viewer.log.write(event="layout", **now)

    # --- overlays ---

    def status_bar(self, rect):
        """The HUD's two lines in a bar of its own (:data:`.layout.STATUS_HEIGHT` high), clipped at
        the window's width; hovering shows them whole."""
        imgui = self.imgui
        x, y, w, h = rect
        flags = (imgui.WindowFlags_.no_decoration | imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_nav
                 | imgui.WindowFlags_.no_focus_on_appearing | imgui.WindowFlags_.no_saved_settings
                 | imgui.WindowFlags_.no_scroll_with_mouse | imgui.WindowFlags_.no_bring_to_front_on_focus)
        imgui.set_next_window_pos(imgui.ImVec2(x, y))
        imgui.set_next_window_size(imgui.ImVec2(w, h))
        imgui.push_style_var(imgui.StyleVar_.window_padding, imgui.ImVec2(8, 4))
        imgui.push_style_var(imgui.StyleVar_.window_rounding, 0.0)
        imgui.begin("status", None, flags)
        lines = self.viewer.hud_lines()
        message = self.viewer.current_message()
        if message:
            colour = imgui.ImVec4(1.0, 0.35, 0.3, 1.0) if message[1] else imgui.ImVec4(0.6, 0.9, 0.6, 1.0)
            imgui.text_colored(colour, lines[0])
        else:
            imgui.text(lines[0])
        imgui.text(lines[1])
        # the lines whole, where the bar cuts them, once the cursor has rested on it (not while it crosses it)
        cut = any(imgui.calc_text_size(line).x > w - 16 for line in lines)
        now = self.glfw.get_time()
        if not (cut and imgui.is_window_hovered()):
            self._hover_since = None
        elif self._hover_since is None:
            self._hover_since = now
        elif now - self._hover_since >= STATUS_TOOLTIP_SECONDS:
            imgui.set_tooltip("\n".join(lines))
        imgui.end()
        imgui.pop_style_var(2)

    def help(self, window, image_rect):
        """The keys and mouse (F1), centred on the image and inside the window (:func:`.layout.help_rect`): each
        key in a column of its own, its description wrapped beside it; scrolling when taller than the window."""
        imgui = self.imgui
        rows = help_rows()
        style = imgui.get_style()
        short = [k for k, _ in rows if len(k) <= HELP_KEY_CHARS]   # keys; a mouse input's words span the box
        key_w = max(imgui.calc_text_size(k).x for k in short) + 2 * style.item_spacing.x
        frame_w = 2 * style.window_padding.x + style.scrollbar_size
        texts = [(d if len(k) <= HELP_KEY_CHARS else f"{k}: {d}") for k, d in rows]
        widest = key_w + max(imgui.calc_text_size(t).x for t in texts) + frame_w
        wrap = max(40.0, min(widest, window[0] - 16) - key_w - frame_w)   # the description column's width
        lines = sum(max(1, int(np.ceil(imgui.calc_text_size(t).x / wrap))) for t in texts)
        tall = lines * imgui.get_text_line_height_with_spacing() + imgui.get_frame_height() + 2 * style.window_padding.y
        x, y, w, h = help_rect(window, image_rect, (widest, tall))
        self.help_box = (x, y, w, h)
        imgui.set_next_window_pos(imgui.ImVec2(x, y))
        imgui.set_next_window_size(imgui.ImVec2(w, h))
        imgui.set_next_window_bg_alpha(0.9)
        flags = (imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings | imgui.WindowFlags_.no_move
                 | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_focus_on_appearing | imgui.WindowFlags_.no_nav)
        imgui.begin("Keys and mouse (F1 closes)", None, flags)
        for key, text in rows:
            if len(key) > HELP_KEY_CHARS:
                imgui.text_wrapped(f"{key}: {text}")
                continue
            imgui.text(key)
            imgui.same_line(key_w)
            imgui.text_wrapped(text)
        imgui.end()

    # --- side panel ---

    def panel(self, rect):
        """The side panel in ``rect`` (window pixels): collapsing sections in a window that scrolls
        (wheel or scroll bar) when they are taller than it."""
        imgui = self.imgui
        x, y, width, height = rect
        self.canvas_height = canvas_height(height)
        imgui.set_next_window_pos(imgui.ImVec2(x, y))
        imgui.set_next_window_size(imgui.ImVec2(width, height))
        flags = (imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_collapse
                 | imgui.WindowFlags_.no_saved_settings | imgui.WindowFlags_.no_title_bar)
        imgui.push_style_var(imgui.StyleVar_.window_rounding, 0.0)
        imgui.begin("dvr view", None, flags)
        imgui.push_item_width(-130)
        if imgui.collapsing_header("Transfer function", imgui.TreeNodeFlags_.default_open) and \
                self.viewer.editor is not None:
            self.transfer_function_section()
        else:
            self._set_canvas(None)
            if self.viewer.editor is None:  # label maps only: colour tables, not curves
                imgui.text_disabled("label maps: colours from their tables (transfer_function.labels or a file)")
        if imgui.collapsing_header("Rendering", imgui.TreeNodeFlags_.default_open):
            self.rendering_section()
        if imgui.collapsing_header("View", imgui.TreeNodeFlags_.default_open):
            self.view_section()
        imgui.pop_item_width()
        # how far it scrolls, and where its last item ends (window pixels): for the frame log's tests
        self.panel_scroll = {"y": round(imgui.get_scroll_y(), 1), "max": round(imgui.get_scroll_max_y(), 1),
                             "last_item_bottom": round(imgui.get_item_rect_max().y, 1)}
        imgui.end()
        imgui.pop_style_var()

    def _refusals(self, key: str) -> dict:
        """Option -> why the current scene's renderer refuses it (None: available), asked of the
        registry once per scene change (the panel greys refused options out)."""
        v = self.viewer
        if self._refusal_version != v.version:
            self._refusal_cache, self._refusal_version = {}, v.version
        if key not in self._refusal_cache:
            current = v.scene.renderer.name if key == "name" else getattr(v.scene.renderer, key)
            self._refusal_cache[key] = {o: (None if o == current else settings.refusal(v.scene, **{key: o}))
                                        for o in settings.choices(key)}
        return self._refusal_cache[key]

    def _combo(self, label: str, key: str, current: str) -> str | None:
        """A combo box of a setting's choices; those the renderer refuses are greyed out, the reason
        in their tooltip."""
        imgui = self.imgui
        chosen = None
        if imgui.begin_combo(label, str(current)):
            for option, reason in self._refusals(key).items():
                flags = imgui.SelectableFlags_.disabled if reason else 0
                clicked, _ = imgui.selectable(str(option), option == current, flags)
                if reason:
                    imgui.set_item_tooltip(reason)
                if clicked and option != current:
                    chosen = option
            imgui.end_combo()
        return chosen

    def _checkbox(self, label: str, value: bool, available: bool) -> bool:
        """A check box, greyed out when the renderer does not support the feature; True when clicked."""
        imgui = self.imgui
        if not available:
            imgui.begin_disabled(True)
        changed, _ = imgui.checkbox(label, value)
        if not available:
            imgui.end_disabled()
        return changed

    def rendering_section(self):
        imgui, v = self.imgui, self.viewer
        r = v.scene.renderer
        plugin = registry.plugin(r.name)
        for key, label in (("name", "renderer"), ("compositing", "compositing"),
                           ("classification", "classification"), ("filter", "filter")):
            choice = self._combo(label, key, r.name if key == "name" else getattr(r, key))
            if choice is not None:
                v.apply(lambda s, k=key, c=choice: settings.change(s, **{k: c}))
        if self._checkbox("shading (L)", r.shading.enabled, plugin.declared("shading") is not None):
            v.apply(settings.toggle_shading)
        if self._checkbox("scattering (G)", r.scattering.enabled, plugin.declared("scattering") is not None):
            v.apply(settings.toggle_scattering)
        if self._checkbox("clipping plane (X; Z moves it)", bool(r.clipping.planes),
                          plugin.declared("clipping") is not None):
            v.apply(settings.toggle_clip_plane)
        if self._checkbox("jitter (J)", r.jitter, plugin.declared("jitter") is not None):
            v.apply(settings.toggle_jitter)
        changed, passes = imgui.slider_int("jitter passes", v.options.passes, 1, 64)
        if changed:
            v.options.passes = passes
            v.controller.set_passes(v._passes(v.scene))
        voxels = settings.sample_distance_voxels(v.scene)
        label = "slice spacing, voxels" if plugin.view_aligned_slices else "sample distance, voxels"
        fixed = settings.fixed_planes(r.name)
        if fixed:
            imgui.begin_disabled(True)
        changed, voxels = imgui.slider_float(label, voxels, settings.MIN_SAMPLE_VOXELS, settings.MAX_SAMPLE_VOXELS,
                                             "%.3f", imgui.SliderFlags_.logarithmic)
        if fixed:
            imgui.end_disabled()
        if changed:
            v.apply(lambda s: settings.set_sample_distance_voxels(s, voxels), interactive=imgui.is_item_active())
        if imgui.is_item_deactivated_after_edit():
            v.end_gesture()
        imgui.text_disabled(settings.sampling_text(v.scene))
        if r.compositing == "isosurface":
            lo, hi = v.scene.field.value_range
            changed, iso = imgui.slider_float("iso value", r.iso_value, lo, hi, "%.4g")
            if changed:
                v.apply(lambda s: settings.change(s, iso_value=iso), interactive=imgui.is_item_active())
            if imgui.is_item_deactivated_after_edit():
                v.end_gesture()
        changed, budget = imgui.slider_float("budget, ms", v.options.budget_ms, 10.0, 1000.0, "%.0f",
                                             imgui.SliderFlags_.logarithmic)
        if changed:
            v.options.budget_ms = budget
            v.controller.budget = budget / 1e3

    def view_section(self):
        imgui, v = self.imgui, self.viewer
        cam = v.scene.camera
        az, el, dist = cam.orbit or cam.orbited().orbit
        imgui.text(f"azimuth {az:.1f}, elevation {el:.1f}, distance {dist:.4g}")
        changed, _ = imgui.checkbox("orthographic (P)", cam.projection == "orthographic")
        if changed:
            v.move_camera(navigation.toggle_projection(cam), interactive=False)
        if imgui.button("reset view (R)"):
            v.action("reset_view")
        imgui.same_line()
        if imgui.button("screenshot (S)"):
            v.action("screenshot")
        imgui.text_disabled(f"screenshots: {v.options.screenshot_dir}/dvr_view_NNNN{v.options.screenshot_format}")
        if imgui.checkbox("annotations (A)", v.annotations_on)[0]:
            v.action("toggle_annotations")
        imgui.same_line()
        if imgui.checkbox("pick under the cursor (I)", v.probe.enabled)[0]:
            v.action("toggle_pick")
        if imgui.button("add keyframe (shift+K)"):
            v.action("add_keyframe")
        imgui.same_line()
        if imgui.button("clear (Backspace)"):
            v.action("clear_keyframes")
        imgui.same_line()
        imgui.text(f"{len(v.recorder.cameras)} keyframes")
        if v.player is not None:
            self.time_controls()

    def time_controls(self):
        """Play, pause and step through a time series (the keys Space, Left, Right)."""
        imgui, v = self.imgui, self.viewer
        if imgui.button("pause (Space)" if v.player.playing else "play (Space)"):
            v.action("toggle_play")
        imgui.same_line()
        if imgui.button("<"):
            v.action("previous_step")
        imgui.same_line()
        if imgui.button(">"):
            v.action("next_step")
        imgui.same_line()
        imgui.text(f"step {v.player.step} of 0..{v.player.steps - 1}")

    # --- transfer-function editor ---

    def _value_range(self) -> tuple[float, float]:
        v = self.viewer
        lo, hi = v.edited_field.value_range
        lo, hi = min(lo, v.editor.points[0, 0]), max(hi, v.editor.points[-1, 0])
        return (lo, hi) if hi > lo else (lo, lo + 1.0)

    def _heights_for(self, value_range) -> np.ndarray:
        key = (id(self.viewer.edited_field), value_range)
        if key != self._histogram_key:
            field = self.viewer.edited_field
            # a grid's samples, a mesh's values (point or cell): what the transfer function maps
            values = value_sample(field)  # out of core: an even subsample
            self._histogram_key, self._heights = key, histogram(values, value_range)
        return self._heights

    def _opacity_max(self) -> float:
        editor = self.viewer.editor
        if self.axis_choice:
            return float(OPACITY_AXES[self.axis_choice])
        if self.dragging is None or self.axis_max is None:   # the axis holds still while a point moves
            self.axis_max = nice_opacity_max(editor.points[:, 4], editor.opacity_model)
        return self.axis_max

    def transfer_function_section(self):
        imgui, v = self.imgui, self.viewer
        editor = v.editor
        layers = v.scene.layers
        if len(layers) > 1:  # several fields: whose transfer function this is
            layer = layers[v.field_index]
            imgui.text(f"field {v.field_index + 1} of {len(layers)}: {layer.name or layer.field.name}")
            imgui.same_line()
            if imgui.button("next field (N)"):
                v.action("next_field")
        self._mode_switch()
        if v.tf_mode == "2d" and v.editor_2d is not None:
            self.editor_2d_section()
            return
        value_range = self._value_range()
        pos = imgui.get_cursor_screen_pos()
        width = max(imgui.get_content_region_avail().x, 50.0)
        canvas_h = self.canvas_height
        mapping = CanvasMapping(pos.x, pos.y, width, canvas_h, value_range, self._opacity_max())
        self._set_canvas((pos.x, pos.y, width, float(canvas_h)))
        imgui.invisible_button("tf canvas", imgui.ImVec2(width, canvas_h + COLOUR_BAR_HEIGHT),
                               imgui.ButtonFlags_.mouse_button_left | imgui.ButtonFlags_.mouse_button_right)
        self._canvas_input(mapping)
        self._draw_canvas(mapping, value_range)
        imgui.text_disabled("click: add | drag: move | right-click: delete")
        self._selected_point()
        _, self.axis_choice = imgui.combo("opacity axis", self.axis_choice, list(OPACITY_AXES))
        current = self.preset_label()
        if imgui.begin_combo("preset", current):   # choosing one applies it
            for name in PRESETS:
                clicked, _ = imgui.selectable(name, name == current)
                if clicked:
                    editor.replace(preset(name, v.edited_field.value_range, v.options.rescale_intercept,
                                          editor.unit_distance))
                    self._preset = (editor, editor.version, name)
            imgui.end_combo()
        _, self.tf_path = imgui.input_text("file", self.tf_path)
        if imgui.button("save"):
            try:
                v.notify(f"saved the transfer function to {editor.save(self.tf_path)}")
            except DvrError as exc:  # shown, not raised
                v.notify(str(exc), error=True)
        imgui.same_line()
        if imgui.button("load"):
            try:
                editor.replace(load_points(self.tf_path))
                v.notify(f"loaded the transfer function from {self.tf_path}")
            except DvrError as exc:
                v.notify(str(exc), error=True)

    def preset_label(self) -> str:
        """The preset box's name: the preset the edited function is (looked up when the editor opens on a field),
        the one last chosen, or "custom" after any other edit."""
        v, editor = self.viewer, self.viewer.editor
        known, version, label = self._preset
        if known is not editor:
            spec = getattr(getattr(v.scene, "spec", None), "transfer_function", None)
            hint = getattr(spec, "preset", None) if len(v.scene.layers) == 1 else None
            label = preset_name(editor.transfer_function(), v.edited_field.value_range,
                                v.options.rescale_intercept, hint)
        elif version != editor.version:
            label = CUSTOM
        self._preset = (editor, editor.version, label)
        return label

    @property
    def preset_shown(self) -> str | None:
        """The name the preset box showed last (None: not drawn yet)."""
        return self._preset[2] if self._preset[0] is not None else None

    def _mode_switch(self):
        """1D / 2D transfer function, where the renderer declares a 2D one for the data (or one is edited)."""
        imgui, v = self.imgui, self.viewer
        self.switch_2d = None
        if v.tf_mode != "2d" and not v.offers_2d():
            return
        if imgui.radio_button("1D: value", v.tf_mode == "1d"):
            v.set_tf_mode("1d")
        imgui.same_line()
        clicked = imgui.radio_button("2D: value x |gradient|", v.tf_mode == "2d")
        low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
        self.switch_2d = (low.x, low.y, high.x - low.x, high.y - low.y)
        if clicked:
            v.set_tf_mode("2d")

    # --- the 2D editor ---

    def editor_2d_section(self):
        """The log histogram of value x gradient magnitude, the boxes over it, and the selected box's settings."""
        imgui, v = self.imgui, self.viewer
        ed = v.editor_2d
        pos = imgui.get_cursor_screen_pos()
        width = max(imgui.get_content_region_avail().x, 50.0)
        canvas = Canvas2D(pos.x, pos.y, width, float(self.canvas_height), ed.value_range, ed.gradient_range)
        self._set_canvas((pos.x, pos.y, width, float(self.canvas_height)))
        imgui.invisible_button("tf 2d canvas", imgui.ImVec2(width, self.canvas_height),
                               imgui.ButtonFlags_.mouse_button_left | imgui.ButtonFlags_.mouse_button_right)
        self._canvas_2d_input(canvas)
        self._draw_canvas_2d(canvas)
        imgui.text_disabled("click: add | drag: move | edge, corner: resize")
        imgui.text_disabled("right-click or Delete: delete")
        if imgui.button("add box"):
            ed.add(sum(ed.value_range) / 2, sum(ed.gradient_range) / 2)
        i = ed.selected
        if i is None or i >= len(ed.boxes):
            imgui.same_line()
            imgui.text_disabled(f"{len(ed.boxes)} boxes; none selected")
            return
        imgui.same_line()
        if imgui.button("delete box"):
            ed.delete(i)
            return
        box = ed.boxes[i]
        changed, colour = imgui.color_edit3("colour", list(linear_to_srgb(np.array(box[4:7]))))
        if changed:
            ed.set_color(i, _linear(colour))
        changed, alpha = imgui.slider_float("opacity", box[7], 0.0, 1.0, "%.3f")
        if changed:
            ed.set_opacity(i, alpha)
        if imgui.is_item_deactivated_after_edit():
            v.end_gesture()
        imgui.text_disabled(f"value {box[0]:.4g} + {box[2]:.4g}, |gradient| {box[1]:.4g} + {box[3]:.4g}")

    def _canvas_2d_input(self, canvas: Canvas2D):
        imgui, ed = self.imgui, self.viewer.editor_2d
        mouse = imgui.get_mouse_pos()
        if imgui.is_item_hovered() and canvas.contains(mouse.x, mouse.y):
            hit = ed.hit(canvas, mouse.x, mouse.y)
            if imgui.is_mouse_clicked(0):   # on a box: grab it; elsewhere: a new box there, grabbed
                i, part = hit if hit is not None else (ed.add(*canvas.from_pixel(mouse.x, mouse.y)), "inside")
                ed.selected, self.grab = i, (i, part, list(ed.boxes[i]), mouse.x, mouse.y, None)
            elif imgui.is_mouse_clicked(1) and hit is not None:
                ed.delete(hit[0])
        if self.grab is not None:
            # the box follows the cursor while the button is down, and to where it was released (the release
            # and the last moves can reach ImGui in one frame, when a frame was slow)
            i, part, row, x0, y0, moved = self.grab
            if i < len(ed.boxes) and imgui.is_mouse_pos_valid() and (moved or imgui.is_mouse_dragging(0, 1.0)
                                                                    or max(abs(mouse.x - x0), abs(mouse.y - y0)) >= 1):
                if not moved or (mouse.x, mouse.y) != moved:
                    ed.drag(i, part, row, mouse.x - x0, mouse.y - y0, canvas)
                moved = (mouse.x, mouse.y)
            self.grab = (i, part, row, x0, y0, moved)
            if not imgui.is_mouse_down(0) or i >= len(ed.boxes):
                self.grab = None
                self.viewer.end_gesture()
        if (ed.selected is not None and ed.selected < len(ed.boxes) and imgui.is_window_focused()
                and not imgui.get_io().want_text_input and imgui.is_key_pressed(imgui.Key.delete)):
            ed.delete(ed.selected)

    def _draw_canvas_2d(self, canvas: Canvas2D):
        imgui, ed = self.imgui, self.viewer.editor_2d
        draw = imgui.get_window_draw_list()
        x0, y0, w, h = canvas.x, canvas.y, canvas.width, canvas.height
        draw.add_rect_filled(imgui.ImVec2(x0, y0), imgui.ImVec2(x0 + w, y0 + h), _col32(0.1, 0.1, 0.12))
        cells = self._cells_2d()
        cw, ch = w / cells.shape[0], h / cells.shape[1]
        for i, j in zip(*np.nonzero(cells)):   # value to the right, gradient magnitude up
            grey = 0.15 + 0.6 * cells[i, j]
            draw.add_rect_filled(imgui.ImVec2(x0 + i * cw, y0 + h - (j + 1) * ch),
                                 imgui.ImVec2(x0 + (i + 1) * cw, y0 + h - j * ch), _col32(grey, grey, grey))
        draw.push_clip_rect(imgui.ImVec2(x0, y0), imgui.ImVec2(x0 + w, y0 + h), True)
        for k, box in enumerate(ed.boxes):
            left, top, right, bottom = canvas.box_rect(box)
            r, g, b = linear_to_srgb(np.array(box[4:7]))
            fill = _col32(r, g, b, 0.25 + 0.5 * box[7])
            draw.add_rect_filled(imgui.ImVec2(left, top), imgui.ImVec2(right, bottom), fill)
            selected = k == ed.selected
            draw.add_rect(imgui.ImVec2(left, top), imgui.ImVec2(right, bottom),
                          _col32(1, 1, 0) if selected else _col32(1, 1, 1), 0.0, 2.0 if selected else 1.0)
        draw.pop_clip_rect()
        grey = _col32(0.8, 0.8, 0.8)
        draw.add_text(imgui.ImVec2(x0 + 3, y0 + 2), grey, f"|gradient| {ed.gradient_range[1]:.4g}")
        draw.add_text(imgui.ImVec2(x0 + 3, y0 + h - 15), grey, f"{ed.value_range[0]:.4g}")
        label = f"{ed.value_range[1]:.4g}"
        draw.add_text(imgui.ImVec2(x0 + w - 7 * len(label) - 3, y0 + h - 15), grey, label)

    def _cells_2d(self) -> np.ndarray:
        ed = self.viewer.editor_2d
        if getattr(self, "_cells_key", None) is not ed:
            self._cells_key, self._cells = ed, ed.display_cells()
        return self._cells

    def _canvas_input(self, mapping: CanvasMapping):
        imgui, editor = self.imgui, self.viewer.editor
        mouse = imgui.get_mouse_pos()
        inside = (mapping.x <= mouse.x <= mapping.x + mapping.width
                  and mapping.y <= mouse.y <= mapping.y + mapping.height)
        if imgui.is_item_hovered() and inside:
            if imgui.is_mouse_clicked(0):
                i = editor.pick(mapping, mouse.x, mouse.y)
                if i is None:
                    i = editor.add(*mapping.from_pixel(mouse.x, mouse.y))
                editor.selected = self.dragging = i
            elif imgui.is_mouse_clicked(1):
                i = editor.pick(mapping, mouse.x, mouse.y)
                if i is not None and not editor.delete(i):
                    self.viewer.notify("a transfer function keeps at least two points", error=True)
        if self.dragging is not None:
            # to where the button was released too (the release and the last moves can come in one frame)
            if imgui.is_mouse_pos_valid() and (imgui.is_mouse_dragging(0, 1.0) or imgui.is_mouse_released(0)) \
                    and self.dragging < len(editor.points):
                value, opacity = mapping.from_pixel(mouse.x, mouse.y)
                if (value, opacity) != tuple(editor.points[self.dragging, [0, 4]]) and (
                        imgui.is_mouse_down(0) or imgui.get_mouse_drag_delta(0, 0.0).x or
                        imgui.get_mouse_drag_delta(0, 0.0).y):
                    editor.move(self.dragging, value, opacity)
            if not imgui.is_mouse_down(0):
                self.dragging = None
                self.viewer.end_gesture()

    def _draw_canvas(self, mapping: CanvasMapping, value_range):
        imgui, editor = self.imgui, self.viewer.editor
        draw = imgui.get_window_draw_list()
        x0, y0, w, h = mapping.x, mapping.y, mapping.width, mapping.height
        draw.add_rect_filled(imgui.ImVec2(x0, y0), imgui.ImVec2(x0 + w, y0 + h), _col32(0.1, 0.1, 0.12))
        heights = self._heights_for(value_range)
        bar = w / len(heights)
        grey = _col32(0.35, 0.35, 0.4)
        for i, hgt in enumerate(heights):
            if hgt > 0:
                draw.add_rect_filled(imgui.ImVec2(x0 + i * bar, y0 + h * (1 - hgt)),
                                     imgui.ImVec2(x0 + (i + 1) * bar, y0 + h), grey)
        # the colour bar: the function's colour at each value, display-encoded
        n = 96
        values = np.linspace(value_range[0], value_range[1], n + 1)
        colours = linear_to_srgb(editor.transfer_function().color((values[:-1] + values[1:]) / 2))
        for i in range(n):
            draw.add_rect_filled(imgui.ImVec2(x0 + w * i / n, y0 + h + 2),
                                 imgui.ImVec2(x0 + w * (i + 1) / n + 0.5, y0 + h + COLOUR_BAR_HEIGHT),
                                 _col32(*colours[i]))
        points = [imgui.ImVec2(*mapping.to_pixel(vv, o)) for vv, o in editor.points[:, [0, 4]]]
        ends = [imgui.ImVec2(x0, points[0].y), *points, imgui.ImVec2(x0 + w, points[-1].y)]
        draw.add_polyline(ends, _col32(0.95, 0.95, 0.95), 1.5, 0)
        for i, (p, row) in enumerate(zip(points, editor.points)):
            selected = i == editor.selected
            draw.add_circle_filled(p, 6.0 if selected else 5.0, _col32(*linear_to_srgb(row[1:4])))
            draw.add_circle(p, 6.0 if selected else 5.0, _col32(1, 1, 0) if selected else _col32(1, 1, 1), 0,
                            2.0 if selected else 1.0)
        top = mapping.opacity_max
        draw.add_text(imgui.ImVec2(x0 + 3, y0 + 2), _col32(0.8, 0.8, 0.8), f"opacity {top:g}")
        draw.add_text(imgui.ImVec2(x0 + 3, y0 + h - 15), _col32(0.8, 0.8, 0.8), f"{value_range[0]:.4g}")
        label = f"{value_range[1]:.4g}"
        draw.add_text(imgui.ImVec2(x0 + w - 7 * len(label) - 3, y0 + h - 15), _col32(0.8, 0.8, 0.8), label)

    def _selected_point(self):
        imgui, editor = self.imgui, self.viewer.editor
        i = editor.selected
        if i is None or i >= len(editor.points):
            imgui.text_disabled("no point selected")
            return
        value, opacity = float(editor.points[i, 0]), float(editor.points[i, 4])
        lo, hi = self._value_range()
        changed, value = imgui.drag_float("value", value, (hi - lo) / 1000.0, 0.0, 0.0, "%.5g")
        if changed:
            editor.move(i, value, opacity)
        changed, opacity = imgui.drag_float("opacity", opacity, 0.001, 0.0, float(editor.opacity_limit), "%.4f")
        if changed:
            editor.move(i, float(editor.points[i, 0]), opacity)
        changed, colour = imgui.color_edit3("colour", list(linear_to_srgb(editor.points[i, 1:4])))
        if changed:
            editor.set_color(i, _linear(colour))
        if imgui.button("delete point") and not editor.delete(i):
            self.viewer.notify("a transfer function keeps at least two points", error=True)

    def close(self):
        self.renderer.release()
        self.imgui.destroy_context(self.context)
