"""The napari plugin on the shared two-channel nucleus: the docs' screenshot and the dock widget's render time.

Opens napari (run it under a display: ``xvfb-run -a -s "-screen 0 1280x1024x24" python benchmarks/napari_picture.py``)
with the nucleus's two channels as image layers (their spacing from the file, through the plugin's reader) and a
labels layer (the confocal channel above a threshold, split into two labels at the nucleus's middle), docks the
dvr-gl widget, renders napari's oblique 3D view with it, and prints the time of the first render (a new GL
context, the shaders compiled) and of the ones after it (median), at the canvas's size, 512 and 256 pixels wide.
Writes ``napari.png`` (the window: the dvr-gl picture as a layer, the widget) and ``napari-canvas.png``
(napari's own rendering of the same view) into ``--out``.  The widget keeps one GL context, as it does in use.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data-dir", type=Path, default=Path("../shared/data"), help="the shared data folder")
    parser.add_argument("--out", type=Path, default=Path("docs/images"), help="folder of the two PNGs")
    parser.add_argument("--repeat", type=int, default=5, help="renders timed after the first (median)")
    return parser.parse_args()


def build(viewer, data_dir: Path):
    import numpy as np

    from dvr_gl import load_field
    from dvr_gl.napari.readers import volume_layer

    nucleus = load_field(data_dir / "microscopy" / "xyzc_16bit__dna_conf_wf.tif")
    names, colormaps = ("confocal", "widefield"), ("green", "magenta")
    for member, name, colormap in zip(nucleus.members, names, colormaps):
        data, attributes, _ = volume_layer(member.field, name)
        hi = float(np.percentile(data, 99.9))
        viewer.add_image(data, **{**attributes, "name": name}, colormap=colormap, blending="additive",
                         contrast_limits=(float(np.percentile(data, 50)), hi), opacity=0.8)
    from scipy import ndimage

    confocal = ndimage.gaussian_filter(np.asarray(nucleus.members[0].field.data, dtype=np.float32), 1.5)
    parts, _ = ndimage.label(confocal > np.percentile(confocal, 96))
    largest = np.argmax(np.bincount(parts.ravel())[1:]) + 1
    labels = (parts == largest).astype(np.uint8)
    labels[:, :, confocal.shape[2] // 2:] *= 2  # two labels: the nucleus's two halves in x
    attributes = volume_layer(nucleus.members[0].field, "mask")[1]
    viewer.add_labels(labels, **{**attributes, "name": "mask"}, opacity=0.05)
    viewer.dims.ndisplay = 3
    viewer.reset_view()
    viewer.camera.angles = (-10.0, 35.0, 120.0)
    viewer.camera.perspective = 20.0


def timed(widget, width, repeat: int) -> tuple[float, float]:
    """Seconds of the first render and the median of ``repeat`` more, at ``width`` pixels (0: the canvas's)."""
    from dvr_gl.napari.scene import render_view

    widget.width_box.setValue(width)
    options = widget.options()
    seconds = []
    for _ in range(repeat + 1):
        start = time.perf_counter()
        render_view(widget.viewer, **options)
        seconds.append(time.perf_counter() - start)
    return seconds[0], statistics.median(seconds[1:])


def main():
    args = parse_args()
    os.environ.setdefault("QT_QPA_PLATFORM", "xcb")
    import napari
    from PIL import Image as PILImage
    from qtpy.QtWidgets import QApplication

    from dvr_gl.napari.scene import view_size
    from dvr_gl.napari.widget import RenderWidget

    viewer = napari.Viewer(show=True)
    viewer.window.resize(1180, 720)
    build(viewer, args.data_dir)
    widget = RenderWidget(viewer)
    viewer.window.add_dock_widget(widget, name="dvr-gl render", area="right")
    QApplication.processEvents()
    args.out.mkdir(parents=True, exist_ok=True)
    PILImage.fromarray(viewer.screenshot(canvas_only=True)[..., :3]).save(args.out / "napari-canvas.png",
                                                                           optimize=True)
    w, h = view_size(viewer)
    print(f"| picture | renderer | first render (s) | median of {args.repeat} after (s) |")
    print("|---|---|---|---|")
    for width in (0, 512, 256):
        first, median = timed(widget, width, args.repeat)
        size = view_size(viewer, width or None)
        print(f"| {size[0]}x{size[1]} | {widget.renderer.currentText()} | {first:.2f} | {median:.2f} |")
    widget.width_box.setValue(0)
    widget.output.setCurrentText("new layer")
    widget.run()
    print(widget.status.text(), f"(canvas {w}x{h})")
    for layer in viewer.layers[:-1]:
        layer.visible = False
    viewer.dims.ndisplay = 2
    viewer.reset_view()
    QApplication.processEvents()
    shot = viewer.screenshot(canvas_only=False, flash=False)[..., :3]
    PILImage.fromarray(shot).save(args.out / "napari.png", optimize=True)
    print(f"wrote {args.out / 'napari.png'} ({shot.shape[1]}x{shot.shape[0]}) and {args.out / 'napari-canvas.png'}")
    viewer.close()


if __name__ == "__main__":
    main()
