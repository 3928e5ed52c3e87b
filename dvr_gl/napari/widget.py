"""The dock widget: render napari's current 3D view with a dvr-gl renderer (docs/napari.md).

The mapping is :mod:`dvr_gl.napari.scene`'s; this is its Qt face: the renderer (those registered whose
declared data kinds and field roles take the layers), the width in pixels (0: the canvas's), the depth in
voxels through which an image layer's brightest value reaches its opacity, the output (a new RGB layer, a file,
an orbit or a time animation as a stack of frames) and a line saying how long the render took, or why it could
not render.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from qtpy import QtWidgets as qt

from ..errors import DvrError
from ..gl.context import create_context
from ..image import write_image
from ..renderers import registry
from .scene import DEPTH_VOXELS, render_animation, render_view, rendered_layers, rendering_note, time_axis

OUTPUTS = ("new layer", "file", "orbit", "time")


def renderers_for(layers) -> list[str]:
    """Registered renderers whose declared data kinds and field roles take napari ``layers`` (image and labels
    layers, as :func:`~dvr_gl.napari.scene.layer_members` makes them: one image layer is grid data, anything
    more several fields), read from the layers' types alone (no voxel is read)."""
    roles = {"label" if type(la).__name__.lower() == "labels" else "scalar" for la in layers}
    kind = "grid" if len(layers) == 1 and roles == {"scalar"} else "fields"
    roles = roles if kind == "fields" else set()
    return registry.renderers_with(lambda p: (p.data_kinds is None or kind in p.data_kinds)
                                   and roles <= set(p.field_roles))


