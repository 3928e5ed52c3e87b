"""Key bindings and mouse controls: one table, read by the viewer, its help overlay and the docs.

Keys are named as GLFW names them (``glfw.KEY_<NAME>``); ``shift+`` marks a shifted binding.
"""

from __future__ import annotations

# (key, action, description); Viewer.action (app.py) carries out the actions by name.  The keys 1 to 9
# and 0, then shifted, choose the registered renderers in the registry's order (renderer_keys); these are
# the rest.
SETTING_KEYS = (
    ("C", "next_compositing", "compositing: emission-absorption, isosurface, average, MIP, MinIP"),
    ("K", "next_classification", "classification: post, pre, pre-integrated"),
    ("F", "next_filter", "filter: those of the renderer (nearest, linear, cubic B-spline, Catmull-Rom, Gaussian)"),
    ("L", "toggle_shading", "shading (lighting) on/off"),
    ("G", "toggle_scattering", "single scattering with shadows on/off (replaces shading)"),
    ("COMMA", "light_left", "scattering: turn the first light 15 degrees about the view's up axis (also .)"),
    ("PERIOD", "light_right", ""),
    ("shift+COMMA", "light_down", "scattering: tilt the first light 15 degrees (also >)"),
    ("shift+PERIOD", "light_up", ""),
    ("X", "toggle_clip_plane", "clipping plane on/off: facing the eye through the volume's centre"),
    ("Z", "clip_deeper", "move the clipping plane 5 % of the volume's diagonal away from the eye (shift: back)"),
    ("shift+Z", "clip_back", ""),
    ("J", "toggle_jitter", "jitter on/off (idle: averages jittered passes)"),
    ("RIGHT_BRACKET", "finer", "finer sampling: sample distance or slice spacing / 1.5"),
    ("LEFT_BRACKET", "coarser", "coarser sampling: sample distance or slice spacing x 1.5"),
    ("P", "toggle_projection", "perspective / orthographic"),
    ("SPACE", "toggle_play", "time series: play / pause (one step read at a time)"),
    ("RIGHT", "next_step", "time series: the next step (left arrow: the previous)"),
    ("LEFT", "previous_step", ""),
    ("N", "next_field", "several fields: the transfer-function editor edits the next field's"),
    ("R", "reset_view", "reset the view"),
    ("I", "toggle_pick", "picking on/off: the value, voxel and world position under the resting cursor"),
    ("A", "toggle_annotations", "annotations on/off: colour bar, scale bar, axes (display and 8-bit screenshots)"),
    ("shift+K", "add_keyframe", "camera path: add the view as a keyframe (k-th at k s); S saves the path"),
    ("BACKSPACE", "clear_keyframes", "camera path: clear the keyframes"),
    ("S", "screenshot", "screenshot: image and effective scene (.toml, with a recorded camera path), numbered"),
    ("H", "toggle_hud", "status bar (HUD) on/off"),
    ("TAB", "toggle_panel", "side panel on/off"),
    ("F1", "toggle_help", "this help (also ?)"),
    ("Q", "quit", "quit (also Esc)"),
    ("ESCAPE", "quit", ""),
    ("shift+SLASH", "toggle_help", ""),
)


def renderer_keys() -> tuple:
    """1 to 9, then 0: the first ten registered renderers in their declared order; shift+1 to shift+0 the
    next ten (a renderer installed from another package comes after the built-in ones)."""
    from ..renderers import registry

    return tuple((("shift+" if i > 10 else "") + str(i % 10), f"renderer_{name}",
                  f"renderer: {name} ({plugin.description})")
                 for i, (name, plugin) in enumerate(list(registry.plugins().items())[:20], start=1))


def key_table() -> tuple:
    """Every key binding: ``(key, action, description)``."""
    return renderer_keys() + SETTING_KEYS


MOUSE = (
    ("left drag", "orbit (turn the volume)"),
    ("middle drag, shift + left drag", "pan"),
    ("wheel, right drag", "zoom"),
    ("transfer-function panel", "click: add a point; drag: move it; right-click: delete; "
                                "select it to edit its colour"),
    ("2D transfer-function panel", "click: add a box; drag inside: move it; drag an edge or corner: "
                                   "resize it; right-click or Delete: delete; select it to edit its colour "
                                   "and opacity"),
)


def help_rows() -> list[tuple[str, str]]:
    """The help overlay's rows: ``(key or mouse input, what it does)``; an empty row between the keys and the
    mouse."""
    return [(_label(k), d) for k, _, d in key_table() if d] + [("", "")] + list(MOUSE)


def help_lines() -> list[str]:
    """The help as text lines (the terminal's, without the GUI)."""
    return [(f"{k:>6}  {d}" if len(k) <= 6 else f"{k}: {d}") if k else "" for k, d in help_rows()]


def _label(key: str) -> str:
    return {"RIGHT_BRACKET": "]", "LEFT_BRACKET": "[", "TAB": "Tab", "ESCAPE": "Esc", "COMMA": ",",
            "shift+COMMA": "<", "SPACE": "Space", "RIGHT": "Right", "LEFT": "Left",
            "BACKSPACE": "Backspace"}.get(key, key)
