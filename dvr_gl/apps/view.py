"""Explore a scene (a TOML file, a volume file, or the built-in demo) in a window.

Orbit with the left mouse button, pan with the middle one (or shift + left), zoom with the
wheel; switch renderers and settings with keys or the side panel; edit the transfer function in
the panel; S writes a screenshot and the scene that reproduces it with ``dvr render``; F1 lists
the keys.  The scene flags are those of ``dvr render``.  While you drag, frames are rendered at
reduced resolution and sampling to hold the frame-time budget; when you stop, the view refines
to full quality (with jitter, by averaging passes).  A time series plays and pauses with Space and
steps with the arrow keys, read one step at a time; with several fields, N chooses the field whose
transfer function the editor edits.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dvr_gl.errors import DvrError
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import read_scene_dict

from . import render as render_cmd
from .fields import timed_files

HELP = "explore a scene, a volume file or the demo in a window (orbit, renderers, transfer-function editor)"

# What `dvr render`'s parser has and the viewer uses: the scene and its overrides.  Its other
# flags (output, frames, ...) are hidden here and refused if given.
_SCENE_DESTS = {"scene", "fields", "demo", "volume", "size", "background", "set", "help", *render_cmd._SCENE_KEYS}


def _is_scene_dest(dest: str) -> bool:
    return dest in _SCENE_DESTS or dest.startswith(render_cmd.SETTING_DEST)
DEFAULT_SIZE = "512x512"  # the render area of the demo and a volume file (dvr render's default is 256x256)


def add_arguments(p: argparse.ArgumentParser):
    render_cmd.add_arguments(p)  # the same scene and override flags as `dvr render`
    for action in p._actions:
        if not _is_scene_dest(action.dest) and action.dest != "debug":
            action.required, action.help = False, argparse.SUPPRESS
    v = p.add_argument_group("viewer")
    v.add_argument("--budget", type=float, default=100.0, metavar="MS",
                   help="frame-time budget while dragging, milliseconds (default 100)")
    v.add_argument("--passes", type=int, default=8, metavar="N",
                   help="jittered passes averaged when idle, with jitter on (default 8)")
    v.add_argument("--screenshot-dir", default=".", metavar="DIR", help="where S writes screenshots (default .)")
    v.add_argument("--screenshot-format", default="png", choices=("png", "exr", "tif"),
                   help="screenshot image format: png (8-bit sRGB) or exr/tif (linear float)")
    v.add_argument("--no-gui", action="store_true", help="no panels or HUD (keys only; HUD in the title)")
    v.add_argument("--frame-log", metavar="FILE", help="write every frame and event as JSON lines")
    v.add_argument("--benchmark", type=float, metavar="SECONDS",
                   help="orbit automatically for SECONDS, refine, print the frame times and exit")


def _refuse_render_only(args, parser_defaults: dict):
    for dest, default in parser_defaults.items():
        if not _is_scene_dest(dest) and getattr(args, dest, default) != default:
            raise DvrError(f"--{dest.replace('_', '-')} belongs to dvr render, not dvr view")


def _rescale_intercept(args, overrides: dict) -> float:
    """For the CT presets in the panel: the intercept given by flag, --set or the scene file."""
    if "transfer_function.rescale_intercept" in overrides:
        return float(overrides["transfer_function.rescale_intercept"])
    if args.scene:
        return float(read_scene_dict(Path(args.scene)).get("transfer_function", {}).get("rescale_intercept", 0.0))
    return 0.0


def run(args) -> int:
    from dvr_gl.viewer.app import ViewerOptions, check_display, run_viewer

    # the sandbox's and Dask's flags too: parsed (the parser is render's) but not applied by the viewer, so
    # refused rather than silently ignored (a scene one did not write would be read unconfined)
    defaults = {"output": None, "overwrite": False, "save_scene": None, "frames": None,
                "fps": render_cmd.DEFAULT_FPS, "sandbox": None, "max_seconds": None, "max_memory": None,
                "dask": None, "compositing_method": "direct_send", "animate": None}
    _refuse_render_only(args, defaults)
    render_cmd.positional_volume(args)
    render_cmd.check_data_given(args, "view")
    if args.passes < 1 or args.budget <= 0:
        raise DvrError("--passes must be at least 1 and --budget positive")
    check_display()  # before loading a volume that may be large
    # A scene file keeps its image size, drawn scaled to fit; the demo and a volume file get a
    # DEFAULT_SIZE render area that follows the window (docs/viewer.md)
    fit = bool(args.scene) and not args.size
    if not args.scene and not args.size:
        args.size = DEFAULT_SIZE
    source = render_cmd.source_of(args, "view")
    overrides = source.overrides
    scene = source.load()
    series = timed_files(source, scene, required=False)  # a time series: the viewer reads one step at a time
    registry.check(scene)  # the renderer's one-line refusal, before a window opens
    shots = Path(args.screenshot_dir)
    if not shots.is_dir():
        raise DvrError(f"--screenshot-dir {shots}: not a folder; create it first")
    options = ViewerOptions(budget_ms=args.budget, passes=args.passes, screenshot_dir=shots,
                            screenshot_format="." + args.screenshot_format, gui=not args.no_gui,
                            frame_log=Path(args.frame_log) if args.frame_log else None,
                            rescale_intercept=_rescale_intercept(args, overrides), benchmark=args.benchmark,
                            fit=fit, time_steps=series[0] if series else 1, time_step=args.time or 0,
                            read_step=lambda k: source.load(k, scene.renderer))
    return run_viewer(scene, options)
