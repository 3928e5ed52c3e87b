"""``dvr bench widget``: the notebook widget driven by simulated pointer events, no browser.

For each renderer (default: the GL renderers that take the data), a widget on the scene at SIZE x SIZE: the
time of a full-quality frame; then a left drag of ``--moves`` moves of 4 pixels (after ``--warm-up`` moves that
let the refinement controller measure its levels), each move one event, one frame and that frame's JPEG encoding
(what jupyter_rfb sends while interacting): frames per second while dragging, the median frame and the
level the controller chose most; then the pointer's release, and the time until the full-quality frame is ready
(frames and encodings included).  The browser's side (transfer, decoding) is not in these numbers; on a remote
server the network adds its latency to each frame.
"""

from __future__ import annotations

import contextlib
import io
import statistics
import time
from collections import Counter

from . import tick, volume_keys

COLUMNS = [("renderer", "renderer", ""), ("full_ms", "full frame ms", ".0f"), ("fps", "drag frames/s", ".1f"),
           ("drag_ms", "drag frame ms (median)", ".0f"), ("level", "drag level (most frames)", ""),
           ("settle_s", "release to full image s", ".2f")]


def run(args) -> int:
    from ..renderers import registry
    from ..scene.resolve import load_scene

    volume, what = volume_keys(args.volume, args.volume_size)
    scene = load_scene(None, {"image.width": args.size, "image.height": args.size, **volume})
    kind = scene.field.kind
    names = args.renderer or registry.renderers_with(
        lambda p: p.needs_gl and (p.data_kinds is None or kind in p.data_kinds))
    args.report.text(f"dvr bench widget: {what}, {args.size}x{args.size}, budget {1e3 * args.budget:.0f} ms a frame "
                     f"while dragging; {args.moves} timed moves after {args.warm_up}; kernel side only (render, "
                     f"8-bit conversion, JPEG encoding), no browser")
    rows, notes = [], []
    for name in names:
        refused = registry.refusal(scene.with_renderer(name=name))
        if refused:
            notes.append(f"{name}: left out ({refused})")
            continue
        rows.append(measure(scene.with_renderer(name=name), args))
    args.report.table(rows, COLUMNS, notes)
    return 0


def measure(scene, args) -> dict:
    """One renderer's row (see the module doc)."""
    from jupyter_rfb._utils import array2compressed

    from ..jupyter.canvas import VolumeWidget
    from ..viewer.refinement import FULL, FramePlan

    with contextlib.redirect_stdout(io.StringIO()):
        view = VolumeWidget(scene, budget=args.budget)
    try:
        start = time.perf_counter()
        view._draw(FramePlan(FULL))
        full = time.perf_counter() - start
        centre = args.size / 2

        def send(kind, x):
            view.handle_event({"type": kind, "x": x, "y": centre, "button": 1, "buttons": [1], "modifiers": []})

        def frame():
            pixels = view.get_frame()
            array2compressed(pixels, view.quality)
            tick()

        send("pointer_down", centre)
        times, levels = [], Counter()
        for k in range(args.warm_up + args.moves):
            start = time.perf_counter()
            send("pointer_move", centre + 4 * (k + 1))
            frame()
            if k >= args.warm_up:
                times.append(time.perf_counter() - start)
                level = view.last_plan.level
                levels[f"1/{level.block} res, {level.distance_factor:g}x d" if not level.full else "full"] += 1
        start = time.perf_counter()
        send("pointer_up", centre + 4 * (args.warm_up + args.moves))
        while not view.refined:
            frame()
        settle = time.perf_counter() - start
    finally:
        view.release()
    return {"renderer": scene.renderer.name, "full_ms": 1e3 * full, "fps": len(times) / sum(times),
            "drag_ms": 1e3 * statistics.median(times), "level": levels.most_common(1)[0][0], "settle_s": settle}