class RenderWidget(qt.QWidget):
    """The dock widget (see the module doc); ``napari_viewer`` is given by napari."""

    def __init__(self, napari_viewer):
        super().__init__()
        self.viewer = napari_viewer
        self._ctx = None
        self.renderer = qt.QComboBox()
        self.width_box = qt.QSpinBox()
        self.width_box.setRange(0, 8192)
        self.width_box.setSpecialValueText("canvas")
        self.width_box.setToolTip("picture width in pixels (0: the canvas's size); the height keeps its aspect")
        self.depth = qt.QDoubleSpinBox()
        self.depth.setRange(0.01, 1e6)
        self.depth.setValue(DEPTH_VOXELS)
        self.depth.setToolTip("voxels through which an image layer's brightest value reaches the layer's opacity")
        self.selected = qt.QCheckBox("selected layers only")
        self.selected.setToolTip("render the selected image and labels layers, not every visible one")
        self.selected.toggled.connect(self.refresh_renderers)
        self.projection = qt.QCheckBox("napari's rendering mode")
        self.projection.setToolTip("one image layer: its rendering as dvr-gl's mode (mip, minip, average, iso at its "
                                   "iso_threshold; attenuated_mip and additive approximated, said in the status "
                                   "line); otherwise emission and absorption")
        self.output = qt.QComboBox()
        self.output.addItems(OUTPUTS)
        self.path = qt.QLineEdit()
        self.path.setPlaceholderText("file (.png, .exr, .tif); frames: name_0000.png ...")
        self.frames = qt.QSpinBox()
        self.frames.setRange(0, 3600)
        self.frames.setSpecialValueText("auto")
        self.frames.setToolTip("frames of an animation (auto: 36 for an orbit, one per step for time)")
        self.button = qt.QPushButton("Render")
        self.button.clicked.connect(self.run)
        self.status = qt.QLabel("")
        self.status.setWordWrap(True)
        form = qt.QFormLayout()
        rows = (("renderer", self.renderer), ("width", self.width_box), ("depth (voxels)", self.depth),
                ("layers", self.selected), ("projection", self.projection), ("output", self.output),
                ("file", self.path), ("frames", self.frames))
        for label, widget in rows:
            form.addRow(label, widget)
        layout = qt.QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(self.button)
        layout.addWidget(self.status)
        layout.addStretch(1)
        self.viewer.layers.events.inserted.connect(self.refresh_renderers)
        self.viewer.layers.events.removed.connect(self.refresh_renderers)
        self.viewer.layers.selection.events.changed.connect(self.refresh_renderers)
        self.refresh_renderers()

    # --- what the controls say ----------------------------------------------------------------------

    def refresh_renderers(self, event=None) -> None:
        """List the renderers that take the rendered layers (keeping the chosen one where it still does)."""
        layers = rendered_layers(self.viewer, self.selected.isChecked())
        names = renderers_for(layers) if layers else registry.names()
        current = self.renderer.currentText()
        self.renderer.blockSignals(True)
        self.renderer.clear()
        self.renderer.addItems(names)
        if current in names:
            self.renderer.setCurrentText(current)
        self.renderer.blockSignals(False)

    def context(self):
        """The widget's GL context, kept so that each program is compiled once; made at the first render once
        napari's window is shown, since a context made before napari's canvas makes its own renders nothing
        after it (measured with Mesa: empty pictures); None before that: each render makes its own."""
        if self._ctx is None and self._window_shown():
            self._ctx = create_context()
        return self._ctx

    def _window_shown(self) -> bool:
        window = getattr(getattr(self.viewer, "window", None), "_qt_window", None)
        return window is not None and window.isVisible()

    def options(self) -> dict:
        """The controls as :func:`~dvr_gl.napari.scene.render_view`'s keywords."""
        name = self.renderer.currentText() or None
        gl = name is None or registry.plugin(name).needs_gl
        return {"renderer": name, "width": self.width_box.value() or None, "depth": self.depth.value(),
                "selected": self.selected.isChecked(), "projection": self.projection.isChecked(),
                "ctx": self.context() if gl else None}

    # --- the outputs --------------------------------------------------------------------------------

    def render_layer(self):
        """Render the view into a new RGB image layer (8-bit sRGB over black), returned."""
        image = render_view(self.viewer, **self.options())
        return self.viewer.add_image(image.srgb8()[..., :3], rgb=True, name=f"dvr-gl {image.scene.renderer.name}",
                                     metadata={"dvr_gl_stats": image.stats})

    def render_file(self, path) -> Path:
        """Render the view into ``path`` (.png/.jpg 8-bit sRGB, .exr/.tif linear float), never replacing a file."""
        return render_view(self.viewer, **self.options()).save(path)

    def render_frames(self, orbit: bool, time_steps: bool, path=None):
        """An orbit and/or time animation (:func:`~dvr_gl.napari.scene.render_animation`) as a new layer of
        frames, written as ``stem_0000.png``... beside ``path`` when given."""
        images = render_animation(self.viewer, orbit, time_steps, self.frames.value() or None, **self.options())
        stack = np.stack([im.srgb8()[..., :3] for im in images])
        if path:
            p = Path(path)
            for i, im in enumerate(images):
                write_image(p.with_name(f"{p.stem}_{i:04d}{p.suffix or '.png'}"), im.composited())
        return self.viewer.add_image(stack, rgb=True, name=f"dvr-gl {'orbit' if orbit else 'time'}")

    def run(self) -> None:
        """The button: the chosen output, its time or the reason it could not render in the status line."""
        start = time.perf_counter()
        choice = self.output.currentText()
        try:
            if choice == "file":
                if not self.path.text():
                    raise DvrError("output file: give a path (.png, .exr, .tif)")
                done = f"wrote {self.render_file(self.path.text())}"
            elif choice == "new layer":
                done = f"added layer {self.render_layer().name!r}"
            else:
                if choice == "time" and time_axis(self.viewer) is None:
                    raise DvrError("no time axis: the layers have no fourth axis with more than one step")
                done = f"added layer {self.render_frames(choice == 'orbit', choice == 'time', self.path.text()).name!r}"
        except (DvrError, OSError) as exc:
            self.status.setText(str(exc))
            return
        note = rendering_note(self.viewer, self.selected.isChecked(), self.projection.isChecked())
        self.status.setText(f"{done} in {time.perf_counter() - start:.2f} s" + (f"; {note}" if note else ""))
